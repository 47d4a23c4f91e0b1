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
  neighbouring gaps' shared camera-1 frames correlate them, plus camera 1's
  linear-interpolation error (its track's bend between frames), the grid step's and the
  fitted clocks' own error. The minimum is taken over the frames every offset about it
  measures. Refused in words: a motion along the epipolar lines (sideways, for cameras side
  by side), one that repeats, a best at the search's edge, exchanged cameras.

Both first fit each camera's frame times by a regular clock (:func:`regular_times`: a
camera's frames are taken at a fixed rate; the stamps' jitter is the host's), so the
stamps' jitter averages out instead of entering every frame. No I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from twopose.arrays import F64, Bools, Ints
from twopose.errors import InputValueError
from twopose.pair.board_fit import LensModel
from twopose.pair.calibration import PairCalibration
from twopose.pair.clock_fit import ClockOffset, RegularTimes, regular_times
from twopose.pair.flash import offset_from_flash

__all__ = [
    "ClockOffset",
    "RegularTimes",
    "epipolar_gap_px",
    "offset_from_flash",
    "offset_from_ray_gap",
    "regular_times",
]

#: The fewest camera-2 frames an offset candidate's gap is averaged over.
MIN_GAP_FRAMES = 10
#: A rays' gap whose minimum is this wide (1-sigma, a share of a frame interval) fixes no
#: offset: the dot moved along the epipolar lines, or barely.
MAX_SIGMA_SHARE = 0.25
#: The least likelihood ratio (``n (S / S_min - 1)``, chi-square-like) by which every
#: offset a frame or more from the best must fit worse: below it, another offset fits
#: nearly as well and the offset is not known.
MIN_LIKELIHOOD_RATIO = 25.0
#: The offsets searched by default, either way (ns). Wider finds a repeating motion's
#: other periods (a 2 in square at 10 in/s repeats every 0.8 s) and, on a short trial,
#: offsets few frames overlap at: a best at its edge is refused as beyond it.
SEARCH_NS = 0.5e9
#: The coarse cost's local minima refined and compared (:func:`_basins`).
BASINS = 6
#: Two minima closer than this (frame intervals) are one basin's (a minimum's 5-sigma
#: width is at most 1.25 of them, :data:`MAX_SIGMA_SHARE`), not two periods' of a path.
REPEAT_APART = 2.0
#: The fine search's candidates per frame interval (its step's uniform error enters sigma).
FINE_STEPS = 200
#: The mean squared gap this many times smaller with the cameras exchanged says they are.
SWAP_RATIO = 10.0


def epipolar_gap_px(pair: PairCalibration, u1: F64, u2: F64) -> F64:
    """(N,) the rays' gap in pixels: Sampson's distance of undistorted pixels ``u1``, ``u2``.

    (N, 2) each, camera 1's and camera 2's, to the pair's epipolar constraint
    ``u1^T F u2 = 0`` (``F = K1^-T [t]x R K2^-1``, from ``p1 = R p2 + t``).
    """
    t = pair.t_2_in_1
    tx = np.array([[0.0, -t[2], t[1]], [t[2], 0.0, -t[0]], [-t[1], t[0], 0.0]])
    F = np.linalg.inv(pair.intrinsics1.K).T @ tx @ pair.R_2_to_1 @ np.linalg.inv(pair.intrinsics2.K)
    F = F / np.linalg.norm(F)
    h1 = np.concatenate([u1, np.ones((*u1.shape[:-1], 1))], axis=-1)
    h2 = np.concatenate([u2, np.ones((*u2.shape[:-1], 1))], axis=-1)
    Fx2 = h2 @ F.T
    Ftx1 = h1 @ F
    e = (h1 * Fx2).sum(axis=-1)
    denom = Fx2[..., 0] ** 2 + Fx2[..., 1] ** 2 + Ftx1[..., 0] ** 2 + Ftx1[..., 1] ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(e / np.sqrt(denom))


@dataclass(frozen=True, kw_only=True, eq=False)
class _DotTracks:
    """Both cameras' undistorted dot tracks (N, 2), fitted times (N,) and found flags."""

    pair: PairCalibration
    tracks: tuple[F64, F64]
    times: tuple[F64, F64]
    found: tuple[Bools, Bools]
    gap_ns: float  # the widest span between two camera-1 frames interpolated between
    clock_sigma: tuple[F64, F64]  # each fitted time's 1-sigma (regular_times)

    def camera1_at(self, at: F64) -> tuple[F64, F64]:
        """Camera 1's track at times ``at`` (C, N2), linearly, and each one's weight ``w``.

        NaN where its two neighbours are not both found, are further apart than
        ``gap_ns``, or do not bracket the time.
        """
        track, times, found = self.tracks[0], self.times[0], self.found[0]
        j = np.clip(np.searchsorted(times, at, side="right"), 1, times.size - 1)
        i = j - 1
        w = (at - times[i]) / (times[j] - times[i])
        ok = found[i] & found[j] & (times[j] - times[i] <= self.gap_ns) & (w >= 0) & (w <= 1)
        out = track[i] * (1 - w)[..., None] + track[j] * w[..., None]
        return np.where(ok[..., None], out, np.nan), w

    def weights(self, offset_ns: float) -> tuple[Ints, F64, Bools]:
        """Camera 2's frames' camera-1 neighbours at ``offset_ns``.

        The left neighbour's index (N2,), the right one's weight (N2,), and which frames'
        gap is measured (both neighbours found and close, camera 2's dot found).
        """
        at = self.times[1] - offset_ns
        t, found = self.times[0], self.found[0]
        j = np.clip(np.searchsorted(t, at, side="right"), 1, t.size - 1)
        i = j - 1
        w = (at - t[i]) / (t[j] - t[i])
        ok = found[i] & found[j] & (t[j] - t[i] <= self.gap_ns) & (w >= 0) & (w <= 1)
        return i.astype(np.intp), w, np.asarray(ok & self.found[1])

    def correlation_factor(self, offset_ns: float) -> float:
        """The variance factor of the gaps' sum: neighbouring gaps share a camera-1 frame.

        Each gap holds camera 2's frame's error and camera 1's two frames' weighted by
        ``1 - w`` and ``w`` (equal noise in both cameras taken); two successive gaps that
        interpolate across a common camera-1 frame are correlated, which a sum over gaps
        that change slowly (a smooth motion) feels as ``1 + 2 sum cov / sum var``.
        """
        i, w, ok = self.weights(offset_ns)
        i, w = i[ok], w[ok]
        if i.size < 2:
            return 1.0
        var = 1.0 + (1 - w) ** 2 + w**2
        left = np.stack([i, i + 1], axis=1)  # each gap's two camera-1 frames
        weight = np.stack([1 - w, w], axis=1)
        a, b = left[:-1], left[1:]
        wa, wb = weight[:-1], weight[1:]
        same = a[:, :, None] == b[:, None, :]
        cov = (same * wa[:, :, None] * wb[:, None, :]).sum(axis=(1, 2))
        return float(1.0 + 2.0 * cov.sum() / var.sum())

    def clock_sigma_ns(self) -> float:
        """The two fitted clocks' error as the offset feels it, combined.

        A gap averaged over a stream's frames feels each clock's error at its frames'
        centre (the fit's least 1-sigma); its slope's error averages out.
        """
        return float(np.hypot(np.min(self.clock_sigma[0]), np.min(self.clock_sigma[1])))

    def gaps(self, candidates: F64) -> tuple[F64, F64]:
        """(C, N2) the rays' gap (px) at each candidate offset, and its noise weight.

        The weight is camera 2's frame and camera 1's two, by ``1 - w`` and ``w`` (equal
        noise taken), ``1 + w^2 + (1 - w)^2`` times one frame's variance; NaN gaps where
        camera 1 has no frames about camera 2's.
        """
        u1, w = self.camera1_at(self.times[1][None, :] - candidates[:, None])
        u2 = np.where(self.found[1][:, None], self.tracks[1], np.nan)
        gap = epipolar_gap_px(self.pair, u1, np.broadcast_to(u2, u1.shape))
        return gap, 1 + w**2 + (1 - w) ** 2

    def mean_gap(self, candidates: F64, *, common: bool = False) -> tuple[F64, F64]:
        """(C,) the mean squared gap at each candidate offset, and (C,) the frames used.

        Each gap is weighed by its noise (:meth:`gaps`); a cost not weighed so would favour
        offsets that put camera 2's frames on camera 1's (where interpolation averages no
        noise away), the more so the slower the target. ``common``: over the frames every
        candidate measures only -- a mean over a set of frames that changes with the
        offset is no function of it (a frame whose camera-1 neighbours leave the set at
        one candidate made a step that looked like a sharp minimum, issue 58's 50% drop).
        """
        gap, weight = self.gaps(candidates)
        g2 = gap**2 / weight
        if common:
            every: Bools = np.asarray(np.isfinite(g2).all(axis=0))
            g2 = np.where(every[None, :], g2, np.nan)
        used = np.isfinite(g2).sum(axis=1)
        enough = used >= MIN_GAP_FRAMES
        mean = np.where(enough, np.nansum(g2, axis=1) / np.maximum(used, 1), np.nan)
        return mean, used.astype(np.float64)

    def bend_px2(self) -> float:
        """The mean squared most camera 1's linear interpolation can miss its track (px^2).

        Half-way between two frames ``dt`` apart the line misses a track bending with
        acceleration ``a`` by ``dt^2 |a| / 8``; at another offset camera 2's frames fall
        elsewhere between camera 1's (another phase ``w``), so two offsets' costs can
        differ by up to this mean with no difference in fit.
        """
        track, t, found = self.tracks[0], self.times[0], self.found[0]
        slope = (track[1:] - track[:-1]) / np.diff(t)[:, None]
        acc = 2 * (slope[1:] - slope[:-1]) / (t[2:] - t[:-2])[:, None]
        ok = found[:-2] & found[1:-1] & found[2:]
        if not ok.any():
            return 0.0
        dt = 0.5 * (t[2:] - t[:-2])[ok]
        miss = dt**2 * np.linalg.norm(acc[ok], axis=1) / 8
        return float(np.mean(miss**2))

    def interpolation_ns(self, offset_ns: float, step_ns: float, *, half: bool = False) -> float:
        """The offset's error (ns) that interpolating camera 1 linearly can make, 1-sigma.

        Between two camera-1 frames ``dt`` apart, a track bending with acceleration ``a``
        (px/ns^2, from camera 1's three frames about each) is missed by the line through
        them by ``w (1 - w) dt^2 a / 2``; each gap moves by that error's share across the
        epipolar line (``dg``), and the offset by ``-sum(dg s / v) / sum(s^2 / v)``, ``s``
        each gap's rate with the offset and ``v`` its weight. Its size is carried as a
        term of the sigma: a fast or sharply turning target (100 in/s round a 2 in square)
        or frames bridged across a dropped one bend between camera 1's frames.
        """
        track, t, found = self.tracks[0], self.times[0], self.found[0]
        acc = np.full(track.shape, np.nan)
        dt_left, dt_right = np.diff(t)[:-1], np.diff(t)[1:]
        slope = (track[1:] - track[:-1]) / np.diff(t)[:, None]
        acc[1:-1] = 2 * (slope[1:] - slope[:-1]) / (dt_left + dt_right)[:, None]
        acc[1:-1][~(found[:-2] & found[1:-1] & found[2:])] = np.nan
        candidates = np.array([offset_ns - step_ns, offset_ns, offset_ns + step_ns])
        gap, weight = self.gaps(candidates)
        i, w, ok = self.weights(offset_ns)
        ok = ok & np.isfinite(gap).all(axis=0)
        if ok.sum() < 2:
            return 0.0
        i, w = i[ok], w[ok]
        # The larger bend of the bracket's two frames (either may lack its neighbours).
        a = np.where(np.isfinite(acc[i]), acc[i], acc[i + 1])
        a_other = np.where(np.isfinite(acc[i + 1]), acc[i + 1], acc[i])
        larger = np.linalg.norm(np.nan_to_num(a_other), axis=1) > np.linalg.norm(
            np.nan_to_num(a), axis=1
        )
        a = np.where(larger[:, None], a_other, a)
        dt = t[i + 1] - t[i]
        share = np.full_like(w, 0.25) if half else w * (1 - w)
        miss = (0.5 * share * dt**2)[:, None] * np.nan_to_num(a)
        at = self.times[1][ok] - offset_ns
        u1, _ = self.camera1_at(at)
        u2 = self.tracks[1][ok]
        dg = epipolar_gap_px(self.pair, u1 + miss, u2) - epipolar_gap_px(self.pair, u1, u2)
        s = (gap[2, ok] - gap[0, ok]) / (2 * step_ns)
        v = weight[1, ok]
        info = float((s**2 / v).sum())
        if not info > 0:
            return 0.0
        # Signed (a bend shared by neighbouring frames moves them alike) and random parts.
        shift = abs(float((np.nan_to_num(dg) * s / v).sum())) / info
        spread = float(np.sqrt((np.nan_to_num(dg) ** 2 * s**2 / v**2).sum())) / info
        return float(np.hypot(shift, spread))


def offset_from_ray_gap(
    pair: PairCalibration,
    track1_px: ArrayLike,
    t1_ns: ArrayLike,
    track2_px: ArrayLike,
    t2_ns: ArrayLike,
    *,
    search_ns: tuple[float, float] = (-SEARCH_NS, SEARCH_NS),
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

    Returns
    -------
    ClockOffset
    """
    tracks, times = (track1_px, track2_px), (t1_ns, t2_ns)
    dots = _dot_tracks(pair, tracks, times)
    try:
        offset = _ray_gap(dots, search_ns)
    except InputValueError as err:
        raise InputValueError(f"{err}{_swapped_hint(pair, tracks, times, search_ns)}") from err
    # Exchanged cameras can still find a minimum (a wrong one, with a small sigma): the
    # gap far smaller the other way round refuses it.
    hint = _swapped_hint(pair, tracks, times, search_ns)
    if hint:
        raise InputValueError(hint.removeprefix("; "))
    return offset


def _ray_gap(dots: _DotTracks, search_ns: tuple[float, float]) -> ClockOffset:
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
    # Least squares on S = n * mean: var = 2 s^2 / S'', s^2 = S_min / (n - 1).
    min_mean = c1 - 0.25 * (c0 - c2) ** 2 / (c0 - 2 * c1 + c2) / 2
    variance = 2 * max(min_mean, 0.0) / ((n - 1) * curvature) * dots.correlation_factor(vertex)
    if np.sqrt(variance) > MAX_SIGMA_SHARE * interval:
        raise InputValueError(_NOT_FIXED)
    # A likelihood ratio against every offset a frame or more away: one that fits nearly
    # as well (the motion along the epipolar lines fits every offset; a periodic one
    # several) leaves the offset unknown.
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
    if bend > MAX_SIGMA_SHARE * interval:
        raise InputValueError(
            f"the target's track bends too much between camera 1's frames to be interpolated "
            f"(the offset could be off by {bend / 1e6:.1f} ms): move it slower or straighter, "
            "or drop fewer frames"
        )
    return ClockOffset(
        offset_ns=float(vertex), sigma_ns=float(np.sqrt(variance)), method="ray gap", n=n
    )


def _basins(
    dots: _DotTracks, coarse: F64, cost: F64, interval: float
) -> list[tuple[float, float, float]]:
    """The coarse cost's :data:`BASINS` lowest local minima refined: (offset ns, mean, n).

    A quarter-frame grid step can straddle a fast target's narrow basin (the point beside
    the true bottom costing more than one beside another period's): each is searched again
    at ``interval / 32`` a coarse step either way, and ranked by its bottom. A path
    repeating within a coarse step or two is not resolved by this grid at all.
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
    add at another phase (``bend``, :meth:`_DotTracks.bend_px2`) is no evidence and is
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


_NOT_FIXED = (
    "the target's motion does not fix the clock offset (it moved along the epipolar lines, "
    "or too little): move it across them, up and down for cameras side by side"
)


def _swapped_hint(
    pair: PairCalibration,
    tracks: tuple[ArrayLike, ArrayLike],
    times: tuple[ArrayLike, ArrayLike],
    search_ns: tuple[float, float],
) -> str:
    """Words for a refusal when the cameras look exchanged: the gap far smaller so."""
    try:
        ours = _dot_tracks(pair, tracks, times)
        # The pair as calibrated, fed each camera's track as the other's.
        theirs = _dot_tracks(pair, (tracks[1], tracks[0]), (times[1], times[0]))
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


def _dot_tracks(
    pair: PairCalibration, tracks: tuple[ArrayLike, ArrayLike], times: tuple[ArrayLike, ArrayLike]
) -> _DotTracks:
    """Both cameras' dot tracks checked, undistorted, their times fitted by a regular clock."""
    lenses = (LensModel.of(pair.intrinsics1), LensModel.of(pair.intrinsics2))
    undistorted, fitted, found, sigma = [], [], [], []
    for n in (0, 1):
        p = np.asarray(tracks[n], dtype=np.float64).reshape(-1, 2)
        stamps = np.asarray(times[n], dtype=np.float64).reshape(-1)
        if p.shape[0] != stamps.size:
            raise InputValueError(f"camera {n + 1}: {p.shape[0]} pixels for {stamps.size} times")
        ok = np.asarray(np.isfinite(p).all(axis=1))
        undistorted.append(np.where(ok[:, None], lenses[n].undistort(np.nan_to_num(p)), np.nan))
        clock = regular_times(stamps)
        fitted.append(clock.times_ns)
        sigma.append(clock.sigma_ns)
        found.append(ok)
    interval = float(np.median(np.diff(fitted[0])))
    return _DotTracks(
        pair=pair,
        tracks=(undistorted[0], undistorted[1]),
        times=(fitted[0], fitted[1]),
        found=(found[0], found[1]),
        gap_ns=2.5 * interval,  # one dropped frame between two neighbours is bridged
        clock_sigma=(sigma[0], sigma[1]),
    )
