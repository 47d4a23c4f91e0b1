"""Outputs never replace inputs (issue 22): every output path (``run --out``, ``--junit``
on run and check, ``rig --out``, ``compare --out``) is refused, with exit 3 and nothing
touched, when it is or lies inside what the command reads, or is anything but a regular
file or a new name (a FIFO, a device, a folder where a file is wanted); and one atomic
writer, synced, writes every file."""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import stat
from collections.abc import Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

from analysis.batch.outputs import write_atomically
from analysis.cli import app
from twopose.errors import EXIT_ERROR, InputValueError

runner = CliRunner()
REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def run_dir(
    tmp_path_factory: pytest.TempPathFactory, point_session: Path, ground_session: Path
) -> Path:
    out = tmp_path_factory.mktemp("guard") / "run"
    args = ["run", str(point_session), str(ground_session), "--out", str(out), "--no-scene"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    return out


def _snapshot(path: Path) -> dict[str, tuple[int, str]]:
    """Every file below ``path`` (or ``path`` itself): its mode and content hash."""
    files = sorted(path.rglob("*")) if path.is_dir() else [path]
    return {
        str(f.relative_to(path) if path.is_dir() else f): (
            f.lstat().st_mode,
            hashlib.sha256(f.read_bytes()).hexdigest() if f.is_file() else "",
        )
        for f in files
    }


def _refused(args: list[str], *words: str) -> str:
    result = runner.invoke(app, args)
    assert result.exit_code == EXIT_ERROR, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit)
    assert "Traceback" not in result.output
    for word in words:
        assert word in result.output
    return result.output


@pytest.fixture
def session(tmp_path: Path, point_session: Path) -> Path:
    copy = tmp_path / "s.mcap"
    shutil.copy(point_session, copy)
    return copy


@pytest.fixture
def a_run(tmp_path: Path, run_dir: Path) -> Path:
    copy = tmp_path / "A"
    shutil.copytree(run_dir, copy)
    return copy


# -- What we saw: output options destroy inputs -----------------------------------------


@pytest.mark.parametrize("where", [".", "cmp", "figures/deeper"])
def test_compare_out_at_or_inside_a_run_is_refused(a_run: Path, run_dir: Path, where: str) -> None:
    """Before: ``compare A B --out A`` deleted A's trials.csv, summary.csv, report, figures."""
    before = _snapshot(a_run)
    out = a_run / where
    _refused(["compare", str(a_run), str(run_dir), "--out", str(out)], "run folder", "--out")
    _refused(["compare", str(run_dir), str(a_run), "--out", str(out)], "being read")
    assert _snapshot(a_run) == before


def test_rig_out_at_a_session_is_refused(tmp_path: Path, session: Path) -> None:
    """Before: ``rig S.mcap --out S.mcap`` replaced the recording with TOML (exit 0)."""
    before = _snapshot(session)
    _refused(["rig", str(session), "--out", str(session)], "is the input")
    link = tmp_path / "link.toml"
    link.symlink_to(session)
    _refused(["rig", str(session), "--out", str(link)], "is the input")
    hard = tmp_path / "hard.toml"
    os.link(session, hard)
    _refused(["rig", str(session), "--out", str(hard)], "is the input")
    other = tmp_path / "sub" / ".." / session.name  # another spelling
    (tmp_path / "sub").mkdir()
    _refused(["rig", str(session), "--out", str(other)], "is the input")
    assert _snapshot(session) == before


def test_run_junit_at_a_session_is_refused_before_the_run(tmp_path: Path, session: Path) -> None:
    """Before: ``run S.mcap --junit S.mcap`` replaced the recording with XML."""
    before = _snapshot(session)
    out = tmp_path / "results"
    _refused(["run", str(session), "--out", str(out), "--junit", str(session)], "is the input")
    _refused(["run", str(tmp_path), "--out", str(out), "--junit", str(session)], "is the input")
    assert _snapshot(session) == before
    assert not out.exists()  # nothing analysed, nothing written


def test_run_out_at_or_holding_a_session_is_refused(tmp_path: Path, session: Path) -> None:
    before = _snapshot(session)
    _refused(["run", str(session), "--out", str(session)], "is a file")
    _refused(["run", str(session), "--out", str(tmp_path)], "holds the input")
    assert _snapshot(session) == before


