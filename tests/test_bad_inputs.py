"""Malformed command input, as found by fuzzing (issue 12): each gets exit code 2 or 3 and
a message naming the problem, never a traceback; then hypothesis generates more of the
same kind (solve requests, plans, scenes) under the same invariant."""

from __future__ import annotations

import contextlib
import json
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from analysis.cli import app as analyze
from recorder.cli.app import app as record
from tests.fuzzing import Outcomes, check_command
from twopose.methods.specs import Method
from twopose.values.units import Units

TWO_POSES = "poses = [{t=[0,0,0]},{t=[1,0,0]}]\n"
PLANS = {
    "poses as a number": 'method = "point"\n[[trials]]\nposes = 3\n',
    "trials as a number": 'method = "point"\ntrials = 3\n',
    "trials as numbers": 'method = "point"\ntrials = [1, 2]\n',
    "ground_height as text": f'method = "ground"\nground_height = "x"\n[[trials]]\n{TWO_POSES}',
    "ground_height as a list": f'method = "ground"\nground_height = [1]\n[[trials]]\n{TWO_POSES}',
    "ground_height negative": f'method = "ground"\nground_height = -2\n[[trials]]\n{TWO_POSES}',
    "resolution as text": f'method = "point"\nresolution = "x"\n[[trials]]\n{TWO_POSES}',
    "width 1e12": f'method = "point"\n[camera]\nwidth = 1e12\n[[trials]]\n{TWO_POSES}',
    "a pose as a number": 'method = "point"\n[[trials]]\nposes = [3, {t=[1,0,0]}]\n',
}
SCENES = {
    "step 1e-300": "[poses]\nstep = 1e-300\n",
    "fps 1e-300": "[sensor]\nfps = 1e-300\n",
    "width 1e12": '[[cameras]]\nid = "cam0"\nwidth = 1000000000000\n',
    "clutter 1e6": "[clutter]\ncount = 1000000\n",
    "5000 poses": "[poses]\ncount = 5000\n",
    "colour 999": "[point]\ndot_color = [999, 0, 0]\n",
    "colour -5": "[clutter]\nnavy_color = [-5, 0, 0]\n",
}


def _check(app: Any, args: list[str], case: str, stdin: str | None = None) -> int:
    outcomes = Outcomes()
    code = check_command(app, args, case, outcomes, stdin=stdin)
    assert outcomes.violations == [], outcomes.violations
    assert code is not None
    return code


@pytest.mark.parametrize("case", sorted(PLANS))
def test_a_malformed_plan_is_named_not_a_traceback(tmp_path: Path, case: str) -> None:
    plan = tmp_path / "plan.toml"
    plan.write_text(PLANS[case])
    args = ["new", str(tmp_path / "s.mcap"), "--plan", str(plan), "--source", "synthetic"]
    assert _check(record, args, case) == 3
    assert not (tmp_path / "s.mcap").exists()


@pytest.mark.parametrize("case", sorted(SCENES))
def test_an_impossible_scene_is_named_not_a_traceback(tmp_path: Path, case: str) -> None:
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENES[case])
    args = ["simulate", str(tmp_path / "s.mcap"), "--method", "point", "--scene", str(scene)]
    assert _check(record, args, case) == 3


@pytest.mark.parametrize(
    ("args", "code"),
    [
        (["simulate", "S", "--method", "point", "--seed", "-1"], 2),
        (["calibrate", "C", "--source", "synthetic", "--board", "100000x100000"], 3),
    ],
)
def test_impossible_recorder_options(tmp_path: Path, args: list[str], code: int) -> None:
    args = [str(tmp_path / a) if a in ("S", "C") else a for a in args]
    assert _check(record, args, " ".join(args)) == code


@pytest.mark.parametrize("address", ["not a url", "tcp://[::1"])
def test_a_bad_dask_address_is_named(tmp_path: Path, point_session: Path, address: str) -> None:
    args = ["run", str(point_session), "--out", str(tmp_path / "o"), "--dask", address]
    assert _check(analyze, args, address) == 3


