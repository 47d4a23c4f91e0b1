"""``twopose-analyze detect`` and ``solve`` through typer's CliRunner: one JSON object per
image or request, degenerate geometry as a status, bad input refused with its reason."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from analysis.cli import app
from twopose.camera.model import Intrinsics, project_points
from twopose.errors import EXIT_ERROR, EXIT_SOME_INPUTS_FAILED
from twopose.format.reader import SessionReader

runner = CliRunner()


K = [525.0, 525.0, 320.0, 240.0]


INTR = Intrinsics(width=640, height=480, fx=K[0], fy=K[1], cx=K[2], cy=K[3])


def _view(t: list[float], **measure: object) -> dict[str, object]:
    return {"K": K, "pose": {"t": t, "r_deg": [0, 0, 0]}, **measure}


def _line_view(t: list[float], a: np.ndarray, b: np.ndarray) -> dict[str, object]:
    pa, pb = project_points(np.stack([a, b]), INTR, np.eye(3), t)
    theta = float(np.degrees(np.arctan2(*(pb - pa)[::-1])))
    return _view(t, line={"px": pa.tolist(), "theta_deg": theta})


def test_detect_prints_one_json_object_per_image(tmp_path: Path, ground_session: Path) -> None:
    with SessionReader(ground_session) as r:
        from twopose.format.trials import iter_trials

        frame = next(iter_trials(r)).poses[0].frames[0]
    img = tmp_path / "frame.png"
    cv2.imwrite(str(img), frame.decode())
    blank = tmp_path / "blank.png"
    cv2.imwrite(str(blank), np.full((48, 64, 3), 128, np.uint8))
    result = runner.invoke(app, ["detect", str(img), str(blank), "--target", "glove"])
    assert result.exit_code == 0, result.output
    first, second = (json.loads(line) for line in result.output.strip().splitlines())
    assert set(first) == {
        "image",
        "found",
        "centroid_px",
        "theta_deg",
        "area_px",
        "eccentricity",
        "n_blobs",
        "reason",
    }  # the one set of key names: the web console's frames carry the same
    assert first["found"] is True
    assert -90 < first["theta_deg"] <= 90
    assert second["found"] is False
    assert second["reason"]


def test_detect_unreadable_image(tmp_path: Path) -> None:
    bad = tmp_path / "x.png"
    bad.write_text("not an image")
    result = runner.invoke(app, ["detect", str(bad), "--target", "dot"])
    assert result.exit_code == EXIT_SOME_INPUTS_FAILED
    assert "is not a readable image" in json.loads(result.output)["reason"]


def test_solve_point() -> None:
    req = {"views": [_view([0, 0, 0], px=[320, 240]), _view([1, 0, 0], px=[267.5, 240])]}
    result = runner.invoke(app, ["solve", "point"], input=json.dumps(req))
    assert result.exit_code == 0, result.output
    answer = json.loads(result.output)
    np.testing.assert_allclose(answer["point"], [0, 0, 10], atol=1e-9)
    assert answer["status"] == "ok"
    assert answer["conditioning"] > 0


@pytest.mark.parametrize("method", ["line", "ground"])
def test_solve_line_and_ground(method: str) -> None:
    a, b = np.array([1.0, 3.0, 12.0]), np.array([1.91, 9.625, 8.375])
    req = {"views": [_line_view([0, 0, 0], a, b), _line_view([1.1, 0, 0], a, b)], "ground_y": 9.625}
    result = runner.invoke(app, ["solve", method], input=json.dumps(req))
    assert result.exit_code == 0, result.output
    answer = json.loads(result.output)
    if method == "ground":
        np.testing.assert_allclose(answer["point"], b, atol=1e-9)
    else:
        u = np.array(answer["line"]["direction"])
        assert np.linalg.norm(np.cross(u, (b - a) / np.linalg.norm(b - a))) < 1e-9


def test_solve_degenerate_is_a_status_not_a_crash() -> None:
    req = {"views": [_view([0, 0, 0], px=[320, 240]), _view([0, 0, 2], px=[320, 240])]}
    answer = json.loads(runner.invoke(app, ["solve", "point"], input=json.dumps(req)).output)
    assert answer["status"] == "degenerate"
    assert answer["point"] is None
    assert answer["reason"] == "point on the baseline (rays parallel)"


@pytest.mark.parametrize(
    ("method", "payload", "message"),
    [
        ("point", "{not json", "not valid JSON"),
        ("point", json.dumps({"views": [_view([0, 0, 0], px=[1, 2])]}), "2 or more"),
        (
            "point",
            json.dumps({"views": [_view([0, 0, 0], px=[1, 2])] * 2, "estimator": "best"}),
            "estimator",
        ),
        (
            "point",
            json.dumps({"views": [_view([0, 0, 0], px=[1, "a"]), _view([1, 0, 0], px=[1, 2])]}),
            "views[0].px",
        ),
        (
            "point",
            json.dumps({"views": [_view([0, 0], px=[1, 2]), _view([1, 0, 0], px=[1, 2])]}),
            "pose.t",
        ),
        (
            "line",
            json.dumps({"views": [_view([0, 0, 0], px=[1, 2]), _view([1, 0, 0], px=[1, 2])]}),
            "'line'",
        ),
        (
            "ground",
            json.dumps({"views": [_view([0, 0, 0], line={"px": [1, 2], "theta_deg": 3})] * 2}),
            "ground_y",
        ),
        ("point", json.dumps([1, 2]), "'views'"),
    ],
)
def test_solve_bad_requests_say_what_is_wrong(method: str, payload: str, message: str) -> None:
    result = runner.invoke(app, ["solve", method], input=payload)
    assert result.exit_code == EXIT_ERROR
    assert message in result.output
    assert "Traceback" not in result.output


def test_detect_refuses_an_image_bomb_and_an_empty_file_with_a_reason(tmp_path: Path) -> None:
    from tests.helpers import jpeg_declaring

    bomb, empty = tmp_path / "bomb.jpg", tmp_path / "empty.png"
    bomb.write_bytes(jpeg_declaring(32000, 32000))
    empty.write_bytes(b"")
    result = CliRunner().invoke(app, ["detect", str(bomb), str(empty), "--target", "dot"])
    assert result.exit_code == 1
    assert result.exception is None or isinstance(result.exception, SystemExit)
    lines = [json.loads(line) for line in result.stdout.splitlines()]
    assert [d["found"] for d in lines] == [False, False]
    assert "over the limit" in lines[0]["reason"]
    assert "not a readable image" in lines[1]["reason"]
