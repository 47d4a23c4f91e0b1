"""``twopose-record calibrate-pair``: a pair of cameras calibrated from stills of a board.

The board (a checkerboard) is shown to both cameras at once at several places and tilts;
each moment is a pair of stills, camera 1's (``--left``) and camera 2's (``--right``),
paired by their sorted file names (whose numbers must agree: ``left03.jpg`` with
``right03.jpg``), or a pair of frames from two live cameras (``--source pair:A,B``: the
pairs :mod:`recorder.calibration.pair_live` keeps). :func:`calibrate_pair_views` takes the pairs
from
any iterator of ``(name, left image, right image)`` and fits the pair
(:func:`twopose.pair.calibration.fit_pair`): each camera's intrinsics from its calibration
file, or fitted on its own views by the one-camera fit
(:func:`recorder.calibration.camera.fit_views`), said which. A board lying on the floor,
seen by both (``--floor-left``, ``--floor-right``), gives the floor plane.
:func:`calibrate_pair` is the whole command as one call: it refuses an existing output
before any work, pairs the files, loads the calibration files, fits, checks, and writes the
pair file (:mod:`twopose.pair.pair_file`).
"""

from __future__ import annotations

import dataclasses
import glob
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from recorder.calibration.board_size import refuse_larger_board
from recorder.calibration.camera import (
    Calibration,
    fit_views,
    load_calibration,
    load_calibration_sigma,
)
from recorder.calibration.pair_live import numbers_differ
from recorder.sources.registry import IMAGE_SUFFIXES
from twopose.arrays import F32
from twopose.camera.model import Intrinsics
from twopose.detect.checkerboard import board_pattern, find_board
from twopose.errors import InputValueError, SessionExistsError, TwoposeError
from twopose.pair.board_fit import BoardCorners
from twopose.pair.calibration import MIN_VIEWS, FloorPlane, PairCalibration, fit_pair
from twopose.pair.floor import floor_from_board, with_floor
from twopose.pair.pair_file import write_pair_file
from twopose.values.units import Units, unit_spec

if TYPE_CHECKING:
    from recorder.calibration.pair_live import LiveOutcome

__all__ = [
    "FloorStills",
    "PairCalibrationRun",
    "PairRequest",
    "StillPair",
    "calibrate_pair",
    "calibrate_pair_views",
    "read_still_pairs",
    "still_pairs",
]

Image = NDArray[np.uint8]
#: One moment seen by both cameras: its name, camera 1's image, camera 2's image.
StillPair = tuple[str, Image, Image]
#: How many fitted views each camera's own fit needs (the one-camera fit's least).
MIN_OWN_VIEWS = 3
#: A camera's intrinsics and their 1-sigma (its calibration file's).
Calibrated = tuple[Intrinsics, dict[str, float]]


@dataclass(frozen=True, kw_only=True)
class PairCalibrationRun:
    """What ``calibrate-pair`` did: the calibration and how it came about.

    ``pair`` the calibration (with its floor if one was given); ``used`` the pairs fitted;
    ``skipped`` the pairs whose board was not found in both cameras, each saying where it
    was missing; ``intrinsics_from`` the intrinsics' origin in words; ``own`` each camera's
    own fit when the intrinsics were fitted here (None: from a calibration file);
    ``path`` the pair file written (None: not written); ``live`` how a live ``pair:``
    source's collection went (None: stills).
    """

    pair: PairCalibration
    used: tuple[str, ...]
    skipped: tuple[str, ...]
    intrinsics_from: str
    own: tuple[Calibration | None, Calibration | None] = (None, None)
    path: Path | None = None
    live: LiveOutcome | None = None


@dataclass(frozen=True, kw_only=True)
class FloorStills:
    """A board lying on the floor: camera 1's image (camera 2's, if it saw it), and the
    board's printed face's height above the floor (the pair's units)."""

    left: Image
    right: Image | None = None
    thickness: float = 0.0


@dataclass(frozen=True, kw_only=True)
class PairRequest:
    """What ``calibrate-pair`` is asked (its command line, as one record).

    ``out`` the pair file to write; ``left``/``right`` file patterns of camera 1's and
    camera 2's stills, or ``source`` a ``pair:A,B`` source read live (``views`` the pairs
    it keeps: :class:`recorder.calibration.pair_live.LiveRules`); ``board`` inner corners (cols,
    rows); ``square`` a square's side in ``units``; ``calibration_left``/
    ``calibration_right`` each camera's calibration file (both or neither: neither fits
    each camera on its own views); ``floor_left``/``floor_right`` stills of a board lying
    on the floor (camera 1's needed for a floor); ``board_thickness`` that board's printed
    face above the floor, in ``units``.
    """

    out: Path
    left: str | None = None
    right: str | None = None
    board: tuple[int, int]
    square: float
    units: Units
    source: str | None = None
    views: int | None = None
    calibration_left: Path | None = None
    calibration_right: Path | None = None
    floor_left: Path | None = None
    floor_right: Path | None = None
    board_thickness: float = 0.0


