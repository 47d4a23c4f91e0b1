"""Camera calibration (beyond the thesis' fixed f = 525): a checkerboard seen from several
angles, OpenCV's corner finder and ``calibrateCameraExtended``, written as a small TOML file
that ``twopose-record new --calibration`` and plan files accept.

Done as the careful tools do it (OpenCV's sample, mrcal's advice):

- every distinct view counts: a folder of stills uses every image where the board is found;
  a camera or video keeps a frame only when the board has moved since the last kept view
  (mean corner displacement of at least ``min_motion_px``), not after a fixed frame count;
- the fit reports the standard deviation of every intrinsic, the RMS of every view, and
  drops a view whose RMS is far above the others (then fits again, naming it);
- it says how much of the image the corners covered, and warns when they never reached
  the outer third of the frame (where the distortion is, and so where it is learned);
- it warns when the views' file names fall into more than one family (``left*`` and
  ``right*``): one calibration is one camera's, and a folder of two cameras' stills fits as
  one camera with nothing else to show for it.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from recorder.calibration.board_size import refuse_larger_board
from recorder.sources.registry import FrameSource
from twopose.arrays import F32
from twopose.camera.model import SIGMA_KEYS, Intrinsics, intrinsics_sigma
from twopose.detect.checkerboard import board_pattern, find_board, outlier_view
from twopose.errors import InputValueError, SessionExistsError, SourceError
from twopose.values.bounds import INNER_CORNERS
from twopose.values.toml import read_toml

__all__ = [
    "Calibration",
    "calibrate",
    "fit_views",
    "load_calibration",
    "load_calibration_sigma",
    "save_calibration",
]

#: The corners should reach beyond this share of the half-diagonal from the image centre
#: (the outer third of the frame) at least once.
OUTER_THIRD = 2.0 / 3.0


@dataclass(frozen=True, kw_only=True)
class Calibration:
    """Intrinsics with the quality of the fit behind them."""

    intrinsics: Intrinsics
    rms_px: float
    n_views: int
    sigma: dict[str, float] = field(default_factory=dict)  # 1-sigma of SIGMA_KEYS
    view_rms_px: tuple[float, ...] = ()  # per kept view
    view_names: tuple[str, ...] = ()  # which frame each kept view was
    dropped: tuple[str, ...] = ()  # views dropped as outliers, with their RMS
    coverage: float = 0.0  # share of a 8x6 grid of image cells holding a corner
    reach: float = 0.0  # farthest corner from the centre / half-diagonal
    warnings: tuple[str, ...] = ()


@dataclass(kw_only=True)
class _Views:
    """The corner sets collected so far, with where each came from."""

    points: list[F32] = field(default_factory=list)
    names: list[str] = field(default_factory=list)
    size: tuple[int, int] | None = None


def _moved(corners: F32, views: _Views, min_motion_px: float) -> bool:
    """Whether the board moved since the last kept view (mean corner displacement)."""
    if not views.points:
        return True
    shift = np.linalg.norm(corners.reshape(-1, 2) - views.points[-1].reshape(-1, 2), axis=1)
    return float(shift.mean()) >= min_motion_px


def _collect(
    source: FrameSource,
    board: tuple[int, int],
    *,
    views: int | None,
    max_frames: int,
    min_motion_px: float | None,
    on_view: Callable[[int, bool], None] | None,
) -> _Views:
    """Read frames until ``views`` distinct views (every one, for stills) or the end."""
    kept = _Views()
    with source:
        stills = source.stills
        if min_motion_px is None:  # 5% of the image diagonal
            min_motion_px = 0.05 * float(np.hypot(source.info.width, source.info.height))
        for i in range(max_frames):
            if views is not None and len(kept.points) >= views:
                break
            try:
                frame = source.read()
            except SourceError:
                if i > 0:
                    break  # a folder or video that ran out: fit what it showed
                raise
            kept.size = (frame.shape[1], frame.shape[0])
            corners = find_board(frame, board)
            use = corners is not None and (stills or _moved(corners, kept, min_motion_px))
            if corners is not None and use:
                if not kept.points:  # once: the search costs a third of a second
                    refuse_larger_board(frame, board, corners, source.frame_name(i))
                kept.points.append(corners)
                kept.names.append(source.frame_name(i))
            if on_view is not None:
                on_view(i, corners is not None)
    return kept


def calibrate(
    source: FrameSource,
    board: tuple[int, int],
    square: float,
    *,
    views: int | None = None,
    max_frames: int = 1000,
    min_motion_px: float | None = None,
    on_view: Callable[[int, bool], None] | None = None,
) -> Calibration:
    """Collect the board's views from ``source`` and fit (see the module docstring).

    Parameters
    ----------
    source : FrameSource
        Opened by this function. A folder of stills uses every image with the board.
    board : (cols, rows)
        Inner corners of the checkerboard.
    square : float
        Side of a board square, in the session's units (scale does not change intrinsics).
    views : int, optional
        Stop after this many views (default: every still; 15 from a camera or video).
    max_frames : int
        Read at most this many frames.
    on_view : callable, optional
        Called with each frame's index and whether the board was found in it.
    min_motion_px : float, optional
        From a camera or video, a view is kept when its corners moved this far on average
        since the last kept one (default: 5% of the image diagonal).

    Returns
    -------
    Calibration
        The intrinsics and distortion, their 1-sigma, the RMS reprojection error and the
        views used.
    """
    cols, rows = board
    low = INNER_CORNERS.low  # OpenCV's board search needs more than 2 each way
    if cols < low or rows < low:
        raise InputValueError(
            f"the board needs at least {low:g}x{low:g} inner corners, got {cols}x{rows}"
        )
    kept = _collect(
        source,
        board,
        views=views if views is not None or source.stills else 15,
        max_frames=max_frames,
        min_motion_px=min_motion_px,
        on_view=on_view,
    )
    if len(kept.points) < 3 or kept.size is None:
        raise InputValueError(
            f"found the {cols}x{rows} board in only {len(kept.points)} view(s); need 3 or more "
            "(check --board: inner corners, not squares; show the board at different angles)"
        )
    return fit_views(kept.points, kept.names, kept.size, board_pattern(board, square))


def _fit(
    image_points: list[F32], pattern: NDArray[np.float32], size: tuple[int, int]
) -> tuple[
    float, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]
]:
    """OpenCV's fit: RMS, K, distortion, the intrinsics' sigmas and the per-view RMS."""
    objects = [pattern] * len(image_points)
    rms, K, dist, _, _, std_intrinsics, _, per_view = cv2.calibrateCameraExtended(
        objects, image_points, size, np.eye(3), np.zeros(5)
    )
    return (
        float(rms),
        np.asarray(K, np.float64),
        np.asarray(dist, np.float64).ravel(),
        np.asarray(std_intrinsics, np.float64).ravel(),
        np.asarray(per_view, np.float64).ravel(),
    )


def fit_views(
    image_points: list[F32],
    names: list[str],
    size: tuple[int, int],
    pattern: NDArray[np.float32],
) -> Calibration:
    """Fit the views; drop a view whose RMS is far above the others' and fit again."""
    rms, K, dist, std, per_view = _fit(image_points, pattern, size)
    dropped: list[str] = []
    while len(image_points) > 3:
        worst = outlier_view(per_view)
        if worst is None:
            break
        dropped.append(f"{names[worst]} (RMS {per_view[worst]:.2f} px)")
        image_points = image_points[:worst] + image_points[worst + 1 :]
        names = names[:worst] + names[worst + 1 :]
        rms, K, dist, std, per_view = _fit(image_points, pattern, size)
    d = [float(x) for x in dist[:5]] + [0.0] * 5
    intrinsics = Intrinsics(
        width=size[0],
        height=size[1],
        fx=float(K[0, 0]),
        fy=float(K[1, 1]),
        cx=float(K[0, 2]),
        cy=float(K[1, 2]),
        distortion=(d[0], d[1], d[2], d[3], d[4]),
    )  # fmt: skip
    coverage, reach = _coverage(image_points, size)
    warnings = _name_families(names)
    if reach < OUTER_THIRD:
        warnings.append(
            f"the corners never reached the outer third of the image (farthest at {reach:.0%} "
            "of the half-diagonal): the distortion is extrapolated there; show the board "
            "near the image's edges and corners too"
        )
    return Calibration(
        intrinsics=intrinsics,
        rms_px=rms,
        n_views=len(image_points),
        sigma={k: float(s) for k, s in zip(SIGMA_KEYS, std, strict=False)},
        view_rms_px=tuple(float(e) for e in per_view),
        view_names=tuple(names),
        dropped=tuple(dropped),
        coverage=coverage,
        reach=reach,
        warnings=tuple(warnings),
    )


