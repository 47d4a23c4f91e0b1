"""overlay: a detection drawn as foxglove.ImageAnnotations (used live and in results.mcap)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from twopose.detect.detection import GloveParams, detect_glove
from twopose.display.scene import GREEN, image_annotations


def test_rejected_candidates_are_drawn_in_red_with_the_reason() -> None:
    img = np.full((240, 320, 3), 200, np.uint8)
    cv2.circle(img, (100, 120), 25, (200, 90, 30), -1)  # blue (BGR) and round: not a finger
    det = detect_glove(img)
    assert not det.found
    msg = image_annotations(det, 5, "trial 1 pose 1 frame 0")
    red = [p for p in msg.points if p.outline_color.r > 0.9 and p.outline_color.g < 0.5]
    assert len(red) == 1
    xs = [pt.x for pt in red[0].points]
    assert 70 < min(xs) < 80
    assert 120 < max(xs) < 130
    assert any(t.text.startswith("eccentricity") for t in msg.texts)
    assert "rejected" in msg.texts[-1].text


def test_a_found_blob_is_drawn_green_with_centroid_and_orientation() -> None:
    img = np.full((240, 320, 3), 128, np.uint8)
    cv2.line(img, (120, 97), (200, 143), (192, 108, 38), 30, lineType=cv2.LINE_AA)  # a finger
    det = detect_glove(img, GloveParams(pi_min=2.5, pi_max=3.2))
    assert det.found, det.reason
    msg = image_annotations(det, 7, "trial 2 pose 1 frame 3")
    (circle,) = msg.circles
    np.testing.assert_allclose([circle.position.x, circle.position.y], det.centroid_px)
    assert (circle.outline_color.r, circle.outline_color.g) == pytest.approx(GREEN[:2], abs=1e-6)
    line = [p for p in msg.points if len(p.points) == 2]
    assert len(line) == 1  # the orientation line through the centroid
    (a, b) = line[0].points
    angle = np.degrees(np.arctan2(b.y - a.y, b.x - a.x))
    assert abs(((angle - det.theta_deg) + 90) % 180 - 90) < 1e-6
    assert msg.texts[-1].text == "trial 2 pose 1 frame 3: found"
    assert all(t.timestamp.ToNanoseconds() == 7 for t in msg.texts)