@dataclass(kw_only=True)
class _Found:
    """The boards found so far: both cameras' corners per pair, and each camera's own."""

    left: list[F32]
    right: list[F32]
    names: list[str]
    own: tuple[list[tuple[str, F32]], list[tuple[str, F32]]]
    skipped: list[str]
    size: list[tuple[int, int] | None]


def _find_all(
    pairs: Iterable[StillPair],
    board: tuple[int, int],
    on_pair: Callable[[str, tuple[bool, bool]], None] | None,
) -> _Found:
    """Every pair's board in both images; each camera's image size checked constant."""
    found = _Found(left=[], right=[], names=[], own=([], []), skipped=[], size=[None, None])
    for name, left, right in pairs:
        corners = []
        for n, image in enumerate((left, right)):
            size = (int(image.shape[1]), int(image.shape[0]))
            if found.size[n] is not None and found.size[n] != size:
                raise InputValueError(
                    f"{name}: camera {n + 1}'s image is {size[0]}x{size[1]}, its earlier ones "
                    f"{found.size[n][0]}x{found.size[n][1]}: one camera's stills come at one size"  # type: ignore[index]
                )
            found.size[n] = size
            c = find_board(image, board)
            corners.append(c)
            if c is not None:
                found.own[n].append((name, c))
        if on_pair is not None:
            on_pair(name, (corners[0] is not None, corners[1] is not None))
        if corners[0] is not None and corners[1] is not None:
            if not found.names:  # once: the first pair (the search costs a third of a second)
                refuse_larger_board(left, board, corners[0], f"{name} (camera 1)")
            found.left.append(corners[0])
            found.right.append(corners[1])
            found.names.append(name)
        else:
            missing = [f"camera {n + 1}" for n, c in enumerate(corners) if c is None]
            found.skipped.append(f"{name} (no board in {' or '.join(missing)})")
    return found


def _intrinsics(
    found: _Found,
    board: tuple[int, int],
    square: float,
    given: tuple[Calibrated, Calibrated] | None,
    given_from: str,
) -> tuple[tuple[Calibrated, Calibrated], str, tuple[Calibration | None, Calibration | None]]:
    """Each camera's intrinsics and their 1-sigma, their origin in words, the own fits.

    Given (checked against its stills' size), or fitted on its own stills (every still its
    board was found in).
    """
    if given is not None:
        for n, (intrinsics, _) in enumerate(given):
            size = found.size[n]
            if size is not None and size != (intrinsics.width, intrinsics.height):
                raise InputValueError(
                    f"camera {n + 1}'s stills are {size[0]}x{size[1]}, its calibration "
                    f"{intrinsics.width}x{intrinsics.height}: give the calibration made at "
                    "this size"
                )
        _refuse_swapped(found, board_pattern(board, square), given)
        return given, given_from, (None, None)
    fits: list[Calibration] = []
    for n in (0, 1):
        own, size = found.own[n], found.size[n]
        if len(own) < MIN_OWN_VIEWS or size is None:
            raise InputValueError(
                f"camera {n + 1} saw the board in {len(own)} still(s); fitting its intrinsics "
                f"needs {MIN_OWN_VIEWS} or more (or give --calibration-left and "
                "--calibration-right)"
            )
        names = [name for name, _ in own]
        fits.append(fit_views([c for _, c in own], names, size, board_pattern(board, square)))
    note = (
        f"fitted on each camera's own stills ({fits[0].n_views} and {fits[1].n_views} views, "
        f"RMS {fits[0].rms_px:.3f} and {fits[1].rms_px:.3f} px)"
    )
    cameras = ((fits[0].intrinsics, dict(fits[0].sigma)), (fits[1].intrinsics, dict(fits[1].sigma)))
    return cameras, note, (fits[0], fits[1])


#: A sign test over the views at this level refuses calibration files that fit swapped.
SWAPPED_LEVEL = 0.001


