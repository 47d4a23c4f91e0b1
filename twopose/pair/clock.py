"""The two cameras' clock offset measured, with its 1-sigma.

``offset_ns`` is camera 2's capture clock minus camera 1's for the same instant
(``t1 = t2 - offset_ns``). It is measured, never assumed, two ways:

- :func:`offset_from_flash` (:mod:`twopose.pair.flash`): a flash both cameras see, its
  onset found to a fraction of a frame from the lit share of the frame it falls in.
- :func:`offset_from_ray_gap`: a dot both cameras see while it moves. For each candidate
  offset, camera 1's pixel track is interpolated (linearly) to camera 2's capture times
  and the rays' gap is measured in pixels (Sampson's first-order distance to the pair's
  epipolar constraint); the offset is the candidates' minimum of the mean squared gap,
  refined by a parabola through the three candidates about it. Its 1-sigma is that of a
  least-squares parameter: ``var = 2 s^2 / S''``, ``S''`` the curvature of the summed
  squared gap and ``s^2`` the gaps' variance at the minimum, times the factor by which
  neighbouring gaps' shared camera-1 frames correlate them, less camera 1's noise's share
  of the curvature (a still frame's rate with the offset is its noise's), floored by a
  jackknife over runs of frames, plus camera 1's linear-interpolation error (its track's
  bend between frames), the grid step's and the fitted clocks' own error, and the
  detector's error alike over frames about one place (the method's floor in a pair,
  ``floor_px``: :meth:`DotTracks.systematic_ns`; a slow glove was 35 sigma off without
  it). The minimum is
  taken over the frames every offset about it measures; the offsets searched are every
  offset a pair's clocks may differ by (:data:`twopose.values.bounds.CLOCK_OFFSET`, what
  ``simulate`` accepts) and a margin. Refused in words: a motion along the epipolar lines
  (sideways, for cameras side by side) or no more than camera 1's noise, one in fewer than
  three frames, one that repeats, a best at the search's edge, exchanged cameras, and a
  dot's rays apart at their best by more than its detection makes (a pair file not these
  cameras': :mod:`twopose.pair.rays_miss`).

Both first fit each camera's frame times by a regular clock (:func:`regular_times`: a
camera's frames are taken at a fixed rate; the stamps' jitter is the host's), so the
stamps' jitter averages out instead of entering every frame. No I/O.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from twopose.arrays import F64
from twopose.errors import InputValueError
from twopose.pair.calibration import PairCalibration
from twopose.pair.clock_fit import ClockOffset, RegularTimes, regular_times
from twopose.pair.dot_tracks import MIN_GAP_FRAMES, DotTracks, dot_tracks, epipolar_gap_px
from twopose.pair.flash import offset_from_flash
from twopose.pair.rays_miss import inside, pixel_sigma, rays_miss_words, still_frames
from twopose.values import bounds

__all__ = [
    "ClockOffset",
    "RegularTimes",
    "epipolar_gap_px",
    "offset_from_flash",
    "offset_from_ray_gap",
    "regular_times",
]

#: A rays' gap whose minimum is this wide (1-sigma, a share of a frame interval) fixes no
#: offset: the dot moved along the epipolar lines, or barely.
MAX_SIGMA_SHARE = 0.25
#: The least likelihood ratio (``n (S / S_min - 1)``, chi-square-like) by which every
#: offset a frame or more from the best must fit worse: below it, another offset fits
#: nearly as well and the offset is not known.
MIN_LIKELIHOOD_RATIO = 25.0
#: Beyond the offsets a pair's clocks may differ by, the search goes on this far (ns), so
#: that a best at the bound is not at the search's edge (which needs a frame interval:
#: 250 ms is one at 4 fps).
SEARCH_MARGIN_NS = 0.25e9
#: The offsets searched by default, either way (ns): every offset a pair's clocks may
#: differ by (:data:`twopose.values.bounds.CLOCK_OFFSET`, what `simulate
#: --clock-offset-ms` accepts: one definition), and :data:`SEARCH_MARGIN_NS`. A search
#: narrower than the offsets that can be would take a repeating motion's other period for
#: the offset (a 2 in square at 10 in/s repeats every 0.8 s); a best at its edge is
#: refused as beyond it.
SEARCH_NS = (
    max(abs(bounds.CLOCK_OFFSET.low), abs(bounds.CLOCK_OFFSET.high)) * 1e6 + SEARCH_MARGIN_NS
)
#: The coarse cost's local minima refined and compared (:func:`_basins`).
BASINS = 6
#: Two minima closer than this (frame intervals) are one basin's (a minimum's 5-sigma
#: width is at most 1.25 of them, :data:`MAX_SIGMA_SHARE`), not two periods' of a path.
REPEAT_APART = 2.0
#: The fine search's candidates per frame interval (its step's uniform error enters sigma).
FINE_STEPS = 200
#: The fewest frames whose motion the offset may rest on (their participation ratio,
#: :meth:`DotTracks.motion_frames`), and the least ratio of the gaps' rates with the
#: offset to what camera 1's noise alone makes them: a line crossed in three frames at
#: 48 in/s, the rest of the trial still, was 59 ms off with a sigma of 6.6 (the minimum
#: was the still frames' noise's, its curvature too).
MIN_MOVING_FRAMES = 3
MIN_ABOVE_NOISE = 1.5
#: Runs of camera 2's frames left out in turn to check the sigma (:func:`_jackknife_variance`).
JACKKNIFE_BLOCKS = 10
#: The mean squared gap this many times smaller with the cameras exchanged says they are.
SWAP_RATIO = 10.0


def offset_from_ray_gap(
    pair: PairCalibration,
    track1_px: ArrayLike,
    t1_ns: ArrayLike,
    track2_px: ArrayLike,
    t2_ns: ArrayLike,
    *,
    search_ns: tuple[float, float] = (-SEARCH_NS, SEARCH_NS),
    angles_deg: tuple[ArrayLike, ArrayLike] | None = None,
    floor_px: float = 0.0,
) -> ClockOffset:
    """The clock offset from a moving target both cameras see (the module docstring).

    Parameters
    ----------
    pair : PairCalibration
        The calibrated pair.
    track1_px, track2_px : (N1, 2), (N2, 2) array_like
        The target's pixel (col, row) in each frame of camera 1 and camera 2, as detected
        (distorted); NaN where not found.
    t1_ns, t2_ns : (N1,), (N2,) array_like
        Their capture times (nanoseconds, each camera's clock).
    search_ns : (float, float)
        The range of offsets searched (default :data:`SEARCH_NS` either way).
    angles_deg : ((N1,), (N2,)) array_like, optional
        Each frame's image line's angle (degrees, as detected) of a target with an image
        line (the glove): its point's place along the line is not the same point of it in
        both cameras, and is fitted (:mod:`twopose.pair.dot_tracks`). None: a dot's.
    floor_px : float
        The detector's systematic error per camera (px, 1-sigma: the method's
        :attr:`~twopose.methods.specs.MethodSpec.floor_in_pair`), which stays over many
        frames and enters the sigma as a term (:meth:`DotTracks.systematic_ns`). 0: tracks
        with no such error (synthetic ones).

    Returns
    -------
    ClockOffset
    """
    tracks, times = (track1_px, track2_px), (t1_ns, t2_ns)
    dots = dot_tracks(pair, tracks, times, angles_deg)
    try:
        offset = _ray_gap(dots, search_ns, floor_px)
    except InputValueError as err:
        hint = _swapped_hint(pair, tracks, times, search_ns, angles_deg)
        raise InputValueError(f"{err}{hint}") from err
    # Exchanged cameras can still find a minimum (a wrong one, with a small sigma): the
    # gap far smaller the other way round refuses it.
    hint = _swapped_hint(pair, tracks, times, search_ns, angles_deg)
    if hint:
        raise InputValueError(hint.removeprefix("; "))
    return offset


def _ray_gap(dots: DotTracks, search_ns: tuple[float, float], floor_px: float) -> ClockOffset:
    """:func:`offset_from_ray_gap` on checked tracks (refusals raised, without the hint)."""
    interval = float(np.median(np.diff(dots.times[0])))
    lo, hi = sorted(float(x) for x in search_ns)
    coarse = np.arange(lo, hi + interval / 8, interval / 4)
    coarse_cost, coarse_used = dots.mean_gap(coarse)
    if not np.isfinite(coarse_cost).any():
        raise InputValueError(
            f"the target was seen by both cameras at the same time in fewer than "
            f"{MIN_GAP_FRAMES} frames at every offset from {lo / 1e6:g} to {hi / 1e6:g} ms: "
            "record a longer trial, with the target in both cameras' view"
        )
    # Offsets that leave most frames without partners rest on few: their mean is noisy.
    supported = coarse_used >= 0.5 * coarse_used.max()
    minima = _basins(dots, coarse, np.where(supported, coarse_cost, np.nan), interval)
    best = minima[0][0]
    _refuse_another_pair(dots, best, floor_px)
    if min(best - lo, hi - best) < interval:
        raise InputValueError(
            f"the rays' gap is smallest at the edge of the offsets searched ({lo / 1e6:+.0f} "
            f"to {hi / 1e6:+.0f} ms): the cameras' clocks may differ by more, which the ray "
            "gap does not measure: measure the offset by a flash both cameras see"
        )
    h = interval / FINE_STEPS
    fine = np.arange(best - interval / 2, best + interval / 2 + h / 2, h)
    cost, used = dots.mean_gap(fine, common=True)
    if not np.isfinite(cost).any():
        raise InputValueError(
            f"fewer than {MIN_GAP_FRAMES} of camera 2's frames have camera 1's frames about "
            "them at every offset near the best (frames dropped): record a longer trial"
        )
    k = int(np.nanargmin(cost))
    if k == 0 or k == fine.size - 1 or not np.isfinite(cost[k - 1 : k + 2]).all():
        raise InputValueError(
            f"the rays' gap has no minimum near {best / 1e6:.0f} ms over the frames every "
            "offset about it measures (too few frames, or too many dropped): record a longer "
            "trial, dropping fewer frames"
        )
    c0, c1, c2 = cost[k - 1], cost[k], cost[k + 1]
    curvature = (c0 - 2 * c1 + c2) / h**2  # of the mean squared gap
    if not curvature > 0:
        raise InputValueError(_NOT_FIXED)
    vertex = fine[k] + 0.5 * h * (c0 - c2) / (c0 - 2 * c1 + c2)
    n = int(used[k])
    # Least squares on S = n * mean: var = 2 s^2 / S'', s^2 = S_min / (n - 1 - nuisances)
    # (a line's slide fitted beside the offset; profiled out of S, so S'' is the offset's
    # information less what the slide takes of it).
    min_mean = c1 - 0.25 * (c0 - c2) ** 2 / (c0 - 2 * c1 + c2) / 2
    dof = n - 1 - dots.nuisances
    variance = 2 * max(min_mean, 0.0) / (dof * curvature) * dots.correlation_factor(vertex)
    above_noise, moving = dots.motion_frames(float(vertex), h, max(min_mean, 0.0))
    if above_noise < MIN_ABOVE_NOISE:
        raise InputValueError(_NOT_FIXED)
    if moving < MIN_MOVING_FRAMES:
        raise InputValueError(
            f"the offset would rest on the target's motion in {moving:.1f} frames (it moved "
            f"in few of them, or fast past them), fewer than {MIN_MOVING_FRAMES}: move it "
            "across both cameras' views for longer, or slower"
        )
    # The curvature holds camera 1's noise's share (a slow target's: half of it at 2 in/s),
    # which fixes nothing: the motion's alone sets the sigma. Then the sigma checked
    # against the data's own scatter (a 1.9 in/s line was once 10 of its sigmas off).
    variance *= above_noise / (above_noise - 1.0)
    variance = max(variance, _jackknife_variance(dots, fine))
    if np.sqrt(variance) > MAX_SIGMA_SHARE * interval:
        raise InputValueError(_NOT_FIXED)
    # A likelihood ratio against every offset a frame or more away: one that fits nearly
    # as well (the motion along the epipolar lines fits every offset; a periodic one
    # several) leaves the offset unknown. A line's other offsets are judged with its slide
    # held at the best's (a repeating path repeats it: DotTracks.holding_slide).
    if dots.lines is not None:
        held = dots.holding_slide(float(vertex))
        coarse_cost, coarse_used = held.mean_gap(coarse)
        supported = coarse_used >= 0.5 * coarse_used.max()
        minima = _basins(held, coarse, np.where(supported, coarse_cost, np.nan), interval)
    far = (np.abs(coarse - vertex) > interval) & supported
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = coarse_used[far] * (coarse_cost[far] / max(min_mean, 1e-300) - 1.0)
    ratio = np.where(np.isfinite(ratio), ratio, np.inf)
    if far.any() and ratio.min() < MIN_LIKELIHOOD_RATIO:
        rival = coarse[far][int(np.argmin(ratio))]
        raise InputValueError(
            f"the rays' gap fits an offset of {rival / 1e6:.0f} ms nearly as well as "
            f"{vertex / 1e6:.0f} ms: the target moved too little, in a repeating path, or "
            "along the epipolar lines: move it across them, up and down for cameras side "
            "by side"
        )
    _refuse_repeats(
        minima,
        vertex,
        (min_mean, dots.bend_px2()),
        n / dots.correlation_factor(vertex),
        (lo, hi, interval),
    )
    # Camera 1's interpolation error (a bend between its frames) as a term, and the grid's
    # resolution (a uniform step), then the fitted clocks' own error.
    # The bend's share at the phase found (camera 2's frames where they fell between camera
    # 1's) or half-way, whichever is larger: the acceleration from three frames is crude
    # about a corner or a stop, and a fast target's best offset is where the miss happens
    # to be small (issue 58: 100 in/s, -21.2 +- 1.4 ms against -12.5).
    bend = max(
        dots.interpolation_ns(float(vertex), h), dots.interpolation_ns(float(vertex), h, half=True)
    )
    variance += bend**2 + h**2 / 12 + dots.clock_sigma_ns() ** 2
    # The detector's error that stays over many frames: the scatter and the jackknife see
    # none of it, and a slow target's offset rests on a few frames' motion.
    variance += dots.systematic_ns(float(vertex), h, floor_px) ** 2
    if bend > MAX_SIGMA_SHARE * interval:
        raise InputValueError(
            f"the target's track bends too much between camera 1's frames to be interpolated "
            f"(the offset could be off by {bend / 1e6:.1f} ms): move it slower or straighter, "
            "or drop fewer frames"
        )
    return ClockOffset(
        offset_ns=float(vertex), sigma_ns=float(np.sqrt(variance)), method="ray gap", n=n,
        clock_sigma_ns=dots.clock_sigma_ns(),
    )  # fmt: skip


def _jackknife_variance(dots: DotTracks, fine: F64) -> float:
    """The offset's variance by a delete-a-block jackknife over camera 2's frames (ns^2).

    The frames every candidate of the fine grid measures, cut into :data:`JACKKNIFE_BLOCKS`
    runs in time (a run keeps the gaps that share camera-1 frames together) that hold equal
    shares of the offset's information (each frame's curvature of its squared gap: runs of
    equal counts, where a trial's motion lies in a few of its frames, left one run out with
    most of it, and the jackknife took 2.7 ms for 27); each run left out in turn, the
    minimum found again (the grid's best, refined by its parabola; a line's slide fitted
    again without the run), and ``(B - 1) / B`` times their sum of squares about their
    mean. One matrix of gaps (a line's: one a run), so it costs a few sums. 0 when there
    are too few frames for it.
    """
    gap, weight = dots.gaps(fine)
    g2 = gap**2 / weight
    every = np.flatnonzero(np.isfinite(g2).all(axis=0))
    if every.size < JACKKNIFE_BLOCKS * 3:
        return 0.0
    g2 = g2[:, every]
    total = g2.sum(axis=1)
    h = float(fine[1] - fine[0])
    vertices = []
    middle = fine.size // 2
    info = np.clip(g2[middle - 1] - 2 * g2[middle] + g2[middle + 1], 0.0, None)
    if not info.sum() > 0:
        return 0.0
    share = (np.cumsum(info) - 0.5 * info) / info.sum()
    runs = np.minimum((share * JACKKNIFE_BLOCKS).astype(int), JACKKNIFE_BLOCKS - 1)
    for b in range(JACKKNIFE_BLOCKS):
        block = np.flatnonzero(runs == b)
        if block.size == 0:
            continue
        if dots.lines is not None:  # the slide fitted without the run
            kept = np.ones(weight.shape[1], dtype=bool)
            kept[every[block]] = False
            g2 = (dots.gaps(fine, fit=kept)[0] ** 2 / weight)[:, every]
            total = g2.sum(axis=1)
        cost = (total - g2[:, block].sum(axis=1)) / (every.size - block.size)
        k = int(np.argmin(cost))
        if k == 0 or k == cost.size - 1:
            return 0.0  # a block's minimum off the grid: the scatter is not this one
        c0, c1, c2 = cost[k - 1 : k + 2]
        bend = c0 - 2 * c1 + c2
        vertices.append(fine[k] + (0.5 * h * (c0 - c2) / bend if bend > 0 else 0.0))
    v = np.asarray(vertices)
    return float((v.size - 1) / v.size * ((v - v.mean()) ** 2).sum())


def _basins(
    dots: DotTracks, coarse: F64, cost: F64, interval: float
) -> list[tuple[float, float, float]]:
    """The coarse cost's :data:`BASINS` lowest local minima refined: (offset ns, mean, n).

    A quarter-frame grid step can straddle a fast target's narrow basin (the point beside
    the true bottom costing more than one beside another period's): each is searched again
    at ``interval / 32`` a coarse step either way, and ranked by its bottom. Two minima a
    coarse step or two apart need a path that turns within a frame or two, which camera
    1's frames cannot follow: such a track bends too much to be interpolated and is refused
    (:func:`_ray_gap`), but for a target vibrating at a harmonic of the frame rate (periods
    of a frame interval or its half, third, quarter: 33, 17, 11, 8 ms at 30 fps), which both
    cameras see as a slow motion, shifted in time by many times its true shift: those
    tracks are another offset's, exactly, and no grid tells them apart (a flash does:
    :mod:`twopose.pair.trial_offset` refuses the two that disagree).
    """
    finite = np.where(np.isfinite(cost), cost, np.inf)
    left, right = np.r_[np.inf, finite[:-1]], np.r_[finite[1:], np.inf]
    local = np.flatnonzero(np.isfinite(cost) & (finite <= left) & (finite <= right))
    local = local[np.argsort(finite[local])][:BASINS]
    step, out = interval / 4, []  # the coarse grid's step
    for k in local:
        grid = np.arange(coarse[k] - step, coarse[k] + step + interval / 64, interval / 32)
        mean, used = dots.mean_gap(grid)
        j = int(np.nanargmin(np.where(np.isfinite(mean), mean, np.inf)))
        if not np.isfinite(mean[j]):  # too few frames about it: the coarse point stands
            j, grid, mean = 0, coarse[k : k + 1], cost[k : k + 1]
        out.append((float(grid[j]), float(mean[j]), float(used[j])))
    return sorted(out, key=lambda m: m[1])


def _refuse_repeats(
    minima: list[tuple[float, float, float]],
    vertex: float,
    costs: tuple[float, float],
    n_eff: float,
    search: tuple[float, float, float],
) -> None:
    """Refuse when another basin's bottom, :data:`REPEAT_APART` frames away, fits about as well.

    The likelihood ratio of two offsets (Gaussian gaps, their variance the best's residual
    ``m_min``): ``2 ln L = n (m_rival - m_min) / m_min``, ``n`` over the gaps' correlation
    factor. Below :data:`MIN_LIKELIHOOD_RATIO` (25: 5 sigma, a one-parameter chi-square's
    p of 6e-7 that the other period, were it the true one, fits this much worse by chance)
    the path's periods are not told apart. The cost camera 1's interpolation alone could
    add at another phase (``bend``, :meth:`DotTracks.bend_px2`) is no evidence and is
    taken off first: a fast target's wrong period can fit best where camera 2's frames
    fall on camera 1's.
    """
    lo, hi, interval = search
    min_mean, bend = costs
    for offset, mean, _ in minima:
        ratio = n_eff * (mean - min_mean - bend) / max(min_mean, 1e-300)
        if abs(offset - vertex) > REPEAT_APART * interval and ratio < MIN_LIKELIHOOD_RATIO:
            raise InputValueError(
                f"the target's path repeats: offsets {vertex / 1e6:.1f} ms and "
                f"{offset / 1e6:.1f} ms fit about equally (likelihood ratio {max(ratio, 0):.1f}, "
                f"under {MIN_LIKELIHOOD_RATIO:g}): measure the offset by a flash both cameras "
                f"see, or move the target along a path that does not repeat within "
                f"{(hi - lo) / 1e6:.0f} ms (the offsets searched, {lo / 1e6:+.0f} to "
                f"{hi / 1e6:+.0f} ms)"
            )


# A pair a little off (0.2-0.3 deg, 0.3 in) leaves the rays apart at every offset, which
# reads as a motion that fixes nothing (a new user's r8 F1): both causes said.
_NOT_FIXED = (
    "the target's motion does not fix the clock offset (it moved along the epipolar lines, "
    "or too little): move it across them, up and down for cameras side by side; if it "
    "did, the pair file may not be these cameras' (a pose a little off leaves the rays "
    "apart at every offset): calibrate the pair again"
)


def _refuse_another_pair(dots: DotTracks, best_ns: float, floor_px: float) -> None:
    """Refuse a pair file not these cameras': a dot's rays apart where it stood still, whole.

    At the best offset (:mod:`twopose.pair.rays_miss`), in its words. A line target's gap
    cannot tell (its slide along the finger takes most of it up): not judged.
    """
    if dots.lines is not None:
        return
    u1 = dots.camera1_at(dots.times[1][None, :] - best_ns)[0][0]
    i1, i2 = dots.pair.intrinsics1, dots.pair.intrinsics2
    judged = still_frames(dots.tracks[1]) & inside(dots.tracks[1], i2.width, i2.height)
    judged &= inside(u1, i1.width, i1.height)
    sigma = pixel_sigma(floor_px, dots.pair.rms_px)
    missed = rays_miss_words(dots.gaps(np.array([best_ns]))[0][0][judged], sigma)
    if missed:
        raise InputValueError(missed)


def _swapped_hint(
    pair: PairCalibration,
    tracks: tuple[ArrayLike, ArrayLike],
    times: tuple[ArrayLike, ArrayLike],
    search_ns: tuple[float, float],
    angles_deg: tuple[ArrayLike, ArrayLike] | None = None,
) -> str:
    """Words for a refusal when the cameras look exchanged: the gap far smaller so."""
    swapped = None if angles_deg is None else (angles_deg[1], angles_deg[0])
    try:
        ours = dot_tracks(pair, tracks, times, angles_deg)
        # The pair as calibrated, fed each camera's track as the other's.
        theirs = dot_tracks(pair, (tracks[1], tracks[0]), (times[1], times[0]), swapped)
        interval = float(np.median(np.diff(ours.times[0])))
        grid = np.arange(min(search_ns), max(search_ns) + interval / 8, interval / 4)
        own_cost, other_cost = ours.mean_gap(grid)[0], theirs.mean_gap(grid)[0]
    except (InputValueError, ValueError):
        return ""
    if not (np.isfinite(own_cost).any() and np.isfinite(other_cost).any()):
        return ""
    own, other = float(np.nanmin(own_cost)), float(np.nanmin(other_cost))
    if not other * SWAP_RATIO < own:
        return ""
    return (
        f"; the cameras may be in the wrong order: with camera 1 and camera 2 exchanged the "
        f"rays' gap is {np.sqrt(own / max(other, 1e-300)):.0f} times smaller (RMS): record "
        "with the pair's camera 1 given first (`new --source pair:A,B`: A is camera 1)"
    )
