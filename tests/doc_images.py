"""The docs' screenshots, written by the browser tests that take them (issue 35): the home,
recording and analysis pages show what the user sees, and can never go stale.

A browser test hands each screenshot it takes for the docs to :func:`doc_image`, which
compares it with ``docs/images/<name>``: a page that changed (another size, or a thumbnail
that differs on average by more than :data:`STALE_LEVELS` grey levels: more than a live
camera image's noise) fails the test, naming the file. ``TWOPOSE_WRITE_DOC_IMAGES=1``
writes them instead (after a change of the page, then look at them and commit).
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
from PIL import Image

DOC_IMAGES = Path(__file__).resolve().parents[1] / "docs" / "images"
WRITE = "TWOPOSE_WRITE_DOC_IMAGES"
#: Mean absolute difference (grey levels, of 255) of 1/8-size thumbnails beyond which the
#: docs' image no longer shows the page.
STALE_LEVELS = 10.0


def _thumbnail(png: bytes) -> tuple[tuple[int, int], np.ndarray]:
    image = Image.open(io.BytesIO(png)).convert("L")
    small = image.resize(
        (max(1, image.width // 8), max(1, image.height // 8)), Image.Resampling.BILINEAR
    )
    return image.size, np.asarray(small, dtype=np.float64)


def doc_image(name: str, png: bytes) -> None:
    """Check (or, with ``TWOPOSE_WRITE_DOC_IMAGES=1``, write) the docs' image ``name``."""
    path = DOC_IMAGES / name
    if os.environ.get(WRITE):
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(png)
        return
    redo = f"run the test with {WRITE}=1, look at docs/images/{name} and commit it"
    assert path.is_file(), f"docs/images/{name} is missing: {redo}"
    (size, fresh), (kept_size, kept) = _thumbnail(png), _thumbnail(path.read_bytes())
    assert size == kept_size, f"docs/images/{name} is {kept_size}, the page {size}: {redo}"
    level = float(np.abs(fresh - kept).mean())
    assert level <= STALE_LEVELS, f"docs/images/{name} is stale ({level:.1f} levels): {redo}"