def _refuse_swapped(found: _Found, pattern: F32, given: tuple[Calibrated, Calibrated]) -> None:
    """Refuse ``--calibration-left`` and ``--calibration-right`` given the wrong way round.

    Each camera's every board, posed alone (PnP) through its own file's intrinsics and
    through the other's: when the other's fit better in nearly every view of both cameras
    (a sign test over the views: views, not corners, are independent, a view's corner
    errors repeating), the files were swapped. The pair's fit cannot see it: its RMS stays
    well under the 2 px it refuses and its leave-one-out check passes, while the pose is 30
    sigma off (a new user's OpenCV photographs).
    """
    from scipy import stats

    from twopose.pair.board_fit import LensModel
    from twopose.pair.holdout import pnp_residual_px

    lenses = [LensModel.of(given[0][0]), LensModel.of(given[1][0])]
    if np.array_equal(lenses[0].K, lenses[1].K) and np.array_equal(
        lenses[0].distortion, lenses[1].distortion
    ):
        return  # one file for both: swapping changes nothing
    better, views, rms = 0, 0, []
    for n, corners in enumerate((found.left, found.right)):
        own = [
            float(np.sqrt(np.mean(pnp_residual_px(c, pattern, lenses[n]) ** 2))) for c in corners
        ]
        other = [
            float(np.sqrt(np.mean(pnp_residual_px(c, pattern, lenses[1 - n]) ** 2)))
            for c in corners
        ]
        better += sum(b < a for a, b in zip(own, other, strict=True))
        views += len(own)
        rms.append(
            (float(np.sqrt(np.mean(np.square(own)))), float(np.sqrt(np.mean(np.square(other)))))
        )
    if stats.binom.sf(better - 1, views, 0.5) >= SWAPPED_LEVEL:
        return
    raise InputValueError(
        f"the stills fit the calibration files swapped: camera 1's boards fit at RMS "
        f"{rms[0][0]:.3f} px through --calibration-left and {rms[0][1]:.3f} px through "
        f"--calibration-right, camera 2's at {rms[1][0]:.3f} px through --calibration-right "
        f"and {rms[1][1]:.3f} px through --calibration-left ({better} of {views} views fit "
        "better the other way): give each camera its own file (are --calibration-left and "
        "--calibration-right, or the cameras' order, swapped?)"
    )


def calibrate_pair_views(
    pairs: Iterable[StillPair],
    board: tuple[int, int],
    square: float,
    units: Units,
    *,
    calibrations: tuple[Calibrated, Calibrated] | None = None,
    calibrations_from: str = "given intrinsics",
    floor: FloorStills | None = None,
    on_pair: Callable[[str, tuple[bool, bool]], None] | None = None,
) -> PairCalibrationRun:
    """The pair's calibration from moments seen by both cameras (the module docstring).

    Parameters
    ----------
    pairs : iterable of (name, left image, right image)
        Each moment's name and both cameras' BGR images (any iterator: stills, or a
        ``pair:`` source's frames).
    board : (cols, rows)
        The board's inner corners.
    square : float
        The side of a square, in ``units``.
    units : Units
        The unit of ``square``, and so of the pair's baseline and floor.
    calibrations : ((Intrinsics, sigma), (Intrinsics, sigma)), optional
        Each camera's intrinsics and their 1-sigma (None: fitted on each camera's stills).
    calibrations_from : str
        Where ``calibrations`` came from, in words (kept in the pair file).
    floor : FloorStills, optional
        A board lying on the floor, seen by camera 1 (and camera 2).
    on_pair : callable, optional
        Called with each moment's name and whether each camera (1, 2) found the board.

    Returns
    -------
    PairCalibrationRun
    """
    units = unit_spec(units).units
    found = _find_all(pairs, board, on_pair)
    if not found.names and not found.skipped:
        raise InputValueError("no stills: give both cameras' images of the board")
    if len(found.names) < MIN_VIEWS:
        none = not found.names and not (found.own[0] or found.own[1])
        raise InputValueError(
            f"the board was found in both cameras in {len(found.names)} pair(s) of "
            f"{len(found.names) + len(found.skipped)}; the pair's calibration needs "
            f"{MIN_VIEWS} or more"
            + (  # found in no still at all: the size given is the likelier cause
                f": a {board[0]}x{board[1]} board is in none of them: is --board right (its "
                "inner corners, where four squares meet, COLSxROWS)?"
                if none
                else f" (not in both: {', '.join(found.skipped)})"
                if found.skipped
                else ""
            )
        )
    cameras, note, own = _intrinsics(found, board, square, calibrations, calibrations_from)
    corners = BoardCorners.of(board, square, found.left, found.right)
    pair = fit_pair(
        corners,
        (cameras[0][0], cameras[1][0]),
        units=units,
        names=found.names,
        sigmas=(cameras[0][1], cameras[1][1]),
        intrinsics_from=note,
    )
    if floor is not None:
        pair = with_floor(pair, _floor(pair, floor, board, square))
    return PairCalibrationRun(
        pair=pair,
        used=tuple(found.names),
        skipped=tuple(found.skipped),
        intrinsics_from=note,
        own=own,
    )


