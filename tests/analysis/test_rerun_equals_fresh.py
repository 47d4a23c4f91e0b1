"""Issue 56's rule, as a property: a result is a function of everything it depends on. For
any settings of the analysis (its options, the environment's limits, rig files placed
anywhere in the tree, the paths given), a re-run into a results folder whose cache holds
a run with any other settings writes exactly the bytes a run with ``--no-reuse`` writes.

Hypothesis draws both runs' settings over the whole space (a few examples: each is three
runs of two tiny sessions); a setting the cache did not key on shows as a stale table. The
static figures (``--figures``) are left out: they cost a second a run, and are reused by
the digest of what they show (analysis.report.figures.cache, tests/analysis/test_drawer.py).
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import get_args

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from analysis.batch.cache import CACHE_FOLDER
from analysis.cli import app
from tests.analysis.test_session_cache import PLACING
from twopose.values.choices import CombineRule
from twopose.values.environment import ENVIRONMENT

runner = CliRunner()
#: Where a rig file may lie: the tree's root, a session's folder, a folder between.
RIG_PLACES = ("", "a", "b", "b/c")
#: What a run may be given: the tree, its folders, a file and a folder.
GIVEN = (("",), ("a", "b"), ("a/point.mcap", "b/c"), ("b",))


#: Each setting a run has, and what it may be: an option (its arguments), a limit in the
#: environment (None: unset), the rig files (by folder: their placing sigma), the paths.
DIMENSIONS: dict[str, st.SearchStrategy[object]] = {
    "combine": st.sampled_from(get_args(CombineRule)).map(lambda rule: ["--combine", rule]),
    "parallax": st.sampled_from(["2.0", "1.5", "40"]).map(lambda deg: ["--min-parallax", deg]),
    "sigma0": st.sampled_from([["--sigma0"], ["--no-sigma0"]]),
    "warned": st.sampled_from([[], ["--include-warned"]]),
    "loo": st.sampled_from(["none", "loo"]).map(lambda mode: ["--rig-calibration", mode]),
    "scene": st.sampled_from([["--scene"], ["--no-scene"]]),
    **{s.name: st.sampled_from([None, s.example]) for s in ENVIRONMENT if s.shapes_results},
    "rigs": st.dictionaries(st.sampled_from(RIG_PLACES), st.sampled_from(["0.2", "0.3"])),
    "given": st.sampled_from(GIVEN),
}
Setting = dict[str, object]


@st.composite
def _runs(draw: st.DrawFn) -> tuple[Setting, Setting]:
    """Two runs' settings: any, and the same with one or two settings drawn again (so that
    the second run can reuse the first's analyses, and a setting the cache does not know
    of shows)."""
    before = {name: draw(values) for name, values in DIMENSIONS.items()}
    changed = draw(st.sets(st.sampled_from(list(DIMENSIONS)), min_size=1, max_size=2))
    return before, {**before, **{name: draw(DIMENSIONS[name]) for name in changed}}


def _arrange(tree: Path, setting: Setting) -> None:
    """The rig files of ``setting`` in ``tree``, and no other."""
    for place in RIG_PLACES:
        (tree / place / "rig.toml").unlink(missing_ok=True)
    rigs = setting["rigs"]
    assert isinstance(rigs, dict)
    for place, sigma in rigs.items():
        (tree / place / "rig.toml").write_text(PLACING.replace("0.2", sigma))


def _run(tree: Path, out: Path, setting: Setting, *extra: str) -> int:
    env = {s.name: setting[s.name] for s in ENVIRONMENT if s.name in setting}
    given = setting["given"]
    assert isinstance(given, tuple)
    args = ["run", *(str(tree / g) for g in given), "--out", str(out), *extra]
    for name in DIMENSIONS:
        if isinstance(setting[name], list):  # an option's arguments
            args += setting[name]  # type: ignore[arg-type]
    return runner.invoke(app, args, env=env).exit_code  # type: ignore[arg-type]


def _written(out: Path) -> dict[str, bytes]:
    """Every file of the run's results (the cache apart: what it holds is keyed)."""
    if not out.is_dir():
        return {}
    return {
        str(p.relative_to(out)): p.read_bytes()
        for p in sorted(out.rglob("*"))
        if p.is_file() and CACHE_FOLDER not in p.relative_to(out).parts
    }


@pytest.fixture(scope="module")
def tree(tmp_path_factory: pytest.TempPathFactory, point_session: Path, line_session: Path) -> Path:
    """Two tiny sessions in a tree: ``a/point.mcap`` and ``b/c/line.mcap``."""
    root = tmp_path_factory.mktemp("tree")
    (root / "a").mkdir()
    (root / "b" / "c").mkdir(parents=True)
    shutil.copy(point_session, root / "a" / "point.mcap")
    shutil.copy(line_session, root / "b" / "c" / "line.mcap")
    return root


#: A run's settings as a user gives them most (the tree, the defaults, no rig file, no limit).
PLAIN: Setting = {
    "combine": ["--combine", "mean"], "parallax": ["--min-parallax", "2.0"],
    "sigma0": ["--sigma0"], "warned": [], "loo": ["--rig-calibration", "none"],
    "scene": ["--no-scene"], "rigs": {}, "given": ("",),
    **{s.name: None for s in ENVIRONMENT if s.shapes_results},
}  # fmt: skip


# Slow: three runs of two tiny sessions an example, three examples (about 5 s of CPU).
@pytest.mark.slow
@settings(
    max_examples=2, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(runs=_runs())
@example(runs=({**PLAIN, "TWOPOSE_MAX_IMAGE_MPIX": "0.1"}, PLAIN))  # issue 56's finding
def test_a_rerun_writes_what_a_fresh_run_writes(
    tree: Path, tmp_path_factory: pytest.TempPathFactory, runs: tuple[Setting, Setting]
) -> None:
    before, now = runs
    out = tmp_path_factory.mktemp("out") / "results"
    _arrange(tree, before)
    _run(tree, out, before)
    _arrange(tree, now)
    code = _run(tree, out, now)
    reused = _written(out)
    assert _run(tree, out, now, "--no-reuse") == code
    fresh = _written(out)
    assert reused.keys() == fresh.keys()
    stale = [name for name in fresh if reused[name] != fresh[name]]
    assert not stale, f"a re-run after {before} wrote other bytes than a fresh run: {stale}"
