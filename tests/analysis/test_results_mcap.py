"""results.mcap: decode what we wrote and check it against the tables."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from analysis.batch.runner import results_mcap_name, run
from analysis.session.results_mcap import SCENE_TOPIC, annotations_topic
from twopose.format.messages import image_topic


def _decoded(path: Path) -> list[tuple[str, int, Any]]:
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [
            (channel.topic, message.log_time, proto)
            for _, channel, message, proto in reader.iter_decoded_messages(log_time_order=True)
        ]


def _entity(update: Any, name: str) -> Any:
    found = [e for e in update.entities if e.id == name]
    assert len(found) == 1, f"{name}: {[e.id for e in update.entities]}"
    return found[0]


def _vec(p: Any) -> np.ndarray:
    return np.array([p.x, p.y, p.z])


@pytest.fixture(scope="module")
def results(
    tmp_path_factory: pytest.TempPathFactory,
    point_session: Path,
    line_session: Path,
    ground_session: Path,
) -> tuple[Path, Any]:
    out = tmp_path_factory.mktemp("results")
    result = run([point_session, line_session, ground_session], out)
    return out, result


@pytest.mark.parametrize("index", [0, 1, 2])
def test_scene_geometry_matches_the_trial_table(results: tuple[Path, Any], index: int) -> None:
    out, result = results
    session = result.sessions[index]
    messages = _decoded(out / results_mcap_name(index, session.session))
    scenes = [m for t, _, m in messages if t == SCENE_TOPIC]
    static, per_trial = scenes[0], scenes[1:]
    assert {e.id for e in static.entities} >= {"grid"}
    assert len(per_trial) == len(session.trials)
    method = session.trials["method"].iloc[0]
    for update, (_, row) in zip(per_trial, session.trials.iterrows(), strict=True):
        estimate = _entity(update, "estimate")
        np.testing.assert_allclose(
            _vec(estimate.spheres[0].pose.position), row[["x", "y", "z"]].to_numpy(float)
        )
        # The 95% ellipsoid's axes are the covariance's: its volume matches the determinant.
        axes = _vec(estimate.spheres[1].size) / 2
        if method == "point":
            cov = np.array(
                [
                    [row.sigma_x**2, row.cov_xy, row.cov_xz],
                    [row.cov_xy, row.sigma_y**2, row.cov_yz],
                    [row.cov_xz, row.cov_yz, row.sigma_z**2],
                ]
            )
            np.testing.assert_allclose(
                np.prod(axes), np.sqrt(7.8147**3 * np.linalg.det(cov)), rtol=1e-3
            )
        truth = _entity(update, "truth")
        if method == "line":
            pts = [_vec(p) for p in truth.lines[0].points]
            np.testing.assert_allclose(
                0.5 * (pts[0] + pts[1]), row[["gt_x", "gt_y", "gt_z"]].to_numpy(float), atol=1e-9
            )
        else:
            np.testing.assert_allclose(
                _vec(truth.spheres[0].pose.position), row[["gt_x", "gt_y", "gt_z"]].to_numpy(float)
            )
        arrow = _entity(update, "error").arrows[0]
        np.testing.assert_allclose(arrow.shaft_length + arrow.head_length, row["err"], rtol=1e-9)
        cameras = _entity(update, "cameras")
        assert len(cameras.lines) == row["n_views"]  # one frustum per pose
        measurements = _entity(update, "measurements")
        if method == "point":
            assert len(measurements.lines[0].points) == 2 * row["n_views"]  # one ray each
        else:
            assert len(measurements.triangles[0].points) == 3 * row["n_views"]  # one wedge each


def test_images_carry_their_detections(results: tuple[Path, Any]) -> None:
    out, result = results
    session = result.sessions[0]
    messages = _decoded(out / results_mcap_name(0, session.session))
    counts = Counter(t for t, _, _ in messages)
    frames = session.frames
    assert counts[image_topic("cam0")] == len(frames)
    assert counts[annotations_topic("cam0")] == len(frames)
    images = {t: m for topic, t, m in messages if topic == image_topic("cam0")}
    overlays = [(t, m) for topic, t, m in messages if topic == annotations_topic("cam0")]
    for (t, overlay), (_, row) in zip(overlays, frames.iterrows(), strict=True):
        assert t == row["log_time_ns"]
        assert images[t].timestamp.ToNanoseconds() == t  # the Image panel pairs them by stamp
        assert overlay.circles[0].timestamp.ToNanoseconds() == t
        centre = overlay.circles[0].position
        np.testing.assert_allclose([centre.x, centre.y], [row["col"], row["row"]])
        assert overlay.texts[-1].text.endswith("found")
        assert f"trial {row['trial']} pose {row['pose']}" in overlay.texts[-1].text


@pytest.mark.slow  # two full runs into folders (~7.5 s): make test-all and CI run it
def test_no_scene_and_failed_sessions_leave_no_results_file(
    tmp_path: Path, point_session: Path
) -> None:
    bad = tmp_path / "in" / "bad.mcap"
    bad.parent.mkdir()
    bad.write_bytes(b"\x89MCAP0\r\n" + b"\0" * 64)
    out = tmp_path / "out"
    result = run([point_session, bad], out)
    assert len(result.errors) == 1
    written = sorted(p.name for p in out.glob("*.mcap"))
    assert written == [results_mcap_name(0, point_session)]
    none = tmp_path / "none"
    run([point_session], none, scene=False)
    assert not list(none.glob("*.mcap"))
    assert pd.read_csv(none / "trials.csv")["status"].eq("ok").all()


def test_the_shipped_foxglove_layout_names_topics_that_exist(results: tuple[Path, Any]) -> None:
    import json

    out, result = results
    layout = json.loads((Path(__file__).parents[2] / "docs" / "foxglove-layout.json").read_text())
    config = layout["configById"]
    image = config["Image!twopose"]["imageMode"]
    wanted = {image["imageTopic"], image["calibrationTopic"], *image["annotations"]}
    wanted |= set(config["3D!twopose"]["topics"])
    wanted.add(config["RawMessages!twopose"]["topicPath"].split(".")[0])
    with (out / results_mcap_name(0, result.sessions[0].session)).open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    topics = {c.topic for c in summary.channels.values()}
    assert wanted <= topics, wanted - topics

    # Every panel the layout tree places is configured.
    def leaves(node: Any) -> list[str]:
        return [node] if isinstance(node, str) else leaves(node["first"]) + leaves(node["second"])

    assert set(leaves(layout["layout"])) == set(config)