def _floor(
    pair: PairCalibration, stills: FloorStills, board: tuple[int, int], square: float
) -> FloorPlane:
    """The floor from its board's stills (refused in words where the board is not found)."""
    left = find_board(stills.left, board)
    if left is None:
        raise InputValueError("the floor board was not found in camera 1's still (--floor-left)")
    right = None if stills.right is None else find_board(stills.right, board)
    if stills.right is not None and right is None:
        raise InputValueError("the floor board was not found in camera 2's still (--floor-right)")
    return floor_from_board(pair, left, right, board, square, thickness=stills.thickness)


def still_pairs(left: str, right: str) -> list[tuple[str, Path, Path]]:
    """Both cameras' stills matched by sorted name: ``(name, left path, right path)``.

    ``left`` and ``right`` are file patterns (``glob``: ``photos/left*.jpg``) of images
    (:data:`recorder.sources.registry.IMAGE_SUFFIXES`). Refused in words: a pattern that matches no
    image, different counts, two files paired whose numbers differ.
    """
    files = []
    for option, pattern in (("--left", left), ("--right", right)):
        matched = sorted(
            Path(p)
            for p in glob.glob(str(Path(pattern).expanduser()))
            if Path(p).suffix.lower() in IMAGE_SUFFIXES and Path(p).is_file()
        )
        if not matched:
            raise InputValueError(
                f"{option} {pattern!r} matches no image ({', '.join(IMAGE_SUFFIXES)})"
            )
        files.append(matched)
    if len(files[0]) != len(files[1]):
        raise InputValueError(
            f"--left matches {len(files[0])} images, --right {len(files[1])}: each still of "
            "camera 1 needs camera 2's of the same moment (paired by sorted name)"
        )
    out = []
    for a, b in zip(files[0], files[1], strict=True):
        if a.resolve() == b.resolve():
            raise InputValueError(f"{a} is both cameras' still: --left and --right must differ")
        if numbers_differ(a.name, b.name):
            raise InputValueError(
                f"{a.name} is paired with {b.name} (sorted names) but their numbers differ: a "
                "still is missing on one side, or the names do not match"
            )
        out.append((f"{a.name} & {b.name}", a, b))
    return out


def read_still_pairs(files: list[tuple[str, Path, Path]]) -> Iterator[StillPair]:
    """Each pair of stills decoded (:func:`twopose.camera.images.decode_image`), one at a time."""
    for name, a, b in files:
        yield name, _decoded(a), _decoded(b)


def calibrate_pair(
    request: PairRequest,
    *,
    on_pair: Callable[[str, tuple[bool, bool]], None] | None = None,
    say: Callable[[str], None] | None = None,
) -> PairCalibrationRun:
    """``twopose-record calibrate-pair`` as one call: fit, check and write the pair file,
    from stills (``--left``/``--right``) or a live ``pair:`` source (``--source``).

    Parameters
    ----------
    request : PairRequest
        The output, both cameras' stills or the pair source, the board, the units, the
        calibration files and the floor board's stills.
    on_pair : callable, optional
        Called with each pair of stills' name and whether each camera (1, 2) found the board.
    say : callable, optional
        Called with each line a live source has to say (its cameras, the pairs kept, why
        others were not, how the collection ended).

    Returns
    -------
    PairCalibrationRun
        With ``path`` the file written (and ``live``, how a live source's collection went).
    """
    r = request
    if r.out.exists():
        raise SessionExistsError(f"{r.out} already exists; choose another pair file")
    if not r.out.parent.is_dir():  # said before the fit, never after it
        raise TwoposeError(
            f"cannot create {r.out}: the folder {r.out.parent} does not exist (create it first)"
        )
    _refuse_combinations(r)
    calibrations = None
    if r.calibration_left is not None and r.calibration_right is not None:
        calibrations = (
            (load_calibration(r.calibration_left), load_calibration_sigma(r.calibration_left)),
            (load_calibration(r.calibration_right), load_calibration_sigma(r.calibration_right)),
        )
    floor = _floor_stills(r)  # an unreadable floor still is refused before the cameras open
    live = None
    if r.source is not None:
        pairs, live = _live_pairs(r.source, r.board, r.views, say or (lambda _: None))
    elif r.left is not None and r.right is not None:
        files = still_pairs(r.left, r.right)
        inputs = {p.resolve() for _, a, b in files for p in (a, b)}
        if r.out.resolve() in inputs:
            raise InputValueError(f"{r.out} is one of the stills: choose another pair file")
        pairs = read_still_pairs(files)
    run = calibrate_pair_views(
        pairs, r.board, r.square, r.units,
        calibrations=calibrations,
        calibrations_from=f"calibration files {r.calibration_left} and {r.calibration_right}",
        floor=floor, on_pair=on_pair if live is None or live.stills else None,  # said live
    )  # fmt: skip
    write_pair_file(r.out, run.pair)
    return dataclasses.replace(run, path=r.out, live=live)


