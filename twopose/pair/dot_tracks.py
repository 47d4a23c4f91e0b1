"""Both cameras' tracks of a moving target, and the rays' gap at a candidate clock offset.

What :func:`twopose.pair.clock.offset_from_ray_gap` searches over: each camera's target
track undistorted, its frame times fitted by a regular clock
(:func:`twopose.pair.clock_fit.regular_times`), camera 1's track interpolated (linearly) to
camera 2's capture times at a candidate offset, and the rays' gap there in pixels
(Sampson's first-order distance to the pair's epipolar constraint), with the terms of the
offset's 1-sigma the tracks themselves set (the gaps' correlation, camera 1's
interpolation error, the fitted clocks' error).

**A target with an image line** (the glove: each frame's line through its centroid, at the
detected angle) is not one point both cameras see: each camera's blob spans its own extent
of the finger, so the two centroids lie at different places along the finger's axis, on
the images of one 3-D line (the rendered sessions' centroids some 5 px along it from the
finger's middle, one way in camera 1 and another in camera 2; the rays' gap on them was
2.6 to 2.9 ms off RMS, 10 of its sigmas in one scene). Where along the finger camera 1's
point lies is then not known: the gap is measured from camera 1's point slid along the
finger by ``s`` (one length for the trial: the part of the finger a blob spans is a
property of the finger and the detector), the finger's 3-D line at each frame being where
the planes of the two cameras' image lines meet (camera 1's interpolated like its point).
``s`` is fitted at every candidate offset by least squares (the gap is linear in it to
first order) and profiled out, so that only the gap's part no slide explains measures the
offset, and the profile's curvature (the Schur complement) carries the slide's
uncertainty into the offset's sigma. Camera 2's point's own slide moves the point its ray
meets along the same line, so one slide stands for both. A slide of a fixed number of
pixels along camera 1's image line instead is not one: a 3-D slide's image length changes
with the finger's place (perspective), and ±0.3 in along a finger circling at 10 in/s was
then 10 ms off with a sigma of 0.5. A finger swept straight at one steady velocity fixes
little (a constant gap is a slide: only perspective is left), and its sigma says so (2.4
ms where a dot's is 0.26; without the slide, 0.05 in along the finger took it 13 ms off,
19 of its sigmas), or the refusals. Other offsets than the best are judged with the
slide held at the best's (:meth:`DotTracks.holding_slide`). No I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike

from twopose.arrays import F64, Bools, Ints
from twopose.errors import InputValueError
from twopose.pair.board_fit import LensModel
from twopose.pair.calibration import PairCalibration
from twopose.pair.clock_fit import regular_times

__all__ = ["MIN_GAP_FRAMES", "DotTracks", "dot_tracks", "epipolar_gap_px", "line_directions"]

#: The fewest camera-2 frames an offset candidate's gap is averaged over.
MIN_GAP_FRAMES = 10
#: Half the span (px) over which a line's direction is undistorted about its centroid.
LINE_STEP_PX = 10.0
#: How far (px, the 1-sigma of a Gaussian) the target moves in the image before the
#: detector's error in it is another (:meth:`DotTracks.systematic_ns`). Over rendered
#: gloves at 2 and 10 in/s, 5 px left the offsets' errors about 1 of their sigmas.
POSE_PX = 5.0
_GRID = 2000  # the most cells a side of the grid the gaps' correlation is summed on


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
class DotTracks:
    """Both cameras' undistorted dot tracks (N, 2), fitted times (N,) and found flags."""

    pair: PairCalibration
    tracks: tuple[F64, F64]
    times: tuple[F64, F64]
    found: tuple[Bools, Bools]
    gap_ns: float  # the widest span between two camera-1 frames interpolated between
    clock_sigma: tuple[F64, F64]  # each fitted time's 1-sigma (regular_times)
    #: each camera's image line's unit direction per frame (N_i, 2), one sense throughout
    #: (None: a dot's tracks, whose point both cameras see)
    lines: tuple[F64, F64] | None = None
    #: a line's slide along the finger held (None: fitted at every candidate offset)
    slide: float | None = None

    @property
    def nuisances(self) -> int:
        """The parameters fitted beside the offset: the slide along a line's (1), none (0)."""
        return 0 if self.lines is None else 1

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

    def gaps(self, candidates: F64, *, fit: Bools | None = None) -> tuple[F64, F64]:
        """(C, N2) the rays' gap (px) at each candidate offset, and its noise weight.

        (:meth:`_gaps`, without the slides.)
        """
        gap, weight, _ = self._gaps(candidates, fit=fit)
        return gap, weight

    def _gaps(self, candidates: F64, *, fit: Bools | None = None) -> tuple[F64, F64, F64]:
        """(C, N2) the rays' gap (px) at each candidate offset, and its noise weight.

        The weight is camera 2's frame and camera 1's two, by ``1 - w`` and ``w`` (equal
        noise taken), ``1 + w^2 + (1 - w)^2`` times one frame's variance; NaN gaps where
        camera 1 has no frames about camera 2's. A line's gaps are those left by the slide
        along the finger that fits best at each candidate (the module docstring), fitted
        over camera 2's frames ``fit`` (N2,) (default all), or held (:attr:`slide`); and
        (C,) the slides (0 for a dot's).
        """
        at = self.times[1][None, :] - candidates[:, None]
        u1, w = self.camera1_at(at)
        u2 = np.broadcast_to(np.where(self.found[1][:, None], self.tracks[1], np.nan), u1.shape)
        gap = epipolar_gap_px(self.pair, u1, u2)
        weight = 1 + w**2 + (1 - w) ** 2
        if self.lines is None:
            return gap, weight, np.zeros(candidates.shape)
        d1 = self._line1_at(at)
        # The gap's rate with the slide (per unit length along the finger; linear to first
        # order), and the slide that fits best at each candidate (least squares).
        rate = epipolar_gap_px(self.pair, u1 + self._slide_px(u1, d1, u2), u2) - gap
        rate = np.where(np.isfinite(rate), rate, 0.0)
        use = np.isfinite(gap) & (True if fit is None else fit[None, :])
        num = np.where(use, gap * rate / weight, 0.0).sum(axis=1)
        den = np.where(use, rate**2 / weight, 0.0).sum(axis=1)
        slide = num / np.where(den > 0, den, np.inf)
        if self.slide is not None:  # held (:meth:`holding_slide`)
            slide = np.full_like(slide, self.slide)
        return gap - slide[:, None] * rate, weight, slide

    def holding_slide(self, offset_ns: float) -> DotTracks:
        """These tracks with a line's slide held at the one fitted at ``offset_ns``.

        What another period of a path is judged by (:func:`twopose.pair.clock._ray_gap`):
        a path that repeats repeats the finger's pose, and with it the slide, so a true
        repeat fits as well with it held; a slide fitted anew at every offset would let
        an offset a second away fit by sliding the point inches along the finger.
        """
        if self.lines is None:
            return self
        held = float(self._gaps(np.array([offset_ns]))[2][0])
        return DotTracks(
            pair=self.pair, tracks=self.tracks, times=self.times, found=self.found,
            gap_ns=self.gap_ns, clock_sigma=self.clock_sigma, lines=self.lines, slide=held,
        )  # fmt: skip

    def _slide_px(self, u1: F64, d1: F64, u2: F64) -> F64:
        """(C, N2, 2) camera 1's pixel step for a unit slide along the finger in 3-D.

        The finger's 3-D line is where the planes of the two cameras' image lines meet
        (camera 1's at ``u1`` along ``d1``, camera 2's at ``u2`` along its own line);
        camera 1's point's ray meets it at ``X``, and ``X + D`` (``D`` its unit direction,
        in the sense of ``d1``) projects a step from ``u1``. 0 where the planes are nearly
        one (the line along the epipolar lines: a slide there moves no gap).
        """
        assert self.lines is not None
        pair = self.pair
        k1inv = np.linalg.inv(pair.intrinsics1.K)
        k2inv = np.linalg.inv(pair.intrinsics2.K)

        def ray(k_inv: ArrayLike, px: ArrayLike) -> F64:
            """Pixels' rays (..., 3) in their camera's frame."""
            p = np.asarray(px, dtype=np.float64)
            return np.asarray(
                np.concatenate([p, np.ones((*p.shape[:-1], 1))], -1) @ np.transpose(k_inv)
            )

        r1 = ray(k1inv, u1)
        n1 = np.cross(r1, ray(k1inv, u1 + d1))
        d2 = np.broadcast_to(self.lines[1], u2.shape)
        r2 = ray(k2inv, u2) @ pair.R_2_to_1.T
        n2 = np.cross(r2, ray(k2inv, u2 + d2) @ pair.R_2_to_1.T)
        with np.errstate(invalid="ignore", divide="ignore"):
            n1 = n1 / np.linalg.norm(n1, axis=-1, keepdims=True)
            n2 = n2 / np.linalg.norm(n2, axis=-1, keepdims=True)
            D = np.cross(n1, n2)
            sin = np.linalg.norm(D, axis=-1, keepdims=True)
            D = D / sin
            mu = (n2 @ pair.t_2_in_1)[..., None] / (n2 * r1).sum(-1, keepdims=True)
            X = mu * r1
            Y = X + D
            q = Y @ pair.intrinsics1.K.T
            step = q[..., :2] / q[..., 2:3] - u1
            step = np.where((step * d1).sum(-1, keepdims=True) < 0, -step, step)
        return np.where((sin > 0.05) & np.isfinite(step), step, 0.0)

    def _line1_at(self, at: F64) -> F64:
        """Camera 1's image line's unit direction at times ``at`` (C, N2, 2).

        Interpolated as its point is (:meth:`camera1_at`: NaN where that is).
        """
        assert self.lines is not None
        times = self.times[0]
        j = np.clip(np.searchsorted(times, at, side="right"), 1, times.size - 1)
        i = j - 1
        w = ((at - times[i]) / (times[j] - times[i]))[..., None]
        d = self.lines[0][i] * (1 - w) + self.lines[0][j] * w
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.asarray(d / np.linalg.norm(d, axis=-1, keepdims=True))

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

    def motion_frames(
        self, offset_ns: float, step_ns: float, noise_px2: float
    ) -> tuple[float, float]:
        """What the offset rests on: the gaps' rates against their noise, and how many frames.

        A gap's rate with the offset ``s`` is camera 1's velocity between the two frames it
        interpolates, and its noise alone makes a still frame's (variance ``2 noise_px2 /
        dt^2``, ``noise_px2`` a camera's noise in gap units: the best's mean squared gap per
        unit weight). Returns the ratio of ``sum s^2 / v`` to what noise alone gives (about
        1 for a still target: its curvature is the noise's, and so would its sigma be),
        and the participation ratio ``(sum i)^2 / sum i^2`` of each frame's information
        beyond the noise's, ``i = (s^2 - 2 noise_px2 / dt^2)+ / v``: the number of frames
        the motion is spread over (one frame of motion among still ones: 1).
        """
        candidates = np.array([offset_ns - step_ns, offset_ns + step_ns])
        gap, weight = self.gaps(candidates)
        i, _, ok = self.weights(offset_ns)
        rate2 = ((gap[1] - gap[0]) / (2 * step_ns)) ** 2
        dt = self.times[0][i + 1] - self.times[0][i]
        v = weight.mean(axis=0)
        use = np.isfinite(rate2) & ok
        noise = 2 * noise_px2 / dt[use] ** 2 / v[use]
        seen = rate2[use] / v[use]
        ratio = float(seen.sum() / noise.sum()) if noise.sum() > 0 else np.inf
        info = np.clip(seen - noise, 0.0, None)
        total = float((info**2).sum())
        return ratio, (float(info.sum() ** 2 / total) if total > 0 else 0.0)

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

    def systematic_ns(self, offset_ns: float, step_ns: float, floor_px: float) -> float:
        """The offset's error (ns) the detector's slowly varying error makes, 1-sigma.

        A detector errs by much the same in frames of much the same pose (the blob's
        outline and shading against the pixel grid: the method's floor in a pair,
        ``floor_px`` per camera), so a gap's error ``d`` is shared by the frames about the
        same place and changes as the target moves on: no frame average shrinks it and no
        jackknife over runs sees it. It moves the offset by ``sum(d s / v) / sum(s^2 / v)``
        (``s`` each gap's rate with the offset, a line's slide profiled out, ``v`` its
        weight); its variance, the gaps' errors correlated as ``2 floor_px^2
        exp(-r^2 / 2 l^2)`` (``r`` camera 2's frames' distance in the image, ``l`` =
        :data:`POSE_PX`; both cameras' errors), is ``a^T C a`` with ``a = (s / v) /
        sum(s^2 / v)``. A slow target's offset rests on its few frames of motion, and a
        detector error that changes with it is what it sees: a glove at 2 in/s, its
        centroid's place along the finger drifting 0.1 px as the finger came down in 1 s
        of 6, was 14 ms off at 35 of a sigma of 0.4 ms without it.
        """
        if not floor_px > 0:
            return 0.0
        candidates = np.array([offset_ns - step_ns, offset_ns + step_ns])
        gap, weight = self.gaps(candidates)
        s = (gap[1] - gap[0]) / (2 * step_ns)
        use = np.isfinite(s)
        s, v, place = s[use], weight.mean(axis=0)[use], self.tracks[1][use]
        info = float((s**2 / v).sum())
        if not info > 0:
            return 0.0
        # a^T C a by binning a at each frame's pixel (1 px, or coarser over a huge span)
        # and blurring by the Gaussian: a sum over pairs of frames without the pairs.
        a = s / v / info
        step = max(1.0, float(np.ptp(place, axis=0).max()) / _GRID)
        cell = np.round((place - place.min(axis=0)) / step).astype(np.intp)
        binned = np.zeros(tuple(int(n) + 1 for n in cell.max(axis=0)), dtype=np.float64)
        np.add.at(binned, (cell[:, 0], cell[:, 1]), a)
        taps = np.arange(-np.ceil(4 * POSE_PX / step), np.ceil(4 * POSE_PX / step) + 1)
        kernel = np.exp(-0.5 * (taps * step / POSE_PX) ** 2)
        blurred = cv2.sepFilter2D(
            binned, cv2.CV_64F, kernel, kernel, borderType=cv2.BORDER_CONSTANT
        )
        total = float((binned * blurred).sum())
        return float(np.sqrt(2.0 * max(total, 0.0)) * floor_px)

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


