"""The registry is the dispatch (issue 35): a method registered from outside the package
is listed and accepted by every command, with nothing else changed (issue 57: through the
extension point, not an edited copy).

The test installs an extension (a module naming its ``register_method`` call under the
entry-point group ``twopose.extensions``) whose method is a copy of the point's (a dot,
rays, one truth point), and drives the commands in a subprocess. A command that still
dispatches on a method's name fails on ``fake``, and its message names what it was.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from tests.helpers import install_extension

FAKE_EXTENSION = """
import dataclasses

from twopose.methods.specs import METHOD_SPECS, Method, register_method

register_method(
    dataclasses.replace(
        METHOD_SPECS[Method.POINT],
        method=Method.declare("fake"),
        thesis_name="a test's method",
        label="fake (a test's)",
        colour="C5",
        thesis_tested=False,
    )
)
"""


@pytest.fixture(scope="module")
def with_fake(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding an installed extension whose method is ``fake``."""
    return install_extension(tmp_path_factory.mktemp("registry"), "fake_ext", FAKE_EXTENSION)


def _run(root: Path, *args: str, stdin: str | None = None) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(root), "COLUMNS": "200", "NO_COLOR": "1"}
    done = subprocess.run(
        [sys.executable, *args], cwd=root, env=env, input=stdin, capture_output=True,
        text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 0, (
        f"`{' '.join(args)}` refused the registry's new method `fake`: something still "
        f"dispatches on method names.\nstdout:\n{done.stdout}\nstderr:\n{done.stderr}"
    )
    return done


def test_the_extension_is_loaded_with_the_registry(with_fake: Path) -> None:
    done = _run(with_fake, "-c", "import twopose.methods.specs as m; print(*m.METHODS)")
    assert done.stdout.split() == ["point", "line", "ground", "board", "fake"]


@pytest.mark.parametrize(
    "command",
    [("recorder", "new"), ("recorder", "simulate"), ("analysis", "solve")],
)
def test_every_command_lists_the_new_method(with_fake: Path, command: tuple[str, str]) -> None:
    package, name = command
    usage = _run(with_fake, "-m", package, name, "--help").stdout
    assert "point|line|ground|board|fake" in usage or "point|line|ground|fake" in usage, usage


def _simulated_trials(root: Path, method: str) -> pd.DataFrame:
    session = root / f"{method}.mcap"
    _run(root, "-m", "recorder", "simulate", str(session), "--method", method,
         "--trials", "3", "--frames", "2", "--seed", "4")  # fmt: skip
    assert method in _run(root, "-m", "analysis", "info", str(session)).stdout
    out = root / f"results_{method}"
    _run(root, "-m", "analysis", "run", str(session), "--out", str(out))
    return pd.read_csv(out / "trials.csv")


# Subprocess-heavy (simulate, info and run on the copy, twice: ~28 s idle): make test-all runs
# it; the quick loop keeps the commands' --help above and the census (tests/test_docs.py),
# which counts every comparison with a method's name.
@pytest.mark.slow
def test_the_new_method_is_recorded_analysed_and_solved(with_fake: Path) -> None:
    trials = _simulated_trials(with_fake, "fake")
    assert set(trials["method"]) == {"fake"}
    assert (trials["status"] == "ok").all()
    # Its spec is the point's: the same scene, the same estimates, to the last digit.
    point = _simulated_trials(with_fake, "point")
    numbers = ["x", "y", "z", "err", "x_optimal", "err_optimal", "semiaxis95"]
    pd.testing.assert_frame_equal(trials[numbers], point[numbers])
    request = {
        "views": [
            {"K": [525, 525, 320, 240], "pose": {"t": [0, 0, 0], "r_deg": [0, 0, 0]},
             "px": [320 + 525 * 0.5 / 10, 240 + 525 * 1.5 / 10]},
            {"K": [525, 525, 320, 240], "pose": {"t": [1, 0, 0], "r_deg": [0, 0, 0]},
             "px": [320 + 525 * -0.5 / 10, 240 + 525 * 1.5 / 10]},
        ]
    }  # fmt: skip
    answer = json.loads(_run(with_fake, "-m", "analysis", "solve", "fake",
                             stdin=json.dumps(request)).stdout)  # fmt: skip
    assert answer["status"] == "ok"
    assert answer["point"] == pytest.approx([0.5, 1.5, 10.0], abs=1e-9)


PLAN = """
method = "fake"
units = "cm"
frames = 2

[camera]
focal = 525.0
principal = [320.0, 240.0]

[[trials]]
ground_truth = [[1.0, 4.0, 28.0]]
poses = [{ t = [0.0, 0.0, 0.0] }, { t = [2.5, 0.0, 0.0] }]
"""


@pytest.mark.slow  # a plan recorded and run in subprocesses (~10 s): as the test above
def test_the_new_method_is_recorded_from_a_plan(with_fake: Path) -> None:
    plan = with_fake / "fake_plan.toml"
    plan.write_text(PLAN, encoding="utf-8")
    session = with_fake / "planned.mcap"
    _run(with_fake, "-m", "recorder", "new", str(session), "--plan", str(plan),
         "--source", "synthetic")  # fmt: skip
    out = with_fake / "planned"
    _run(with_fake, "-m", "analysis", "run", str(session), "--out", str(out))
    trials = pd.read_csv(out / "trials.csv")
    assert list(trials["method"]) == ["fake"]
    assert list(trials["units"]) == ["cm"]
