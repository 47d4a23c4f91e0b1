"""The glove filter's shortcuts are exact: the same mask, bit for bit, as the plain
full-frame formulation (normalized RGB on every pixel, ``cvtColor`` of the frame, OpenCV's
Otsu on the masked grey image), whatever the image."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from twopose.detect.detectors import (
    _components,
    _glove_mask,
    _grey_formula,
    _grey_weights_hold,
    _otsu_foreground,
    detect_glove,
)
from twopose.detect.thresholds import GloveParams
from twopose.format.messages import Frame
from twopose.format.reader import SessionReader

SESSIONS = Path(__file__).resolve().parents[2] / "sessions"


def _plain_mask(image: np.ndarray, p: GloveParams) -> np.ndarray:
    """The thesis' filter as first written: every pixel, the whole frame's grey, Otsu."""
    b, g, r = (c.astype(np.int64) for c in cv2.split(image))
    s = r * r + g * g + b * b
    r2, g2, b2 = (round(v**2 * 10_000) for v in (p.r_max, p.g_min, p.b_min))
    keep = (
        (r * r * 10_000 <= r2 * s) & (g * g * 10_000 >= g2 * s) & (b * b * 10_000 >= b2 * s)
    ) & (s > 0)
    keep8: np.ndarray = keep.astype(np.uint8)
    if not p.use_otsu or not keep.any():
        return keep8
    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    masked = cv2.bitwise_and(grey, grey, mask=keep8)
    _, bw = cv2.threshold(masked, 0, 1, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    return np.asarray(bw, dtype=np.uint8)


def _scene(rng: np.random.Generator, h: int, w: int, kind: int) -> np.ndarray:
    if kind == 0:  # noise: candidates everywhere
        return rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    if kind == 1:  # blue ellipses on grey, blurred: the glove's case
        img = np.clip(rng.normal(150, 30, (h, w, 3)), 0, 255).astype(np.uint8)
        for _ in range(int(rng.integers(0, 8))):
            centre = (int(rng.integers(0, w)), int(rng.integers(0, h)))
            axes = (int(rng.integers(1, max(2, w // 4))), int(rng.integers(1, max(2, h // 4))))
            colour = (
                int(rng.integers(120, 256)),
                int(rng.integers(40, 160)),
                int(rng.integers(90)),
            )
            cv2.ellipse(img, centre, axes, float(rng.uniform(0, 180)), 0, 360, colour, -1)
        return cv2.GaussianBlur(img, (3, 3), 0)
    palette = rng.integers(0, 256, (int(rng.integers(1, 4)), 3)).astype(np.uint8)
    palette[0] = (200, 120, 40)  # few grey levels: ties in Otsu's histogram
    return np.ascontiguousarray(palette[rng.integers(0, len(palette), (h, w))])


PARAMS = [
    GloveParams(),
    GloveParams(use_otsu=False),
    GloveParams(r_max=0.7, b_min=0.5),  # b_min < r_max: every pixel is a candidate
    GloveParams(g_min=0.0),
]


@pytest.mark.parametrize("seed", range(4))
def test_the_glove_mask_is_the_plain_filters_on_random_scenes(seed: int) -> None:
    rng = np.random.default_rng(seed)
    for k in range(30):
        h, w = [(480, 640), (60, 80), (1, 1), (3, 7), (240, 320)][k % 5]
        img = _scene(rng, h, w, k % 3)
        for p in PARAMS:
            assert np.array_equal(_glove_mask(img, p), _plain_mask(img, p)), (seed, k, p)


def test_the_glove_mask_is_the_plain_filters_on_the_bundled_frames() -> None:
    """Every 7th frame of the bundled glove sessions (ground and line)."""
    n = 0
    for path in sorted(SESSIONS.glob("*ground*.mcap")) + sorted(SESSIONS.glob("*line*.mcap")):
        with SessionReader(path) as reader:
            frames = [e for e in reader.iter_entries() if isinstance(e, Frame)]
        for frame in frames[::7]:
            img = frame.decode()
            assert np.array_equal(_glove_mask(img, GloveParams()), _plain_mask(img, GloveParams()))
            n += 1
    assert n > 100


def test_the_grey_formula_is_opencvs_for_every_colour() -> None:
    """All 2^24 colours, in slices: the fixed-point weights are this OpenCV's own."""
    assert _grey_weights_hold()
    step = 1 << 20
    for start in range(0, 1 << 24, step):
        v = np.arange(start, start + step, dtype=np.int32)
        b, g, r = v >> 16, (v >> 8) & 255, v & 255
        image = np.stack((b, g, r), axis=-1).astype(np.uint8).reshape(-1, 1, 3)
        want = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY).ravel()
        assert np.array_equal(_grey_formula(b, g, r), want), start


