"""The docs' screenshots, written by the browser tests that take them (issue 35): the home,
recording and analysis pages show what the user sees, and can never go stale.

A browser test hands each screenshot it takes for the docs to :func:`doc_image`, which
compares it with ``docs/images/<name>`` by what a reader sees (issue 53), not pixel by
pixel: it fails when the page's size changed, when text or shapes changed (more than
:data:`INK_PIXELS` pixels whose grey level moved by more than :data:`INK_LEVELS`, within
some :data:`WINDOW_PX`-pixel square: a word, a line moved, a chart gone), or when a
:data:`SHADE_BLOCK_PX`-pixel block's mean shade moved by more than :data:`SHADE_LEVELS`
(a colour, a picture). Its message names each region that changed, where on the page and
what is drawn there; the page as drawn now is written to ``results/doc-images/<name>``
(CI keeps ``results/``). Text that differs from run to run by nature (a temporary path, a
timing) is named by the test as ``volatile`` and left out of the comparison.

The tolerances were measured: the report drawn with three font sets (the machine's DejaVu
fonts; matplotlib's STIX fonts alone; DejaVu with Liberation, which Chromium's
recommended packages bring) differs in no pixel, its pages naming the fonts they carry
(twopose/display/fonts.py); two runs of the console differ by at most 50 changed pixels in a
window once its path, timings and live picture are left out (a caret's blink, one digit).
Against them: one changed digit is 32 pixels (not seen), a changed word 295, a renamed link
410 (its line moved), the machine's fonts instead of the page's 1,403 in a window.

``TWOPOSE_WRITE_DOC_IMAGES=1`` writes the images instead (after a change of the page,
then look at them and commit).
"""

from __future__ import annotations

import io
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from PIL import Image
from scipy import ndimage

REPO = Path(__file__).resolve().parents[1]
DOC_IMAGES = REPO / "docs" / "images"
#: Where a stale image's page, as drawn now, is written for a person to compare.
FRESH_IMAGES = REPO / "results" / "doc-images"
WRITE = "TWOPOSE_WRITE_DOC_IMAGES"

#: A pixel's grey level moved by more than this: ink changed, not a shade of its edge.
INK_LEVELS = 48
#: The square the changed pixels are counted in, and how many it may hold.
WINDOW_PX = 64
INK_PIXELS = 100
#: A block's mean grey level may move by this much (a colour's anti-aliasing, not a colour).
SHADE_BLOCK_PX = 32
SHADE_LEVELS = 16.0
#: Changed pixels this close together are one region of the message.
REGION_GAP_PX = 12

#: The console's text that differs from run to run: the session's path (a temporary
#: folder), the last capture's line (the recorder's overhead, a timing), the notes (they
#: name the operator's noise file, in the test's temporary folder) and the capture's
#: numbers (its frames' table, their average and the preview's estimate: from whichever
#: frames the synthetic camera delivered to the capture, as a camera's would vary), and the
#: live camera's picture: each of its frames has its own lighting (the scene's gain jitter
#: 4%, gradient 5%), which moved a 32-pixel block of a CI run's screenshot by 18 levels,
#: over :data:`SHADE_LEVELS`. That a frame is drawn there is checked by the tests
#: (``live_frame_drawn``), not by its shades.
CONSOLE_VOLATILE = (
    "[data-testid=live-image]",
    "[data-testid=session-file]",
    "[data-testid=last-capture]",
    "[data-testid=notices]",
    "[data-testid=preview-result]",
    "[data-testid=frames-table]",
    "[data-testid=pose-average]",
)

Rect = tuple[int, int, int, int]  # x0, y0, x1, y1 (px, x1 and y1 excluded)