@pytest.mark.parametrize(
    "request_text",
    [
        '{"views": [{"px": [' + "9" * 5000 + ", 2]}]}",
        "[" * 200_000 + "]" * 200_000,
        '{"views": [{"K": [525, 525, 320, 240], "pose": {"t": [0, 0, 0]}, "px": [1e400, 2]}]}',
        json.dumps(
            {"views": [{"K": [1e308] * 4, "pose": {"t": [1e308] * 3}, "px": [1e308] * 2}] * 2}
        ),
    ],
    ids=["5000 digits", "200000 deep", "1e400", "1e308 everywhere"],
)
def test_a_malformed_solve_request_is_named(request_text: str) -> None:
    code = _check(analyze, ["solve", "point"], "request", stdin=request_text)
    assert code in (0, 3)  # 0: an answer whose status says what went wrong


# --------------------------------------------------------------------------- generated

NUMBERS = st.one_of(
    st.integers(-(10**30), 10**30),
    st.floats(allow_nan=False, allow_infinity=False),
    st.sampled_from([0, 1, -1, 1e308, -1e308, 1e-300, 10**400]),
)
JSONISH = st.recursive(
    st.one_of(NUMBERS, st.text(max_size=5), st.booleans(), st.none()),
    lambda inner: (
        st.lists(inner, max_size=5)
        | st.dictionaries(
            st.sampled_from(["K", "pose", "t", "r_deg", "px", "line", "P", "x"]), inner
        )
    ),
    max_leaves=20,
)
VIEW = st.fixed_dictionaries(
    {
        "K": st.lists(NUMBERS, min_size=3, max_size=5),
        "pose": st.fixed_dictionaries({"t": st.lists(NUMBERS, min_size=2, max_size=4)}),
        "px": st.lists(NUMBERS, min_size=1, max_size=3),
        "line": JSONISH,
    }
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    method=st.sampled_from(["point", "line", "ground"]),
    request=st.one_of(
        JSONISH,
        st.fixed_dictionaries({"views": st.lists(VIEW | JSONISH, max_size=4)}),
        st.fixed_dictionaries({"views": st.lists(VIEW, min_size=2, max_size=3), "ground": JSONISH}),
    ),
)
def test_generated_solve_requests_keep_the_invariant(method: str, request: Any) -> None:
    _check(analyze, ["solve", method], "generated", stdin=json.dumps(request))