def line_directions(lens: LensModel, centroid_px: F64, angle_deg: F64) -> F64:
    """(N, 2) a track's image line's unit direction, undistorted, one sense throughout.

    The line through each (distorted) centroid at its angle, undistorted over
    :data:`LINE_STEP_PX` about the centroid; each direction turned to the sense of the
    track's mean line (the mean of the doubled angles: a detector's angle in (-90, 90]
    flips sense across the vertical). NaN where the angle or the centroid is.
    """
    a = np.radians(np.asarray(angle_deg, dtype=np.float64).reshape(-1))
    step = LINE_STEP_PX * np.column_stack([np.cos(a), np.sin(a)])
    ok: Bools = np.asarray(np.isfinite(step).all(axis=1) & np.isfinite(centroid_px).all(axis=1))
    c, step = np.nan_to_num(centroid_px), np.nan_to_num(step)
    d = lens.undistort(c + step) - lens.undistort(c - step)
    d = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
    doubled = np.angle(np.sum(np.where(ok, (d[:, 0] + 1j * d[:, 1]) ** 2, 0.0)))
    mean = np.array([np.cos(doubled / 2), np.sin(doubled / 2)])
    d = np.where((d @ mean < 0)[:, None], -d, d)
    return np.where(ok[:, None], d, np.nan)


