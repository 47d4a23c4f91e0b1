"""A method on another plane, through the registry alone (issue 45): an installed
extension (docs/development.md's snippet, registered by ``register_method``) adds a
``wall`` method, method 2 on the wall ``x = c`` instead of the ground ``y = h`` (its plane
a :class:`twopose.methods.planes.ConstraintPlane`, its offset a setup value like the ground
height), and nothing else changed.

With it installed, the commands simulate it, record it at the terminal and from a plan
(the synthetic camera rendering the finger pointing at the wall), and analyse each: the
estimates land on the wall's point. The browser's part is ``tests/recorder/test_wall_page.py``.
docs/development.md ("Adding a method") shows the same entry.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from tests.helpers import install_extension

# Slow: records and analyses in subprocesses (make test-all, CI).
pytestmark = pytest.mark.slow

#: The wall's extension, docs/development.md's snippet as written ("Adding a method").
WALL_ENTRY = re.search(
    r"<!-- snippet: wall -->\n```python\n(.*?)```\n",
    (Path(__file__).resolve().parents[1] / "docs" / "development.md").read_text(encoding="utf-8"),
    re.S,
)[1]  # type: ignore[index]
#: The synthetic scene's finger points at its ``ground_point`` of its method's plane, whose
#: offset is the scene's ``ground_height`` (9.625 in): here (y, z) = (6, 14) on the wall
#: x = 9.625, the finger coming down to it at 45 degrees from the wall's normal (a finger
#: level with the camera would need the camera raised, not moved on the paper).
SCENE = """
[finger]
ground_point = [6.0, 14.0]
tilt_deg = 45.0
azimuth_deg = 90.0
tip_height = 4.0
"""
WALL_X = 9.625
TRUTH = (WALL_X, 6.0, 14.0)
POSES = ((0.0, 0.0, 0.0), (3.0, 0.0, 0.0), (-2.0, 0.0, 1.0))


def add_the_wall(root: Path) -> Path:
    """Install the wall's extension under ``root`` (its entry point and module)."""
    install_extension(root, "wall_ext", WALL_ENTRY)
    (root / "wall_scene.toml").write_text(SCENE, encoding="utf-8")
    return root