def _toml(value: Any) -> str:
    """A value as TOML (enough for generated plans and scenes)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value) if value == value and abs(value) != float("inf") else "nan"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {_toml(v)}" for k, v in value.items()) + "}"
    return '""'


TOML_LEAF = st.one_of(NUMBERS, st.text(max_size=4), st.booleans())
TOML_VALUE = st.recursive(
    TOML_LEAF,
    lambda inner: (
        st.lists(inner, max_size=4)
        | st.dictionaries(
            st.sampled_from(["t", "r_deg", "camera", "x", "focal"]), inner, max_size=3
        )
    ),
    max_leaves=12,
)
PLAN_KEYS = ["method", "units", "frames", "ground_height", "camera", "trials", "resolution", "oops"]
SCENE_KEYS = ["units", "ground_height", "poses", "sensor", "clutter", "finger", "point", "oops"]


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    top=st.dictionaries(st.sampled_from(PLAN_KEYS), TOML_VALUE, max_size=6),
    method=st.sampled_from(['"point"', '"ground"', '"line"', "3"]),
)
def test_generated_plans_keep_the_invariant(
    tmp_path_factory: pytest.TempPathFactory, top: dict[str, Any], method: str
) -> None:
    folder = tmp_path_factory.mktemp("plan")
    (folder / "img").mkdir()
    plan = folder / "plan.toml"
    body = "".join(f"{k} = {_toml(v)}\n" for k, v in top.items() if k != "method")
    plan.write_text(f"method = {method}\n{body}")
    args = [
        "new",
        str(folder / "s.mcap"),
        "--plan",
        str(plan),
        "--source",
        f"images:{folder / 'img'}",
    ]
    _check(record, args, plan.read_text())


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(top=st.dictionaries(st.sampled_from(SCENE_KEYS), TOML_VALUE, max_size=4))
def test_generated_scenes_are_checked_before_rendering(
    tmp_path_factory: pytest.TempPathFactory, top: dict[str, Any]
) -> None:
    from twopose.errors import SceneError
    from twopose.sim.scene import load_scene

    folder = tmp_path_factory.mktemp("scene")
    scene = folder / "scene.toml"
    scene.write_text("".join(f"{k} = {_toml(v)}\n" for k, v in top.items()))
    with contextlib.suppress(SceneError):  # anything else is a crash: the test fails
        load_scene(scene)


def test_info_on_a_pose_for_an_unknown_camera_and_a_huge_version(tmp_path: Path) -> None:
    """Files another writer could make: a pose of a camera the session does not declare,
    and a format version of 5000 digits."""
    from mcap.writer import Writer as McapWriter

    from twopose.camera.model import Camera, Intrinsics
    from twopose.format.entries import PoseEntry, SessionInfo
    from twopose.format.writer import SessionWriter

    ghost = tmp_path / "ghost.mcap"
    cam = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=64, height=48, fx=50.0, fy=50.0, cx=32.0, cy=24.0),
    )
    with SessionWriter(ghost, SessionInfo(method=Method.POINT, units=Units.IN), [cam]) as w:
        w._write_json(
            PoseEntry(trial=1, pose=1, camera_id="ghost", t_grid=(0.0, 0.0, 0.0), capture=1), 5
        )  # unchecked
    assert _check(analyze, ["info", str(ghost)], "ghost camera") == 0
    assert _check(analyze, ["run", str(ghost), "--out", str(tmp_path / "o")], "ghost") == 0

    huge = tmp_path / "huge.mcap"
    with open(huge, "wb") as f:
        writer = McapWriter(f)
        writer.start()
        writer.add_metadata("twopose", {"format_version": "9" * 5000 + ".0"})
        writer.finish()
    assert _check(analyze, ["info", str(huge)], "huge version") == 1


def test_impossible_values_are_refused_not_accepted_silently(tmp_path: Path) -> None:
    """A session whose two version records disagree; a frame whose frame_id names another
    camera (kept with its topic's camera); a source whose size is not the calibrated one
    (refused before a file exists)."""
    import numpy as np

    from recorder.setup.plan import load_plan, record_plan
    from recorder.sources.registry import ImagesSource
    from tests.helpers import write_accepted_capture
    from twopose.camera.model import Camera, Intrinsics
    from twopose.errors import InputValueError, SessionFormatError
    from twopose.format.entries import PoseEntry, SessionInfo
    from twopose.format.messages import image_message
    from twopose.format.reader import SessionReader
    from twopose.format.trials import iter_trials
    from twopose.format.writer import SessionWriter

    cam = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=64, height=48, fx=50.0, fy=50.0, cx=32.0, cy=24.0),
    )
    mixed = tmp_path / "mixed.mcap"
    with SessionWriter(
        mixed, SessionInfo(method=Method.POINT, units=Units.IN, format_version="1.0"), [cam]
    ):
        pass
    with pytest.raises(SessionFormatError, match=r"says format 1\.0 but the twopose metadata"):
        SessionReader(mixed).__enter__()

    moved = tmp_path / "moved.mcap"
    with SessionWriter(
        moved, SessionInfo(method=Method.POINT, units=Units.IN), [cam], start_ns=0
    ) as w:
        frame = w.encode_image(np.zeros((48, 64, 3), np.uint8))
        original = w.write_image
        w.write_image = lambda cid, data, t, capture=None: w._write_proto(  # type: ignore[method-assign, assignment]
            "/twopose/camera/cam0/image", image_message("elsewhere", data, "jpeg", t, capture), t
        )
        write_accepted_capture(
            w, PoseEntry(trial=1, pose=1, camera_id="cam0", t_grid=(0, 0, 0)), [frame], 10
        )
        w.write_image = original  # type: ignore[method-assign]
    with SessionReader(moved) as r:
        (trial,) = iter_trials(r)
    assert [len(p.frames) for p in trial.poses] == [1]

    folder = tmp_path / "img"
    folder.mkdir()
    import cv2

    cv2.imwrite(str(folder / "a.png"), np.zeros((24, 32, 3), np.uint8))
    plan = tmp_path / "plan.toml"
    plan.write_text(
        'method = "point"\n[camera]\nfocal = 50.0\nwidth = 64\nheight = 48\n'
        f"[[trials]]\n{TWO_POSES}"
    )
    with pytest.raises(
        InputValueError, match="delivers 32x24 frames, but the camera calibration is for 64x48"
    ):
        record_plan(load_plan(plan), tmp_path / "s.mcap", ImagesSource(folder))
    assert not (tmp_path / "s.mcap").exists()