def _name_families(names: list[str]) -> list[str]:
    """A warning when the views' names, numbers and suffix set aside, fall into several
    families of two or more (``left01.jpg`` ... and ``right01.jpg`` ...)."""
    families: dict[str, int] = {}
    for name in names:
        family = re.sub(r"[\d_\-. ]+$", "", Path(name).stem)
        families[family] = families.get(family, 0) + 1
    several = sorted(f"{f}*" for f, n in families.items() if n >= 2)
    if len(several) < 2:
        return []
    return [
        f"the views' file names fall into {len(several)} families ({', '.join(several)}): a "
        "calibration is one camera's; if these are several cameras' photographs, calibrate "
        f"each on its own files, e.g. --source 'images:DIR/{several[0]}'"
    ]


def _coverage(image_points: list[F32], size: tuple[int, int]) -> tuple[float, float]:
    """The share of an 8x6 grid of image cells holding a corner, and how far the farthest
    corner is from the centre (a share of the half-diagonal)."""
    w, h = size
    corners = np.concatenate([p.reshape(-1, 2) for p in image_points]).astype(np.float64)
    cells = np.zeros((6, 8), bool)
    col = np.clip((corners[:, 0] / w * 8).astype(int), 0, 7)
    row = np.clip((corners[:, 1] / h * 6).astype(int), 0, 5)
    cells[row, col] = True
    radius = np.hypot(corners[:, 0] - w / 2, corners[:, 1] - h / 2)
    return float(cells.mean()), float(radius.max() / np.hypot(w / 2, h / 2))