def dot_tracks(
    pair: PairCalibration,
    tracks: tuple[ArrayLike, ArrayLike],
    times: tuple[ArrayLike, ArrayLike],
    angles_deg: tuple[ArrayLike, ArrayLike] | None = None,
) -> DotTracks:
    """Both cameras' tracks checked, undistorted, their times fitted by a regular clock.

    ``angles_deg`` ((N1,), (N2,)): each camera's image line's angle per frame (a line
    target's, the module docstring: its point's slide along the finger fitted); None: a
    dot's.
    """
    lenses = (LensModel.of(pair.intrinsics1), LensModel.of(pair.intrinsics2))
    undistorted, fitted, found, sigma, lines = [], [], [], [], []
    for n in (0, 1):
        p = np.asarray(tracks[n], dtype=np.float64).reshape(-1, 2)
        stamps = np.asarray(times[n], dtype=np.float64).reshape(-1)
        if p.shape[0] != stamps.size:
            raise InputValueError(f"camera {n + 1}: {p.shape[0]} pixels for {stamps.size} times")
        ok = np.asarray(np.isfinite(p).all(axis=1))
        if angles_deg is not None:
            angle = np.asarray(angles_deg[n], dtype=np.float64).reshape(-1)
            if angle.size != stamps.size:
                raise InputValueError(
                    f"camera {n + 1}: {angle.size} angles for {stamps.size} times"
                )
            lines.append(line_directions(lenses[n], p, angle))
            ok &= np.isfinite(lines[n]).all(axis=1)
        undistorted.append(np.where(ok[:, None], lenses[n].undistort(np.nan_to_num(p)), np.nan))
        clock = regular_times(stamps)
        fitted.append(clock.times_ns)
        sigma.append(clock.sigma_ns)
        found.append(ok)
    interval = float(np.median(np.diff(fitted[0])))
    return DotTracks(
        pair=pair,
        tracks=(undistorted[0], undistorted[1]),
        times=(fitted[0], fitted[1]),
        found=(found[0], found[1]),
        gap_ns=2.5 * interval,  # one dropped frame between two neighbours is bridged
        clock_sigma=(sigma[0], sigma[1]),
        lines=(lines[0], lines[1]) if lines else None,
    )