@dataclass(frozen=True)
class Change:
    """A region of the page that a reader would see changed."""

    rect: Rect
    pixels: int  # changed pixels (INK_LEVELS) in it
    shade: float  # its largest block's change of mean grey level

    def where(self, size: tuple[int, int]) -> str:
        """The region's place on a page of ``size``: "top left", "middle", ..."""
        x0, y0, x1, y1 = self.rect
        thirds = (("top", "middle", "bottom"), ("left", "centre", "right"))
        row = thirds[0][min(2, 3 * (y0 + y1) // 2 // max(1, size[1]))]
        column = thirds[1][min(2, 3 * (x0 + x1) // 2 // max(1, size[0]))]
        return "middle" if (row, column) == ("middle", "centre") else f"{row} {column}"


def grey(png: bytes) -> NDArray[np.float64]:
    """A PNG's grey levels (0-255), rows by columns."""
    return np.asarray(Image.open(io.BytesIO(png)).convert("L"), dtype=np.float64)


def changes(
    fresh: NDArray[np.float64], kept: NDArray[np.float64], volatile: Sequence[Rect] = ()
) -> list[Change]:
    """The regions where ``fresh`` differs from ``kept`` (same shape) as a reader would see,
    largest first; ``volatile`` rectangles are left out."""
    diff = np.abs(fresh - kept)
    for x0, y0, x1, y1 in volatile:
        diff[max(0, y0) : max(0, y1), max(0, x0) : max(0, x1)] = 0.0
    ink = diff > INK_LEVELS
    window = ndimage.uniform_filter(ink.astype(np.float64), WINDOW_PX, mode="constant")
    too_much_ink = window * WINDOW_PX**2 > INK_PIXELS + 0.5
    shades = _block_means(diff)
    too_dark = np.kron(shades > SHADE_LEVELS, np.ones((SHADE_BLOCK_PX, SHADE_BLOCK_PX)))
    seen = np.zeros_like(ink)
    seen[: too_dark.shape[0], : too_dark.shape[1]] = too_dark > 0
    # A shaded block marks the pixels that changed in it and its neighbours; a window
    # over the tolerance, its changed pixels.
    seen = _spread(seen, 3 * SHADE_BLOCK_PX) & (diff > SHADE_LEVELS / 2)
    seen |= _spread(too_much_ink, WINDOW_PX) & ink
    labels, _n = ndimage.label(_spread(seen, 2 * REGION_GAP_PX + 1))
    found = []
    for box in ndimage.find_objects(labels):
        if box is None:
            continue
        rows, cols = box
        part = seen[box]
        ys, xs = np.nonzero(part)
        rect = (
            cols.start + int(xs.min()),
            rows.start + int(ys.min()),
            cols.start + int(xs.max()) + 1,
            rows.start + int(ys.max()) + 1,
        )
        y0, x0 = rect[1] // SHADE_BLOCK_PX, rect[0] // SHADE_BLOCK_PX
        y1, x1 = -(-rect[3] // SHADE_BLOCK_PX), -(-rect[2] // SHADE_BLOCK_PX)
        found.append(
            Change(rect, int(ink[box].sum()), float(shades[y0:y1, x0:x1].max(initial=0.0)))
        )
    return sorted(found, key=lambda c: (c.pixels, c.shade), reverse=True)


def _spread(mask: NDArray[np.bool_], size: int) -> NDArray[np.bool_]:
    """``mask`` grown by a ``size``-pixel square around each of its pixels."""
    return ndimage.maximum_filter(mask.astype(np.uint8), size, mode="constant") > 0


def _block_means(diff: NDArray[np.float64]) -> NDArray[np.float64]:
    """The mean of ``diff`` over each whole SHADE_BLOCK_PX square."""
    k = SHADE_BLOCK_PX
    h, w = diff.shape[0] // k, diff.shape[1] // k
    return diff[: h * k, : w * k].reshape(h, k, w, k).mean(axis=(1, 3))


def _rects(driver: Any, element: Any, selectors: Sequence[str]) -> tuple[list[Rect], Rect]:
    """The viewport boxes of ``selectors``' elements, in the screenshot's pixels (of
    ``element``'s box, when the screenshot is an element's), and that origin."""
    script = (
        "const [el, sels] = arguments;"
        "const o = el ? el.getBoundingClientRect() : {left: 0, top: 0};"
        "const boxes = sels.flatMap(s => [...document.querySelectorAll(s)])"
        ".map(e => e.getBoundingClientRect())"
        ".map(r => [r.left - o.left, r.top - o.top, r.right - o.left, r.bottom - o.top]);"
        "return [boxes, [o.left, o.top, 0, 0]];"
    )
    boxes, origin = driver.execute_script(script, element, list(selectors))
    rounded = [(int(a), int(b), int(np.ceil(c)), int(np.ceil(d))) for a, b, c, d in boxes]
    return rounded, tuple(int(v) for v in origin)  # type: ignore[return-value]


def _what_is_at(driver: Any, origin: Rect, change: Change) -> str:
    """The element drawn at a change's centre and the start of its text (for the message)."""
    x0, y0, x1, y1 = change.rect
    script = (
        "const e = document.elementFromPoint(arguments[0], arguments[1]);"
        "if (!e) return '';"
        "const name = e.tagName.toLowerCase() + (e.id ? '#' + e.id : '');"
        "const text = (e.textContent || '').trim().replace(/\\s+/g, ' ').slice(0, 60);"
        "return text ? name + ' \"' + text + '\"' : name;"
    )
    cx, cy = origin[0] + (x0 + x1) // 2, origin[1] + (y0 + y1) // 2
    return str(driver.execute_script(script, cx, cy) or "")


def doc_image(
    name: str,
    png: bytes,
    *,
    driver: Any = None,
    element: Any = None,
    volatile: Sequence[str] = (),
) -> None:
    """Check (or, with ``TWOPOSE_WRITE_DOC_IMAGES=1``, write) the docs' image ``name``.

    ``driver``: the browser that drew ``png`` (the message then names what is drawn where
    the page changed), ``element`` the element ``png`` is a screenshot of (else the
    window), ``volatile`` the CSS selectors of text that differs by run (left out)."""
    path = DOC_IMAGES / name
    if os.environ.get(WRITE):
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(png)
        return
    redo = f"run the test with {WRITE}=1, look at docs/images/{name} and commit it"
    assert path.is_file(), f"docs/images/{name} is missing: {redo}"
    fresh, kept = grey(png), grey(path.read_bytes())
    size, kept_size = fresh.shape[::-1], kept.shape[::-1]
    if size != kept_size:
        _keep_fresh(name, png)
        raise AssertionError(f"docs/images/{name} is {kept_size}, the page {size}: {redo}")
    boxes, origin = _rects(driver, element, volatile) if driver is not None else ([], (0,) * 4)
    found = changes(fresh, kept, boxes)
    if not found:
        return
    _keep_fresh(name, png)
    lines = []
    for change in found[:4]:
        x0, y0, x1, y1 = change.rect
        what = _what_is_at(driver, origin, change) if driver is not None else ""
        lines.append(
            f"x {x0}-{x1}, y {y0}-{y1} px ({change.where(size)}"
            f"{', ' + what if what else ''}): {change.pixels} pixels changed"
            f"{f', a block {change.shade:.0f} levels' if change.shade > SHADE_LEVELS else ''}"
        )
    more = f"; and {len(found) - 4} more" if len(found) > 4 else ""
    raise AssertionError(
        f"docs/images/{name} is stale: the page changed in {len(found)} region(s): "
        + "; ".join(lines)
        + f"{more} (the page now: results/doc-images/{name}): {redo}"
    )


def live_frame_drawn(driver: Any, png: bytes) -> str:
    """What is wrong with the console's live picture in ``png`` (the window's screenshot),
    or "" when a camera frame is drawn there: the image loaded a frame and its pixels are a
    picture (their grey levels spread), not a blank box."""
    script = (
        "const e = document.querySelector('[data-testid=live-image]');"
        "if (!e) return null; const r = e.getBoundingClientRect();"
        "return [e.naturalWidth, r.left, r.top, r.right, r.bottom];"
    )
    found = driver.execute_script(script)
    if found is None:
        return "the page has no live image"
    natural, x0, y0, x1, y1 = found
    if not natural:
        return "the live image holds no frame"
    box = grey(png)[max(0, int(y0)) : int(y1), max(0, int(x0)) : int(x1)]
    if box.size == 0 or float(box.std()) < 10.0:
        return f"the live image is blank (grey levels' spread {box.std() if box.size else 0:.1f})"
    return ""


def _keep_fresh(name: str, png: bytes) -> None:
    FRESH_IMAGES.mkdir(parents=True, exist_ok=True)
    (FRESH_IMAGES / name).write_bytes(png)