def save_calibration(calibration: Calibration, path: str | Path) -> None:
    """Write the calibration as TOML (refuses to overwrite)."""
    c = calibration
    i = c.intrinsics
    text = (
        "# twopose camera calibration (OpenCV plumb_bob)\n"
        f"width = {i.width}\nheight = {i.height}\n"
        f"fx = {i.fx!r}\nfy = {i.fy!r}\ncx = {i.cx!r}\ncy = {i.cy!r}\n"
        f"distortion = [{', '.join(repr(k) for k in i.distortion)}]\n"
        f"rms_px = {c.rms_px!r}\nviews = {c.n_views}\n"
        f"coverage = {c.coverage!r}  # share of an 8x6 grid of image cells with a corner\n"
        f"reach = {c.reach!r}  # farthest corner from the centre, share of the half-diagonal\n"
        f"view_names = [{', '.join(_quoted(n) for n in c.view_names)}]\n"
        f"view_rms_px = [{', '.join(repr(e) for e in c.view_rms_px)}]\n"
        f"dropped = [{', '.join(_quoted(n) for n in c.dropped)}]\n"
        f"warnings = [{', '.join(_quoted(n) for n in c.warnings)}]\n"
        f"\n[sigma]  # 1-sigma of each intrinsic (calibrateCameraExtended)\n"
        + "".join(f"{k} = {v!r}\n" for k, v in c.sigma.items())
    )
    try:
        with open(path, "x", encoding="utf-8") as fh:
            fh.write(text)
    except FileExistsError as err:
        raise SessionExistsError(f"{path} already exists; choose another calibration file") from err


def _quoted(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


_FILE_KEYS = {"rms_px", "views", "coverage", "reach", "view_names", "view_rms_px", "dropped"}
_FILE_KEYS |= {"warnings", "sigma"}


def load_calibration(path: str | Path) -> Intrinsics:
    """Read a calibration file written by :func:`save_calibration` (or by hand)."""
    data = read_toml(path, "calibration", InputValueError)
    intrinsics = {k: v for k, v in data.items() if k not in _FILE_KEYS}
    return Intrinsics.from_dict(intrinsics, f"calibration {path}")


def load_calibration_sigma(path: str | Path) -> dict[str, float]:
    """The 1-sigma of each intrinsic a calibration file keeps ({} for older files)."""
    data = read_toml(path, "calibration", InputValueError)
    sigma = data.get("sigma", {})
    if not isinstance(sigma, dict):
        raise InputValueError(f"calibration {path}: [sigma] must be a table")
    try:
        return intrinsics_sigma(sigma)
    except InputValueError as err:
        raise InputValueError(f"calibration {path}: [sigma]: {err}") from err
