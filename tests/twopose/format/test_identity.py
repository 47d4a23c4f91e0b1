"""twopose.format.identity: what a session, a part and a strand are, from the files alone,
whatever their names, folders, copies and order."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from recorder.recover import recover_session
from tests.lab import continue_session, kill_midway, record
from twopose.format.identity import (
    Resolution,
    file_digest,
    identify_file,
    path_labels,
    resolve_session_files,
)
from twopose.format.reader import find_sessions


def _resolve(*paths: Path) -> Resolution:
    return resolve_session_files([identify_file(p) for p in paths])


def test_labels_are_the_shortest_tails_that_tell_paths_apart() -> None:
    labels = path_labels(["lab/a/session.mcap", "lab/b/session.mcap", "x/y/t.mcap", "/abs/u.mcap"])
    assert labels == {
        "lab/a/session.mcap": "a/session.mcap",
        "lab/b/session.mcap": "b/session.mcap",
        "x/y/t.mcap": "t.mcap",
        "/abs/u.mcap": "u.mcap",
    }
    deep = path_labels(["p/a/s.mcap", "q/a/s.mcap"])
    assert deep == {"p/a/s.mcap": "p/a/s.mcap", "q/a/s.mcap": "q/a/s.mcap"}


@settings(max_examples=60, deadline=None)
@given(st.lists(st.lists(st.sampled_from("abc"), min_size=1, max_size=4), max_size=6))
def test_labels_are_distinct_and_tails_of_their_paths(parts: list[list[str]]) -> None:
    paths = list(dict.fromkeys("/".join([*p, "s.mcap"]) for p in parts))
    labels = path_labels(paths)
    assert len(set(labels.values())) == len(paths)
    assert all(p.endswith(labels[p]) for p in paths)


def test_a_recovered_copy_and_its_interrupted_original_are_one_part(tmp_path: Path) -> None:
    original = tmp_path / "visit.mcap"
    record(original, 3)
    kill_midway(original)
    fixed = tmp_path / "visit_fixed.mcap"
    recover_session(original, fixed)
    broken = identify_file(original)
    assert not broken.readable
    assert broken.info is not None  # known by its opening entry
    assert broken.part_key == identify_file(fixed).part_key
    for order in ((original, fixed), (fixed, original)):
        resolved = _resolve(*order)
        assert [s.head for s in resolved.strands] == [str(fixed)]
        assert resolved.others == ((str(original), str(fixed), resolved.others[0][2]),)
        assert "interrupted" in resolved.others[0][2]


def test_two_continuations_of_one_part_are_a_fork_of_two_branches(tmp_path: Path) -> None:
    s = tmp_path / "S.mcap"
    record(s, 2)
    continue_session(s, tmp_path / "S2.mcap", 1)
    continue_session(s, tmp_path / "S3.mcap", 1)  # another laptop, beside it: branch B
    continue_session(tmp_path / "S2.mcap", tmp_path / "S4.mcap", 1)
    files = [tmp_path / n for n in ("S.mcap", "S2.mcap", "S3.mcap", "S4.mcap")]
    for order in (files, files[::-1]):
        resolved = _resolve(*order)
        strands = {s.head: s for s in resolved.strands}
        assert set(strands) == {str(s), str(tmp_path / "S3.mcap")}
        trunk = strands[str(s)]
        assert trunk.later == (str(tmp_path / "S2.mcap"), str(tmp_path / "S4.mcap"))
        assert [p.branch for p in trunk.parts] == ["", "A", "A"]
        assert strands[str(tmp_path / "S3.mcap")].branch == "B"
        assert len(resolved.forks) == 1
        assert "branch B" in resolved.forks[0]


def test_a_continuation_of_a_continuation_joins_it_without_the_first_part(tmp_path: Path) -> None:
    first, b, d = tmp_path / "visit.mcap", tmp_path / "visit_b.mcap", tmp_path / "visit_d.mcap"
    record(first, 2)
    continue_session(first, b, 1)
    continue_session(b, d, 1)
    resolved = _resolve(d, b)
    assert [(s.head, s.later) for s in resolved.strands] == [(str(b), (str(d),))]
    said = " ".join(resolved.notes)
    assert "visit.mcap is not among the inputs" in said
    assert f"{d}: continues {b} after trial 3; one session with {b}" in said


def test_a_renamed_copy_is_the_same_part_and_another_session_is_not(tmp_path: Path) -> None:
    a, renamed, other = tmp_path / "a.mcap", tmp_path / "renamed.mcap", tmp_path / "o.mcap"
    record(a, 1)
    shutil.copy(a, renamed)
    record(other, 1)
    assert file_digest(a) == file_digest(renamed)
    assert identify_file(a).part_key == identify_file(renamed).part_key
    assert identify_file(a).part_key != identify_file(other).part_key
    assert identify_file(a).session_id != identify_file(other).session_id


def test_folders_are_searched_through_links_for_mcap_in_any_case(tmp_path: Path) -> None:
    lab, elsewhere = tmp_path / "lab", tmp_path / "elsewhere"
    lab.mkdir()
    elsewhere.mkdir()
    record(lab / "upper.MCAP", 1)
    record(elsewhere / "far.mcap", 1)
    (lab / "linked").symlink_to(elsewhere)
    (elsewhere / "back").symlink_to(lab)  # a cycle: lab/linked/back is lab again
    (lab / "notes.txt").write_text("not a session")
    found = find_sessions([lab])
    assert sorted(p.name for p in found) == ["far.mcap", "upper.MCAP"]
    every = find_sessions([lab], unique=False)
    assert len({os.path.realpath(p) for p in every}) == 2  # each real file, the cycle ended


@pytest.mark.parametrize("units", ["in", "mm"])
def test_a_session_id_is_the_recorded_one_or_the_content_hash(tmp_path: Path, units: str) -> None:
    path = tmp_path / "s.mcap"
    info = record(path, 1, units=units)
    assert identify_file(path).session_id == info.session_id
    assert identify_file(path).part_id == info.part_id


def test_files_without_ids_are_told_apart_by_their_first_frame(tmp_path: Path) -> None:
    """Issue 56: a file with no ids is known by what opens it, its cut copy too; two files
    another writer made with the same opening (no ids, no creation time, the clock at 0)
    but other frames are two sessions, never one kept for the other."""
    import numpy as np

    from tests.helpers import write_accepted_capture
    from tests.lab import CAMERA
    from twopose.format.entries import PoseEntry, SessionInfo
    from twopose.format.writer import SessionWriter
    from twopose.methods.specs import Method
    from twopose.values.units import Units

    def written(path: Path, grey: int) -> Path:
        info = SessionInfo(method=Method.POINT, units=Units.IN, camera_ids=("cam0",))
        with SessionWriter(path, info, [CAMERA], start_ns=0) as w:
            frame = w.encode_image(np.full((48, 64, 3), grey, np.uint8))
            for pose in (1, 2):
                entry = PoseEntry(trial=1, pose=pose, camera_id="cam0", t_grid=(pose, 0, 0))
                write_accepted_capture(w, entry, [frame, frame], 10 * pose)
        return path

    a, b = written(tmp_path / "a.mcap", 100), written(tmp_path / "b.mcap", 200)
    cut = tmp_path / "a_cut.mcap"
    cut.write_bytes(a.read_bytes()[: int(a.stat().st_size * 0.8)])
    files = [identify_file(p) for p in (a, b, cut)]
    assert [f.info is not None and f.info.session_id for f in files] == [None, None, None]
    assert not files[2].readable
    assert files[0].part_key == files[2].part_key != files[1].part_key
    assert files[0].session_id != files[1].session_id
    resolved = _resolve(a, b, cut)
    assert [s.head for s in resolved.strands] == [str(a), str(b)]
    assert [(p, kept) for p, kept, _ in resolved.others] == [(str(cut), str(a))]