def test_run_junit_in_its_own_out_must_not_replace_a_result(tmp_path: Path, session: Path) -> None:
    out = tmp_path / "results"
    _refused(["run", str(session), "--out", str(out), "--junit", str(out / "summary.csv")], ".xml")
    _refused(["run", str(session), "--out", str(out), "--junit", str(out)], "results go to")
    result = runner.invoke(
        app, ["run", str(session), "--out", str(out), "--no-scene", "--junit", str(out / "r.xml")]
    )
    assert result.exit_code == 0, result.output  # the documented place is fine
    assert (out / "r.xml").read_text().startswith("<?xml")


@pytest.mark.parametrize("name", ["summary.csv", "check.xml", "sub/check.xml"])
@pytest.mark.parametrize("side", ["results", "baseline"])
def test_check_junit_inside_a_run_being_read_is_refused(
    a_run: Path, run_dir: Path, tmp_path: Path, name: str, side: str
) -> None:
    """Before: ``check --junit RUN/summary.csv`` overwrote the summary it had just read."""
    before = _snapshot(a_run)
    results, baseline = (a_run, run_dir) if side == "results" else (run_dir, a_run)
    junit = a_run / name
    _refused(
        ["check", str(results), "--baseline", str(baseline), "--junit", str(junit)], "being read"
    )
    assert _snapshot(a_run) == before


def test_check_junit_at_the_tolerance_file_is_refused(run_dir: Path, tmp_path: Path) -> None:
    tolerance = tmp_path / "tolerance.toml"
    tolerance.write_text("[rmse]\nrelative = 0.2\n")
    args = ["check", str(run_dir), "--baseline", str(run_dir), "--tolerance", str(tolerance)]
    _refused([*args, "--junit", str(tolerance)], "is the input")
    assert tolerance.read_text() == "[rmse]\nrelative = 0.2\n"
    result = runner.invoke(app, [*args, "--junit", str(tmp_path / "reports" / "check.xml")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "reports" / "check.xml").is_file()


@pytest.fixture
def device(tmp_path: Path) -> Iterator[Path]:
    """A character device like /dev/null: made here as root (where a rename could replace
    it), else /dev/null itself (which a user cannot replace, but which is refused alike)."""
    if os.geteuid() == 0:
        node = tmp_path / "null"
        os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 3))
        yield node
    else:
        yield Path("/dev/null")


def _commands(run_dir: Path, session: Path, target: Path, tmp_path: Path) -> list[list[str]]:
    return [
        ["run", str(session), "--out", str(tmp_path / "o"), "--junit", str(target)],
        ["check", str(run_dir), "--baseline", str(run_dir), "--junit", str(target)],
        ["rig", str(session), "--out", str(target)],
    ]


def test_a_device_as_an_output_file_is_refused_and_stays_a_device(
    run_dir: Path, session: Path, tmp_path: Path, device: Path
) -> None:
    """Before: as root, ``--junit /dev/null`` replaced /dev/null with a regular file."""
    rdev = device.stat().st_rdev
    for args in _commands(run_dir, session, device, tmp_path):
        _refused(args, "not a regular file")
        assert stat.S_ISCHR(device.stat().st_mode)
        assert device.stat().st_rdev == rdev
    assert not (tmp_path / "o").exists()
    _refused(["compare", str(run_dir), str(run_dir), "--out", str(device)], "not a folder")
    assert stat.S_ISCHR(device.stat().st_mode)


def test_dev_null_is_refused_and_left_alone(run_dir: Path) -> None:
    null = os.stat("/dev/null")
    _refused(
        ["check", str(run_dir), "--baseline", str(run_dir), "--junit", "/dev/null"],
        "not a regular file",
    )
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    assert os.stat("/dev/null").st_ino == null.st_ino


def test_a_fifo_as_an_output_file_is_refused_and_stays_a_fifo(
    run_dir: Path, session: Path, tmp_path: Path
) -> None:
    """Before: ``--junit FIFO`` replaced the FIFO (a reader waiting on it got nothing)."""
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    for args in _commands(run_dir, session, fifo, tmp_path):
        _refused(args, "not a regular file")
        assert stat.S_ISFIFO(fifo.lstat().st_mode)


