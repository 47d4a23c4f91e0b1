"""The docs' pictures are checked by what a reader sees (tests/doc_images.py, issue 53):
on the committed picture of the report's top, a word taken away, a line moved, a panel
shaded or a page of another size fails and the message says where; pixel noise (a
picture drawn with other anti-aliasing, a camera's next frame) and what a test names
as varying by run do not."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tests import doc_images
from tests.doc_images import DOC_IMAGES, changes, doc_image, grey

NAME = "report-answer.png"


@pytest.fixture
def page(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> np.ndarray:
    """The committed picture's grey levels (a stale picture is written under tmp_path)."""
    monkeypatch.delenv(doc_images.WRITE, raising=False)
    monkeypatch.setattr(doc_images, "FRESH_IMAGES", tmp_path / "fresh")
    return grey((DOC_IMAGES / NAME).read_bytes())


def _png(levels: np.ndarray) -> bytes:
    out = io.BytesIO()
    Image.fromarray(np.clip(levels, 0, 255).astype(np.uint8)).save(out, format="PNG")
    return out.getvalue()


def _inked(levels: np.ndarray) -> tuple[int, int, int, int]:
    """The first line of text (its box) in the top half: rows and columns with ink."""
    rows = np.flatnonzero((levels[:300] < 128).any(axis=1))
    first = rows[: np.argmax(np.diff(rows) > 3) + 1]  # the title's rows
    cols = np.flatnonzero((levels[first[0] : first[-1] + 1] < 128).any(axis=0))
    return int(cols[0]), int(first[0]), int(cols[-1]) + 1, int(first[-1]) + 1


def test_the_same_picture_and_pixel_noise_pass(page: np.ndarray) -> None:
    doc_image(NAME, (DOC_IMAGES / NAME).read_bytes())
    noise = np.random.default_rng(53).integers(-20, 21, page.shape)
    doc_image(NAME, _png(page + noise))  # anti-aliasing and a camera's noise


def test_a_word_taken_away_fails_and_the_message_says_where(page: np.ndarray) -> None:
    x0, y0, _x1, y1 = _inked(page)
    edited = page.copy()
    edited[y0:y1, x0 : x0 + 60] = 255.0  # the title's first letters gone
    with pytest.raises(AssertionError) as failed:
        doc_image(NAME, _png(edited))
    message = str(failed.value)
    assert "is stale: the page changed in 1 region(s)" in message, message
    found = changes(grey(_png(edited)), page)
    (cx0, cy0, cx1, cy1) = found[0].rect
    assert x0 <= cx0 < cx1 <= x0 + 60, (found[0].rect, x0)
    assert y0 <= cy0 < cy1 <= y1, (found[0].rect, y0)
    assert f"x {cx0}-{cx1}, y {cy0}-{cy1} px (top left)" in message
    assert (doc_images.FRESH_IMAGES / NAME).read_bytes() == _png(edited)  # the page now
    # A test that names that region as varying by run is not failed by it.
    assert changes(grey(_png(edited)), page, [(x0, y0, x0 + 60, y1)]) == []


def test_a_line_moved_by_two_pixels_or_a_shaded_panel_fails(page: np.ndarray) -> None:
    x0, y0, x1, y1 = _inked(page)
    moved = page.copy()
    moved[y0 + 2 : y1 + 2, x0:x1] = page[y0:y1, x0:x1]
    assert changes(moved, page), "a line moved"
    shaded = page.copy()
    shaded[400:500, 900:1100] -= 30.0  # a panel's background, a shade darker
    found = changes(shaded, page)
    assert found
    assert found[0].shade == pytest.approx(30.0)
    assert found[0].rect == (900, 400, 1100, 500)


def test_a_page_of_another_size_fails(page: np.ndarray) -> None:
    with pytest.raises(AssertionError, match=r"is \(1366, 625\), the page \(1366, 600\)"):
        doc_image(NAME, _png(page[:600]))
