"""Seeded truncation and bit-flip sweeps of a real session through ``info``, ``run`` and
``recover`` (CI-sized; ``benchmarks/fuzz.py`` runs thousands). Every case must end with an
allowed exit code and a message, never a traceback or a hang; ``recover`` leaves either a
valid session or nothing."""

from __future__ import annotations

from pathlib import Path

import pytest

from analysis.cli import app as analyze
from recorder.cli.app import app as record
from recorder.setup.plan import load_plan, record_plan
from recorder.sources.registry import SyntheticSource
from tests.fuzzing import Outcomes, check_command, mutants
from twopose.format.reader import SessionReader
from twopose.methods.specs import Method

# Slow (a real browser, a cluster, or fits over many sessions): make test-all and CI run it.
pytestmark = pytest.mark.slow

PLAN = """method = "point"
frames = 2
[camera]
focal = 525.0
[[trials]]
ground_truth = [[0.5, 1.5, 11.0]]
poses = [{ t = [0.0, 0.0, 0.0] }, { t = [1.1, 0.0, 0.0] }]
[[trials]]
ground_truth = [[0.5, 1.5, 11.0]]
poses = [{ t = [0.0, 0.0, 0.0] }, { t = [1.1, 0.0, 0.0] }]
"""


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> bytes:
    folder = tmp_path_factory.mktemp("fuzz")
    (folder / "plan.toml").write_text(PLAN)
    path = folder / "s.mcap"
    record_plan(
        load_plan(folder / "plan.toml"), path, SyntheticSource(None, Method.POINT, realtime=False)
    )
    return path.read_bytes()


def test_damaged_sessions_get_a_clear_answer_from_info_and_recover(
    tmp_path: Path, session: bytes
) -> None:
    outcomes = Outcomes()
    recovered = 0
    for i, (case, data) in enumerate(mutants(session, 60, seed=11)):
        broken = tmp_path / f"broken{i}.mcap"
        broken.write_bytes(data)
        check_command(analyze, ["info", str(broken)], case, outcomes)
        fixed = tmp_path / f"fixed{i}.mcap"
        code = check_command(record, ["recover", str(broken), "-o", str(fixed)], case, outcomes)
        if code == 0:
            with SessionReader(fixed) as reader:  # a valid, indexed session
                assert reader.info.method == "point", case
            recovered += 1
        elif code is not None:
            assert not fixed.exists(), f"{case}: recover failed but left {fixed}"
    assert outcomes.violations == []
    assert outcomes.cases == 120
    assert recovered >= 20  # most damage is recoverable
    assert outcomes.codes[1] + outcomes.codes[3] > 0  # and the sweep did reach failures


def test_damaged_sessions_get_a_clear_answer_from_run(tmp_path: Path, session: bytes) -> None:
    outcomes = Outcomes()
    # 10 damaged copies, a full run each (~2.7 s): benchmarks/fuzz.py sweeps thousands.
    for i, (case, data) in enumerate(mutants(session, 10, seed=12)):
        broken = tmp_path / f"broken{i}.mcap"
        broken.write_bytes(data)
        args = ["run", str(broken), "--out", str(tmp_path / f"out{i}"), "--no-scene"]
        check_command(analyze, args, case, outcomes)
    assert outcomes.violations == []
    assert outcomes.cases == 10