def test_a_folder_where_a_file_is_wanted_is_refused(
    run_dir: Path, session: Path, tmp_path: Path
) -> None:
    folder = tmp_path / "folder"
    folder.mkdir()
    (folder / "keep.txt").write_text("keep")
    for args in _commands(run_dir, session, folder, tmp_path):
        _refused(args, "is a folder")
    assert (folder / "keep.txt").read_text() == "keep"
    blocker = tmp_path / "file"
    blocker.write_text("x")
    _refused(["rig", str(session), "--out", str(blocker / "rig.toml")], "is not a folder")


# -- One atomic writer ------------------------------------------------------------------


def test_one_atomic_writer_renames_files_into_place() -> None:
    """No module but twopose/atomic_write.py renames a temporary file into place: every
    other writer, the analyst's and the operator's, goes through
    :func:`twopose.atomic_write.replacing`. The run's transaction (analysis/batch/outputs.py)
    alone moves its staged, already synced files into --out."""
    pattern = re.compile(r"\bos\.(replace|rename)\(|\.rename\(|\.replace\(\s*(tmp|partial)")
    offenders = [
        str(path.relative_to(REPO))
        for folder in ("analysis", "recorder", "twopose", "benchmarks", "sessions")
        for path in (REPO / folder).rglob("*.py")
        if pattern.search(path.read_text(encoding="utf-8"))
    ]
    assert sorted(offenders) == ["analysis/batch/outputs.py", "twopose/atomic_write.py"], (
        "write through twopose.atomic_write.replacing (synced, renamed, folder synced), not a "
        "rename of your own"
    )


def test_the_writer_syncs_the_file_before_and_the_folder_after_the_rename(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    events: list[str] = []
    real_fsync, real_replace = os.fsync, os.replace

    def fsync(fd: int) -> None:
        events.append("fsync folder" if stat.S_ISDIR(os.fstat(fd).st_mode) else "fsync file")
        real_fsync(fd)

    def replace(src: str | Path, dst: str | Path) -> None:
        events.append("rename")
        real_replace(src, dst)

    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(os, "replace", replace)
    target = tmp_path / "out.xml"
    target.write_text("old")
    write_atomically(target, b"new")
    assert target.read_bytes() == b"new"
    assert events == ["fsync file", "rename", "fsync folder"]
    assert [p.name for p in tmp_path.iterdir()] == ["out.xml"]


def test_the_writer_leaves_no_partial_file_and_the_old_file_on_failure(tmp_path: Path) -> None:
    from analysis.batch.outputs import replacing

    target = tmp_path / "out.csv"
    target.write_text("old")

    def fail_halfway() -> None:
        with replacing(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("the analysis failed")

    with pytest.raises(RuntimeError):
        fail_halfway()
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


def test_the_writer_itself_refuses_a_fifo_or_a_folder(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    with pytest.raises(InputValueError, match="not a regular file"):
        write_atomically(fifo, b"x")
    assert stat.S_ISFIFO(fifo.lstat().st_mode)
    with pytest.raises(InputValueError, match="is a folder"):
        write_atomically(tmp_path, b"x")
    link = tmp_path / "link"
    link.symlink_to(fifo)  # a symlink is replaced itself, never written through
    write_atomically(link, b"x")
    assert link.read_bytes() == b"x"
    assert stat.S_ISFIFO(fifo.lstat().st_mode)


def test_results_mcap_is_written_by_the_one_writer(
    tmp_path: Path, session: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import twopose.atomic_write

    written: list[str] = []
    real = twopose.atomic_write.replacing

    def spy(path: Path) -> object:
        written.append(path.name)
        return real(path)

    monkeypatch.setattr(twopose.atomic_write, "replacing", spy)
    result = runner.invoke(app, ["run", str(session), "--out", str(tmp_path / "o")])
    assert result.exit_code == 0, result.output
    assert "results_00_s.mcap" in written
    assert {"trials.csv", "summary.csv", "report.html"} <= set(written)
    assert not list((tmp_path / "o").glob(".*.partial"))