def _histogram_image(rng: np.random.Generator, h: int, w: int) -> np.ndarray:
    """A masked grey image like the filter's: mostly zeros, some levels above."""
    n = h * w
    kept = int(rng.integers(0, max(1, n // 10)))
    kind = int(rng.integers(0, 4))
    if kind == 0:
        levels = rng.integers(1, 256, kept)
    elif kind == 1:
        levels = np.clip(rng.normal(rng.uniform(20, 230), rng.uniform(1, 40), kept), 1, 255)
    elif kind == 2:
        half = kept // 2
        levels = np.concatenate(
            [rng.normal(60, 10, half).clip(1, 255), rng.normal(180, 10, kept - half).clip(1, 255)]
        )
    else:
        levels = rng.choice(rng.integers(1, 256, int(rng.integers(1, 4))), kept)
    image = np.zeros(n, np.uint8)
    image[rng.choice(n, kept, replace=False)] = levels.astype(np.uint8)
    return image.reshape(h, w)


@pytest.mark.parametrize("seed", range(3))
def test_otsu_from_the_histogram_is_opencvs_or_defers_to_it(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    decided = 0
    for k in range(400):
        h, w = [(480, 640), (30, 40), (1, 5), (2, 3), (100, 1)][k % 5]
        image = _histogram_image(rng, h, w)
        _, want = cv2.threshold(image, 0, 1, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
        flat = image.ravel()
        kept = np.flatnonzero(flat)
        foreground = _otsu_foreground(flat[kept], flat.size)
        if foreground is None:  # a near tie or a single level: OpenCV decides
            continue
        decided += 1
        got = np.zeros(flat.size, np.uint8)
        got[kept[foreground]] = 1
        assert np.array_equal(got, want.ravel()), (seed, k)
    assert decided > 200  # the rest: no kept pixel, one level, or a near tie


def test_otsu_defers_on_an_exact_tie() -> None:
    """Five levels, symmetric: two splits tie exactly, and OpenCV's (IPP's) rounding
    decides which; the histogram shortcut leaves it to OpenCV."""
    grey = np.array([93, 119, 161, 203, 229], np.uint8)
    assert _otsu_foreground(grey, 5) is None


@pytest.mark.parametrize("seed", range(3))
def test_components_skip_labelling_only_where_no_other_box_reaches(seed: int) -> None:
    """Blobs inside holes, touching boxes, lone blobs: the same shapes as labelling every
    component (connectedComponentsWithStats' areas and centroids)."""
    rng = np.random.default_rng(seed)
    mask = np.zeros((200, 260), np.uint8)
    for _ in range(12):
        centre = (int(rng.integers(0, 260)), int(rng.integers(0, 200)))
        axes = (int(rng.integers(3, 30)), int(rng.integers(3, 30)))
        cv2.ellipse(mask, centre, axes, float(rng.uniform(0, 180)), 0, 360, 1, -1)
        if rng.random() < 0.5:  # a hole, and sometimes a blob inside it
            cv2.ellipse(mask, centre, (axes[0] // 2, axes[1] // 2), 0, 0, 360, 0, -1)
            if rng.random() < 0.5:
                cv2.circle(mask, centre, max(1, min(axes) // 5), 1, -1)
    n, _, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
    n_blobs, shapes = _components(mask, 20.0)
    assert n_blobs == n - 1
    want = sorted(
        (int(stats[i, 4]), *np.round(centroids[i], 9)) for i in range(1, n) if stats[i, 4] >= 20
    )
    got = sorted((int(s.area), round(s.centroid[0], 9), round(s.centroid[1], 9)) for s in shapes)
    assert got == want


def test_detect_glove_is_unchanged_on_a_bundled_frame() -> None:
    """One frame's detection, pinned (the same as before the shortcuts)."""
    with SessionReader(SESSIONS / "thesis_method2_ground.mcap") as reader:
        frame = next(e for e in reader.iter_entries() if isinstance(e, Frame))
    d = detect_glove(frame.decode())
    plain = _plain_mask(frame.decode(), GloveParams())
    n_blobs, shapes = _components(plain, GloveParams().min_area_px)
    assert d.n_blobs == n_blobs
    assert d.found == any(s.centroid == d.centroid_px for s in shapes)
