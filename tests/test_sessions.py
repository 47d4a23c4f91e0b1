"""The bundled sample sessions: valid, CRC-clean, small, and reproducible by their script."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader

from twopose.format.messages import Frame
from twopose.format.reader import SessionReader
from twopose.format.trials import describe_session, iter_trials

SESSIONS = Path(__file__).resolve().parents[1] / "sessions"


def _make_sessions_module() -> ModuleType:
    if "make_sessions" in sys.modules:
        return sys.modules["make_sessions"]
    spec = importlib.util.spec_from_file_location("make_sessions", SESSIONS / "make_sessions.py")
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["make_sessions"] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


SAMPLES = _make_sessions_module().SAMPLES


def test_samples_are_all_there_and_small() -> None:
    files = sorted(p.name for p in SESSIONS.glob("*.mcap"))
    assert files == sorted(s.file for s in SAMPLES)
    assert sum(p.stat().st_size for p in SESSIONS.glob("*.mcap")) < 35e6


@pytest.mark.parametrize("sample", SAMPLES, ids=lambda s: s.file)
def test_sample_opens_with_crc_validation_and_matches_its_recipe(sample: Any) -> None:
    path = SESSIONS / sample.file
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        n = sum(1 for _ in reader.iter_messages())
    assert n > 0
    o = describe_session(path)
    assert o.info.method == sample.method
    assert o.n_trials == sample.trials
    assert o.n_frames == sample.trials * 2 * sample.frames
    assert o.n_incomplete_captures == 0


@pytest.mark.slow
def test_a_sample_regenerates_from_its_script(tmp_path: Path) -> None:
    """The committed thesis line session is what the committed script writes (frames within
    JPEG noise of a different OpenCV build; every typed entry exactly)."""
    module = _make_sessions_module()
    sample = next(s for s in SAMPLES if s.file == "thesis_line.mcap")
    module.make(sample, tmp_path)
    with SessionReader(SESSIONS / sample.file) as a, SessionReader(tmp_path / sample.file) as b:
        assert a.info == b.info
        for ea, eb in zip(a.iter_entries(), b.iter_entries(), strict=True):
            if isinstance(ea, Frame):
                assert isinstance(eb, Frame)
                diff = np.abs(ea.decode().astype(int) - eb.decode().astype(int))
                assert diff.mean() < 0.5
            else:
                assert ea == eb
    with SessionReader(tmp_path / sample.file) as b:
        assert len(list(iter_trials(b, with_frames=False))) == sample.trials


@pytest.mark.parametrize("sample", [s for s in SAMPLES if s.thesis], ids=lambda s: s.file)
def test_thesis_samples_move_the_laptop_as_the_thesis_did(sample: Any) -> None:
    """Section 5.3: along x only, or along x and depth with the depth move the larger;
    typed to 1/8 in; nothing else moves."""
    with SessionReader(SESSIONS / sample.file) as reader:
        trials = list(iter_trials(reader, with_frames=False))
    kinds = []
    for trial in trials:
        typed = np.array([pose.entry.t_grid for pose in trial.poses])
        np.testing.assert_allclose(typed * 8, np.round(typed * 8), atol=1e-9)
        move = typed[1] - typed[0]
        assert move[1] == 0.0
        assert move[2] == 0.0 or abs(move[2]) > abs(move[0]) > 0
        assert 1.0 <= max(abs(move[0]), abs(move[2])) <= 3.0
        kinds.append("x" if move[2] == 0 else "xz")
        assert trial.poses[0].entry.translation_resolution == pytest.approx(0.04)
    assert len(kinds) == sample.trials
    if sample.trials >= 15:
        assert {"x", "xz"} <= set(kinds)  # both kinds of move occur