def _refuse_combinations(r: PairRequest) -> None:
    """The request's options that go only together, or never, refused in words."""
    if (r.source is None) == (r.left is None and r.right is None):
        raise InputValueError(
            "give the stills (--left and --right) or a pair of cameras (--source pair:A,B), "
            "one of them"
        )
    if r.source is None and (r.left is None or r.right is None):
        raise InputValueError("give both cameras' stills: --left and --right")
    if r.source is None and r.views is not None:
        raise InputValueError(
            "--views counts the pairs kept from a live --source; every pair of stills is used"
        )
    if (r.calibration_left is None) != (r.calibration_right is None):
        raise InputValueError(
            "give both cameras' calibration files (--calibration-left and --calibration-right) "
            "or neither (each camera is then fitted on its own stills)"
        )
    if r.floor_left is None and (r.floor_right is not None or r.board_thickness):  # r7 K9
        which = "--floor-right" if r.floor_right is not None else "--board-thickness"
        raise InputValueError(f"{which} needs --floor-left: the floor is in camera 1's frame")


def _live_pairs(
    spec: str, board: tuple[int, int], views: int | None, say: Callable[[str], None]
) -> tuple[Iterable[StillPair], LiveOutcome]:
    """The pairs a ``pair:`` source gives (:mod:`recorder.calibration.pair_live`): a folder's as
    they
    come, as stills are; a camera's collected first, then fitted (or, stopped with too few,
    refused: nothing is written)."""
    from recorder.calibration.pair_live import LiveOutcome, LiveRules, live_pairs
    from recorder.sources.pair import PairSource
    from recorder.sources.registry import SOURCE_KINDS, SourceOptions, kind_of, open_from

    if kind_of(spec).cameras != 2:
        raise InputValueError(
            f"--source {spec}: calibrate-pair takes two cameras: --source pair:A,B "
            "(pair:camera:0,camera:1)"
        )
    source = open_from(SOURCE_KINDS, spec, SourceOptions())
    assert isinstance(source, PairSource)  # the kind of two cameras opens a pair
    outcome = LiveOutcome(stills=source.stills)
    pairs = live_pairs(source, board, LiveRules(views=views), outcome, say)
    if source.stills:
        return pairs, outcome
    kept = list(pairs)
    say(outcome.ended)
    if len(kept) < MIN_VIEWS:
        words = f"the pair's calibration needs {MIN_VIEWS} pairs or more; nothing written"
        if outcome.stopped:
            say(words)
            raise KeyboardInterrupt
        raise InputValueError(
            f"{outcome.ended}; {words}: show the board to both cameras at more places, "
            "holding it still at each"
        )
    return kept, outcome


def _floor_stills(request: PairRequest) -> FloorStills | None:
    """The floor board's stills decoded (None: no floor asked)."""
    if request.floor_left is None:
        return None
    left = _decoded(request.floor_left)
    right = None if request.floor_right is None else _decoded(request.floor_right)
    return FloorStills(left=left, right=right, thickness=request.board_thickness)


def _decoded(path: Path) -> Image:
    """An image file decoded (:func:`twopose.camera.images.decode_image`), refused in words."""
    from twopose.camera.images import decode_image

    try:
        data = path.read_bytes()
    except OSError as err:
        raise InputValueError(f"cannot read {path}: {err.strerror}") from err
    return decode_image(data, str(path))
