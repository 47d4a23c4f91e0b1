"""A rig file has a scope (issue 56, item 4): a ``rig.toml`` applies to the sessions in its
folder and below, wherever the command line starts (the nearest up the tree wins); each
session's rows say which file it used; two rigs on two folders each analyse their own; the
session cache keys each session on its own rig; ``--rig`` is one file for all, said.

A lab's tree of tiny sessions (tests/lab.py: real files, nothing detected, so each trial is
a row whatever happens), rig files at several depths."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import analysis
from analysis.batch.inputs import resolve_inputs
from analysis.batch.noise_pass import by_rig_file, operator_priors_of
from analysis.cli import app
from analysis.results import AnalysisOptions
from analysis.rig.scope import RIG_BESIDE, RigScope, RigUse, nearest_rig, rig_scope
from tests.analysis.rig_helpers import runner
from tests.lab import CAMERA, continue_session, record
from twopose.errors import InputValueError
from twopose.uncertainty.operator_pool import SessionNoise, operator_priors

#: A rig for the lab's camera (64x48, f 52.5), in inches, with a placing sigma.
RIG = (
    'format = 2\n[rig]\nunits = "in"\ncamera_offset = [{x}, 0, 0]\n\n'
    "[[camera]]\nwidth = 64\nheight = 48\nfx = 52.5\nfy = 52.5\ncx = 32.0\ncy = 24.0\n\n"
    '[placing]\nsigma = 0.1\nmeasured_by = "board.mcap"\n'
)


@pytest.fixture
def lab(tmp_path: Path) -> Path:
    """withrig/{a.mcap, rig.toml}, norig/b.mcap, riglab/withrig/{a.mcap, rig.toml},
    riglab/deep/day1/{c.mcap, rig.toml}, riglab/deep/d.mcap: rig files at three depths."""
    for rel in ("withrig/a", "norig/b", "riglab/withrig/a", "riglab/deep/day1/c", "riglab/deep/d"):
        path = tmp_path / f"{rel}.mcap"
        path.parent.mkdir(parents=True, exist_ok=True)
        record(path, 1)
    for rel, x in (("withrig", 0.1), ("riglab/withrig", 0.1), ("riglab/deep/day1", 0.2)):
        (tmp_path / rel / RIG_BESIDE).write_text(RIG.format(x=x))
    return tmp_path


def _rigs(out: Path) -> dict[str, str]:
    summary = pd.read_csv(out / "summary.csv", keep_default_na=False)
    trials = pd.read_csv(out / "trials.csv", keep_default_na=False)
    by_trial = dict(zip(trials["session"], trials["rig_file"], strict=True))
    by_row = dict(zip(summary["session"], summary["rig_file"], strict=True))
    assert by_trial == by_row  # the session's rows agree
    return {s: str(Path(r)) if r else "" for s, r in by_row.items()}


def _run(where: Path, *args: str) -> tuple[int, str]:
    """``twopose-analyze run`` from the folder ``where`` (paths relative to it)."""
    cwd = os.getcwd()
    os.chdir(where)
    try:
        result = runner.invoke(app, ["run", *args, "--no-scene"])
    finally:
        os.chdir(cwd)
    return result.exit_code, result.output


def test_a_rig_file_applies_to_its_folder_and_below_wherever_the_command_starts(
    lab: Path,
) -> None:
    # Two folders on one command line: withrig's rig never reaches norig's session.
    code, said = _run(lab, "withrig", "norig", "--out", "o1")
    assert code == 0, said
    assert _rigs(lab / "o1") == {"withrig/a.mcap": "withrig/rig.toml", "norig/b.mcap": ""}
    assert "withrig/rig.toml (found up the tree: its folder and below" in said
    assert "1 session(s) under no rig file" in said
    # --rig: one file for every session, the analyst's choice; --no-rig: none.
    riglab = resolve_inputs([lab / "riglab"])
    given = rig_scope(riglab, lab / "withrig" / RIG_BESIDE)
    assert {u.path for u in given.by_session.values() if u} == {str(lab / "withrig" / RIG_BESIDE)}
    assert len(given.by_session) == 3
    assert all(u is not None and u.given for u in given.by_session.values())
    assert set(rig_scope(riglab, no_rig=True).by_session.values()) == {None}
    # A session given alone, deep in the tree: still its folder's rig; one a day below a
    # rig file takes it (the nearest up the tree), given alone or by the lab's folder.
    deep = lab / "riglab" / "deep"
    scope = rig_scope(resolve_inputs([deep / "day1" / "c.mcap"]))
    assert [u.path for u in scope.uses] == [str(deep / "day1" / RIG_BESIDE)]
    below = lab / "riglab" / "withrig" / "day2" / "e.mcap"
    below.parent.mkdir()
    record(below, 1)
    for where in (below, lab / "riglab"):
        use = rig_scope(resolve_inputs([where])).of(str(below))
        assert use is not None
        assert use.path == str(lab / "riglab" / "withrig" / RIG_BESIDE)


def test_each_session_is_keyed_on_its_own_rig_file(lab: Path) -> None:
    """Their parent given: the rig files below it, each to its own sessions, the nearest
    winning; editing one folder's rig.toml analyses that folder's sessions again, no other."""
    out = lab / "out"

    def run() -> dict[str, bool]:
        result = analysis.run([lab / "riglab"], out, rigs="scope", scene=False)
        used = dict(zip(result.summary["label"], result.summary["rig_file"], strict=True))
        assert used == {
            "a.mcap": str(lab / "riglab" / "withrig" / RIG_BESIDE),
            "c.mcap": str(lab / "riglab" / "deep" / "day1" / RIG_BESIDE),
            "d.mcap": str(lab / "riglab" / "deep" / RIG_BESIDE)
            if (lab / "riglab" / "deep" / RIG_BESIDE).exists()
            else "",
        }
        return {Path(s.session).name: s.analysis_reused for s in result.sessions}

    assert not any(run().values())
    (lab / "riglab" / "deep" / "day1" / RIG_BESIDE).write_text(RIG.format(x=0.3))
    assert run() == {"a.mcap": True, "c.mcap": False, "d.mcap": True}
    (lab / "riglab" / "deep" / RIG_BESIDE).write_text(RIG.format(x=0.1))  # a new, nearer one
    assert run() == {"a.mcap": True, "c.mcap": True, "d.mcap": False}


def test_a_rig_that_does_not_fit_a_session_under_it_is_refused_before_anything_is_written(
    lab: Path,
) -> None:
    (lab / "riglab" / "deep" / "day1" / RIG_BESIDE).write_text(
        RIG.format(x=0.1).replace(
            "width = 64\nheight = 48\nfx = 52.5", "width = 640\nheight = 480\nfx = 525"
        )
    )
    code, said = _run(lab, "riglab", "--out", "o")
    assert code == 3, said
    assert "fitted for the camera 640x480" in said
    assert "day1/c.mcap" in said
    assert not (lab / "o").exists()
    (lab / "riglab" / "deep" / "day1" / RIG_BESIDE).write_text(
        RIG.format(x=0.1).replace('"in"', '"mm"')
    )
    code, said = _run(lab, "riglab", "--out", "o")
    assert code == 3, said
    assert "is in mm, the session in in" in said


def test_a_session_whose_parts_lie_under_two_rig_files_is_refused(tmp_path: Path) -> None:
    (tmp_path / "day1").mkdir()
    (tmp_path / "day2").mkdir()
    first = tmp_path / "day1" / "s.mcap"
    record(first, 1)
    continue_session(first, tmp_path / "day2" / "s_more.mcap", 1)  # into another folder
    (tmp_path / "day2" / RIG_BESIDE).write_text(RIG.format(x=0.1))
    with pytest.raises(InputValueError, match="lie under different rig files"):
        rig_scope(resolve_inputs([tmp_path]))
    assert rig_scope(resolve_inputs([tmp_path]), no_rig=True).uses == ()
    with pytest.raises(InputValueError, match="contradict"):
        rig_scope(resolve_inputs([tmp_path]), tmp_path / "day2" / RIG_BESIDE, no_rig=True)
    assert CAMERA.intrinsics.width == 64  # the camera the rig records


_FOLDERS = st.lists(st.sampled_from("abc"), min_size=0, max_size=4).map(tuple)


@settings(max_examples=40, deadline=None)
@given(session=_FOLDERS, rigs=st.sets(_FOLDERS, max_size=5))
def test_the_nearest_rig_up_the_tree_wins(
    tmp_path_factory: pytest.TempPathFactory, session: tuple[str, ...], rigs: set[tuple[str, ...]]
) -> None:
    """Any tree, any rig files in it: a session takes the rig file of its deepest folder
    that has one (a prefix of its own folders), relative as the session was given."""
    root = tmp_path_factory.mktemp("tree")
    for folder in rigs:
        (root.joinpath(*folder)).mkdir(parents=True, exist_ok=True)
        (root.joinpath(*folder) / RIG_BESIDE).write_text("")
    where = root.joinpath(*session)
    where.mkdir(parents=True, exist_ok=True)
    above = [f for f in rigs if session[: len(f)] == f]
    want = root.joinpath(*max(above, key=len)) / RIG_BESIDE if above else None
    assert nearest_rig(where / "s.mcap") == want
    cwd = os.getcwd()
    os.chdir(root)
    try:
        relative = nearest_rig(Path(*session, "s.mcap"))
    finally:
        os.chdir(cwd)
    assert relative == (None if want is None else Path(os.path.relpath(want, root)))


def test_a_broken_rig_file_up_the_tree_is_named_with_the_way_around_it(lab: Path) -> None:
    (lab / "norig" / RIG_BESIDE).write_text("[rig\n")
    with pytest.raises(InputValueError, match=r"not valid TOML.*found up the tree from .*--no-rig"):
        rig_scope(resolve_inputs([lab / "norig"]))
    assert rig_scope(resolve_inputs([lab / "norig"]), no_rig=True).uses == ()


def _noise(scale: float, seed: int) -> SessionNoise:
    """A session's first pass: 4 trials of 3 placing components each, their misclosures
    scattering ``scale`` times the variance assumed."""
    z2 = scale * np.random.default_rng(seed).chisquare(1, size=(4, 3))
    return SessionNoise(group="", chi2=z2.sum(axis=1), dof=np.full(4, 3), share=np.ones((4, 3)),
                        z2=z2)  # fmt: skip


def test_an_operators_sessions_under_two_rig_files_pool_apart(tmp_path: Path) -> None:
    # A rig is part of the setup and its [placing] the sigma the regions start from: one
    # operator's sessions under two rigs never lend each other their placing (issue 54's
    # prior, issue 56's scope).
    for name, placing in (("a", "sigma = 0.1\nsigma_sigma = 0.02\n"), ("b", "sigma = 0.3\n")):
        (tmp_path / name).mkdir()
        text = RIG.format(x=0.1).replace("sigma = 0.1\n", placing)
        (tmp_path / name / RIG_BESIDE).write_text(text)
    use = {n: RigUse.read(tmp_path / n / RIG_BESIDE) for n in "ab"}
    sessions = {"a/1.mcap": "a", "a/2.mcap": "a", "b/3.mcap": "b", "b/4.mcap": "b", "c.mcap": ""}
    scope = RigScope(by_session={s: use.get(r) for s, r in sessions.items()})
    base = AnalysisOptions()

    def options_for(session: str) -> AnalysisOptions:
        return scope.options_for(session, base)

    one = dict.fromkeys(sessions, "operator Ada (point)")
    split = by_rig_file(one, options_for)
    assert split == {
        s: f"operator Ada (point) under rig file {tmp_path / r / RIG_BESIDE}"
        for s, r in sessions.items()
        if r  # c.mcap, alone under no rig file, has nobody to pool with
    }
    same = {s: g for s, g in one.items() if s.startswith("a/")}
    assert by_rig_file(same, options_for) == same  # one rig: the groups as they were
    passes = {s: _noise(4.0 if s.startswith("b/") else 1.0, i) for i, s in enumerate(sessions)}
    priors = operator_priors_of(passes, split, base, options_for)
    assert set(priors) == set(split)
    for session, prior in priors.items():
        assert prior.sessions == 1
        assert prior.source == f"1 other session of operator {split[session]}"
        mine = [s for s in split if split[s] == split[session]]
        stats = [dataclasses.replace(passes[s], group=split[s]) for s in mine]
        anchor = options_for(session).estimate.noise.anchor()
        assert prior == operator_priors(stats, anchor)[mine.index(session)]  # its rig's anchor
    assert priors["b/3.mcap"].scale > 2 * priors["a/1.mcap"].scale  # never the other rig's