@pytest.fixture(scope="module")
def walled(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return add_the_wall(tmp_path_factory.mktemp("wall"))


def run_in(root: Path, *args: str, stdin: str | None = None) -> str:
    """A command of the copy; its output (it must succeed)."""
    env = {**os.environ, "PYTHONPATH": str(root), "COLUMNS": "200", "NO_COLOR": "1"}
    done = subprocess.run(
        [sys.executable, *args], cwd=root, env=env, input=stdin, capture_output=True,
        text=True, timeout=600, check=False,
    )  # fmt: skip
    assert done.returncode == 0, (
        f"`{' '.join(args)}` failed on the wall method\nstdout:\n{done.stdout}\n"
        f"stderr:\n{done.stderr}"
    )
    return done.stdout


def analysed(root: Path, session: Path) -> pd.DataFrame:
    """The copy's ``run`` on ``session``: its trials."""
    out = session.with_suffix("")
    run_in(root, "-m", "analysis", "run", str(session), "--out", str(out))
    return pd.read_csv(out / "trials.csv")


def assert_on_the_wall(trials: pd.DataFrame, n: int, within: float) -> None:
    """``n`` ok wall trials whose estimates lie on the wall, ``within`` of its point."""
    assert list(trials["method"]) == ["wall"] * n
    assert (trials["status"] == "ok").all(), trials[["status", "reason"]]
    assert trials["x"].to_numpy() == pytest.approx(WALL_X, abs=1e-9)  # on x = c, exactly
    assert (trials[["gt_x", "gt_y", "gt_z"]].to_numpy() == TRUTH).all()
    assert (trials["err"] < within).all(), trials[["x", "y", "z", "err", "plane_angle_deg"]]


def test_the_setup_asks_the_walls_offset_and_checks_truth_on_the_wall(walled: Path) -> None:
    probe = """
import json
from recorder.setup.form import form_fields, setup_from_answers, FormRefusedError
given = {"method": None, "units": None, "intrinsics": None, "size": (640, 480),
         "ground_truth": []}
asked = {m: sorted(f["name"] for f in form_fields(given) if m in f["methods"])
         for m in ("wall", "ground")}
setup = setup_from_answers({"method": "wall", "wall_x": "9.625",
                            "truth1": "9.625, 6, 14"}, given)
try:
    setup_from_answers({"method": "wall", "wall_x": "9.625", "truth1": "1.91, 9.625, 8.375"},
                       given)
except FormRefusedError as err:
    refused = err.errors["truth1"]
try:  # --ground-height given, the wall chosen in the page (was ignored)
    setup_from_answers({"method": "wall", "wall_x": "9.625", "truth1": "9.625, 6, 14"},
                       {**given, "ground_height": 9.0})
except FormRefusedError as err:
    other = err.errors["method"]
print(json.dumps({"asked": asked, "entry": [setup.ground().normal_grid, setup.ground().offset],
                  "refused": refused, "other": other}))
"""
    import json

    said = json.loads(run_in(walled, "-c", probe))
    assert "wall_x" in said["asked"]["wall"]
    assert "ground_height" not in said["asked"]["wall"]
    assert "ground_height" in said["asked"]["ground"]
    assert "wall_x" not in said["asked"]["ground"]
    assert said["entry"] == [[1.0, 0.0, 0.0], WALL_X]
    assert "the wall is at x = 9.625 in" in said["refused"], said["refused"]
    assert said["other"].startswith("--ground-height is not a wall session's"), said["other"]


#: Each figure of a session drawn in the copy, as its axes name what they show; the error
#: scatter's points against the trials' errors on the wall (y, z).
FIGURES_PROBE = """
import json, sys
import numpy as np
from analysis.report.figures.draw import session_figures
from analysis.tables.read_back import read_table
out = sys.argv[1]
trials, averaging, views = (read_table(f"{out}/{n}.csv") for n in ("trials", "averaging", "views"))
figures = session_figures("s.mcap", trials, averaging, views, include_warned=True)
said = {kind: [[ax.get_xlabel(), ax.get_ylabel(), ax.get_title()] for ax in fig.axes]
        for kind, fig in figures.items()}
drawn = figures["scatter"].axes[0].collections[1].get_offsets()
said["scatter_points"] = np.allclose(drawn, trials[["err_y", "err_z"]].to_numpy())
print(json.dumps(said))
"""


def test_simulated_and_analysed_in_the_walls_own_axes(walled: Path) -> None:
    """The wall's trials are drawn and said facing the wall, in its y and z: the top view,
    the error scatter, the running averages, the report's charts and the terminal's bias
    lines (before: the ground's x and z, looking down on the grid)."""
    import json

    session = walled / "simulated.mcap"
    run_in(walled, "-m", "recorder", "simulate", str(session), "--method", "wall", "--trials",
           "3", "--frames", "2", "--seed", "3", "--scene", "wall_scene.toml")  # fmt: skip
    assert "wall" in run_in(walled, "-m", "analysis", "info", str(session))
    out = session.with_suffix("")
    said = run_in(walled, "-m", "analysis", "run", str(session), "--out", str(out))
    # The scene's own poses, 1-2 in apart on the paper: planes 4-7 degrees apart.
    assert_on_the_wall(pd.read_csv(out / "trials.csv"), 3, within=1.5)
    assert "bias y" in said, said
    assert "bias x" not in said, said
    report = (out / "report.html").read_text(encoding="utf-8")
    assert "Error in the wall plane" in report
    assert "Running average's y error" in report
    assert "Running average's x error" not in report
    figures = json.loads(run_in(walled, "-c", FIGURES_PROBE, str(out)))
    assert figures["topview"][0][:2] == ["y (in)", "z (in)"], figures
    assert "view facing the wall" in figures["topview"][0][2]
    assert figures["scatter"][0][:2] == ["y error (in)", "z error (in)"], figures
    assert figures["scatter_points"] is True
    assert [ax[2] for ax in figures["averaging"]] == ["y error", "z error"], figures


def test_recorded_from_a_plan_and_analysed(walled: Path) -> None:
    poses = ", ".join(f"{{ t = [{x}, {y}, {z}] }}" for x, y, z in POSES)
    plan = walled / "wall_plan.toml"
    plan.write_text(
        f'method = "wall"\nframes = 2\nwall_x = {WALL_X}\n\n[camera]\nfocal = 525.0\n'
        f"principal = [320.0, 240.0]\n\n[[trials]]\nground_truth = [{list(TRUTH)}]\n"
        f"poses = [{poses}]\n",
        encoding="utf-8",
    )
    session = walled / "planned.mcap"
    run_in(walled, "-m", "recorder", "new", str(session), "--plan", str(plan),
           "--source", "synthetic:wall_scene.toml")  # fmt: skip
    assert_on_the_wall(analysed(walled, session), 1, within=0.5)


def test_a_plan_giving_the_ground_height_for_the_wall_is_refused(walled: Path) -> None:
    plan = walled / "wrong_plane.toml"
    plan.write_text(
        'method = "wall"\nground_height = 9.625\n[[trials]]\n'
        "poses = [{ t = [0.0, 0.0, 0.0] }, { t = [2.5, 0.0, 0.0] }]\n",
        encoding="utf-8",
    )
    env = {**os.environ, "PYTHONPATH": str(walled), "NO_COLOR": "1"}
    done = subprocess.run(
        [sys.executable, "-m", "recorder", "new", str(walled / "no.mcap"), "--plan", str(plan),
         "--source", "synthetic"],
        cwd=walled, env=env, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode != 0
    assert "ground_height is not a wall session's: its plane is the wall, x = c" in (
        done.stdout + done.stderr
    )
    assert "Traceback" not in done.stderr
    assert not (walled / "no.mcap").exists()


@pytest.mark.parametrize("option", [[], ["--plane-offset", str(WALL_X)]])
def test_recorded_at_the_terminal_and_analysed(walled: Path, option: list[str]) -> None:
    """The terminal asks the wall's x (unless ``--plane-offset`` gives it: the one option
    of any method's plane), checks the ground truth against the wall, and records what it
    is told."""
    answers = ([] if option else [str(WALL_X)]) + [""]  # the wall's x; no stop rule
    for x, y, z in POSES[:2]:
        answers += [f"{x}, {y}, {z}", "", "a"]  # the pose, no rotation, accept
    answers.append("n")  # no other trial
    session = walled / f"terminal{len(option)}.mcap"
    said = run_in(
        walled, "-m", "recorder", "new", str(session), "--source", "synthetic:wall_scene.toml",
        "--method", "wall", "--units", "in", "--focal", "525", "--principal", "320,240",
        "--ground-truth", ",".join(str(v) for v in TRUTH), "--operator", "Bo", "--frames", "2",
        *option, stdin="\n".join(answers) + "\n",
    )  # fmt: skip
    assert ("wall: its x on the grid (in)" in said) != bool(option), said
    assert_on_the_wall(analysed(walled, session), 1, within=0.5)


def test_the_command_line_refuses_the_ground_height_for_the_wall(walled: Path) -> None:
    """``--ground-height`` is the ground's; a wall session asks its wall's x (before, the
    option was silently ignored)."""
    env = {**os.environ, "PYTHONPATH": str(walled), "NO_COLOR": "1"}
    for ui in ([], ["--ui"]):
        done = subprocess.run(
            [sys.executable, "-m", "recorder", "new", str(walled / "no.mcap"), "--method",
             "wall", "--ground-height", "6", "--source", "synthetic", *ui],
            cwd=walled, env=env, capture_output=True, text=True, timeout=300, check=False,
            stdin=subprocess.DEVNULL,
        )  # fmt: skip
        said = done.stdout + done.stderr
        assert done.returncode == 3, said  # a message naming the input (docs/bad-input.md)
        assert "--ground-height is not a wall session's: its plane is the wall, x = c" in said
        assert "Traceback" not in said
        assert not (walled / "no.mcap").exists()


def test_solve_cuts_the_planes_line_with_the_wall(walled: Path) -> None:
    """``twopose-analyze solve wall`` reads the wall's x under its key and answers a point
    on the wall (before, the ground's y = h was used whatever the plane)."""
    import json

    import numpy as np

    truth = np.array(TRUTH)
    direction = np.array([np.sqrt(0.5), np.sqrt(0.5), 0.0])  # the finger, down to the wall
    views = []
    for t in ((0.0, 0.0, 0.0), (3.0, 0.0, 0.0)):
        ends = [truth - 5 * direction - np.array(t), truth - 8 * direction - np.array(t)]
        px = [[320 + 525 * p[0] / p[2], 240 + 525 * p[1] / p[2]] for p in ends]
        views.append(
            {"K": [525, 525, 320, 240], "pose": {"t": list(t), "r_deg": [0, 0, 0]},
             "line": {"segment_px": [*px[0], *px[1]]}}
        )  # fmt: skip
    request = json.dumps({"views": views, "wall_x": WALL_X})
    answer = json.loads(run_in(walled, "-m", "analysis", "solve", "wall", stdin=request))
    assert answer["status"] == "ok", answer
    assert answer["point"] == pytest.approx(list(TRUTH), abs=1e-6)
