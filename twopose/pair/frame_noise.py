"""A camera's detection noise per frame, from its own frames (issue 58, the regions).

A stream's 95% regions carry each frame's detection noise (``StreamNoise``: the centroid's
1-sigma in pixels, an image line's direction's in degrees). :func:`camera_noise` makes it,
each camera on its own, by the one-camera path's rule for a pose's measurement
(:func:`twopose.uncertainty.propagate.measurement_covariance`): the frames' own scatter
plus the detector's floor (its systematic error, the same in every frame of a target
standing still, which no scatter can see: the method's ``floor_in_pair``, its 1-sigma in a
camera of a pair measured on rendered views by ``benchmarks/bench_detector_floor.py`` at
the image sizes ``FLOOR_MEASURED_SIZES``; at another size the noise says its floor is
unmeasured there). The scatter is a moving target's,
so it is measured about a smooth local fit in time:

- every run of :data:`WINDOW_FRAMES` consecutive found frames (no more than
  :data:`MAX_SPAN_INTERVALS` frame intervals long: a dropped or lost frame or two bridged)
  is fitted by a polynomial of degree :data:`DEGREE` in its capture times, and the middle
  frame's residual divided by its own 1-sigma factor ``sqrt(1 - h)`` (``h`` the fit's
  leverage there): for white noise of 1-sigma ``s`` each such residual has 1-sigma ``s``
  whatever the frames' times. The window being symmetric about its middle frame, the
  quadratic's residual there is blind to the motion's cubic term as well (Savitzky-Golay):
  a fingertip moving at 10 in/s 14 in ahead leaves 0.004 px;
- a finger's centroid across its image line only (along it, the centroid moves no plane
  through the line), and the line's direction as its doubled angle unwrapped (a line has
  no arrow);
- ``s`` is then found robustly: from the residuals' 20% quantile (a low start: a target
  that stops and starts, as a finger touching a point does, or a detection that wobbles,
  makes some residuals far larger than the noise), then iterated: the residuals within
  :data:`CLIP_SIGMA` ``s`` kept, their mean square divided by the share of a normal's
  variance that clip keeps, until it holds. Where the motion is not smooth at the scale of
  five frames, its residuals are larger and the estimate only conservative;
- its degrees of freedom are Satterthwaite's for the kept residuals, which share frames
  (``m^2 / sum_kl (c_k . c_l)^2`` over their unit filters ``c``): about half their count;
- the noise used, ``sqrt(scatter^2 + floor^2)``, has the scatter's degrees of freedom
  times ``((scatter^2 + floor^2) / scatter^2)^2`` (Welch-Satterthwaite, the floor known):
  where the floor dominates, a few frames know it well, if the scatter has at least
  :data:`MIN_SCATTER_DOF` of its own. With fewer than :data:`MIN_DOF` (too few frames, a
  target mostly lost) the assumed noise is used, and said so with why.

Several tracks of one camera (a session's stream trials, a live pointing's last seconds)
are pooled: their residuals are one sample. Arrays in, a frozen record out; no I/O.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64, Bools
from twopose.methods.specs import floor_unmeasured
from twopose.pair.stream import CameraTrack, StreamNoise

__all__ = [
    "CLIP_SIGMA",
    "DEGREE",
    "MAX_SPAN_INTERVALS",
    "MIN_DOF",
    "MIN_SCATTER_DOF",
    "WINDOW_FRAMES",
    "CameraNoise",
    "camera_noise",
]

#: Frames per local fit: odd, so that the fitted frame is the window's middle.
WINDOW_FRAMES = 5
#: The local fit's degree in time (with the symmetric window, exact to the cubic term).
DEGREE = 2
#: A window spans at most this many frame intervals (four: none lost; six: two bridged).
MAX_SPAN_INTERVALS = 6.5
#: Residuals beyond this many sigma are the motion's or a wobble's, not the noise's.
CLIP_SIGMA = 3.0
#: Fewer degrees of freedom than this in the noise used: it is assumed instead (its sigma
#: known to ~13% here).
MIN_DOF = 30.0
#: ... and the scatter itself at least this many: fewer residuals are no estimate of it at
#: all (its 95% upper bound 1.6 times it at 10; the sum's dof, from the estimate, would
#: trust a scatter that came out small by chance).
MIN_SCATTER_DOF = 10.0
#: The robust start: this quantile of the residuals' magnitudes, over a normal's.
_START_QUANTILE = 0.2
_NORMAL_ABS_Q20 = 0.2533471031357997  # the 20% quantile of |z|, z ~ N(0, 1)


def _kept_variance(c: float) -> float:
    """The share of a normal's variance within +-c sigma, over its share of mass."""
    mass = math.erf(c / math.sqrt(2.0))
    density = math.exp(-0.5 * c * c) / math.sqrt(2.0 * math.pi)
    return 1.0 - 2.0 * c * density / mass


_KEPT = _kept_variance(CLIP_SIGMA)


@dataclass(frozen=True, kw_only=True)
class CameraNoise:
    """One camera's detection noise per frame and where it came from (:func:`camera_noise`).

    ``noise`` the 1-sigma the regions carry; ``source`` ``estimated`` (the frames' own
    ``scatter`` with the detector's ``floor`` added), ``assumed`` (too few frames: ``why``
    says why) or ``given``; ``dof_px``/``dof_deg`` the scatter's degrees of freedom (the
    direction's NaN for a dot); ``frames`` the found frames looked at.
    """

    noise: StreamNoise
    source: str
    scatter: StreamNoise | None = None
    floor: tuple[float, float] = (0.0, 0.0)
    dof_px: float = 0.0
    dof_deg: float = math.nan
    frames: int = 0
    why: str = ""
    #: the noise's degrees of freedom, centroid's and direction's: the scatter's with the
    #: floor known (Welch-Satterthwaite; infinite for a given noise, 0 for an assumed one)
    noise_dof: tuple[float, float] = (0.0, 0.0)
    #: words where the floor was not measured at the camera's image size ("" where it was:
    #: :func:`twopose.methods.specs.floor_unmeasured`), said with the noise
    unmeasured: str = ""

    @classmethod
    def given(cls, noise: StreamNoise) -> CameraNoise:
        """A noise given by the user (not estimated)."""
        return cls(noise=noise, source="given", noise_dof=(math.inf, math.inf))

    def said(self, *, lines: bool) -> str:
        """In words.

        E.g. "pixel noise 0.104 px, 0.094 deg: the frames' scatter 0.03 px, 0.05 deg (from
        412 frames, dof 190, 95) and the detector's floor 0.15 px, 0.15 deg", or "pixel noise
        assumed 0.25 px (too few frames: ...)".
        """

        def value(n: StreamNoise | tuple[float, float]) -> str:
            px, deg = (n.centroid_px, n.theta_deg) if isinstance(n, StreamNoise) else n
            return f"{px:.2g} px" + (f", {deg:.2g} deg" if lines else "")

        if self.source == "estimated" and self.scatter is not None:
            dof = f"{self.dof_px:.0f}" + (f", {self.dof_deg:.0f}" if lines else "")
            return (
                f"pixel noise {value(self.noise)}: the frames' scatter {value(self.scatter)} "
                f"(estimated from {self.frames} frames, dof {dof}) and the detector's floor "
                f"{value(self.floor)}" + (f" ({self.unmeasured})" if self.unmeasured else "")
            )
        if self.source == "given":
            return f"pixel noise {value(self.noise)} given"
        return f"pixel noise assumed {value(self.noise)}" + (f" ({self.why})" if self.why else "")


@dataclass(frozen=True, kw_only=True, eq=False)
class _Residuals:
    """Standardised residuals (M,) and their unit filters' overlaps with the next four."""

    z: F64
    overlap: F64  # (M, WINDOW_FRAMES - 1): c_k . c_{k+d}, d = 1..4 (0: not neighbours)


def _residuals(t_ns: F64, y: F64, interval: float) -> _Residuals:
    """The middle frames' standardised residuals of ``y`` (N,) about their local fits."""
    W, half = WINDOW_FRAMES, WINDOW_FRAMES // 2
    n = y.size
    if n < W or not interval > 0:
        return _Residuals(z=np.zeros(0), overlap=np.zeros((0, W - 1)))
    idx = np.arange(n - W + 1)[:, None] + np.arange(W)[None, :]
    x = (t_ns[idx] - t_ns[idx[:, half]][:, None]) / interval  # (M, W), the middle at 0
    span_ok = (x[:, -1] - x[:, 0]) <= MAX_SPAN_INTERVALS
    X = x[:, :, None] ** np.arange(DEGREE + 1)[None, None, :]  # (M, W, D+1)
    # The middle row of the hat matrix: e0^T (X^T X)^-1 X^T, e0 the constant term.
    gram = np.einsum("mwi,mwj->mij", X, X)
    e0 = np.zeros(DEGREE + 1)
    e0[0] = 1.0
    a = np.linalg.solve(gram, np.broadcast_to(e0, (x.shape[0], DEGREE + 1))[..., None])[..., 0]
    h = np.einsum("mi,mwi->mw", a, X)
    c = -h
    c[:, half] += 1.0
    c /= np.linalg.norm(c, axis=1, keepdims=True)
    z = np.einsum("mw,mw->m", c, y[idx])
    M = x.shape[0]
    overlap = np.zeros((M, W - 1))
    for d in range(1, min(W, M)):  # rows k and k + d share W - d frames
        overlap[: M - d, d - 1] = np.einsum("mw,mw->m", c[:-d, d:], c[d:, : W - d])
        overlap[: M - d, d - 1] *= span_ok[d:]
    overlap[~span_ok, :] = 0.0
    z = np.where(span_ok, z, np.nan)
    return _Residuals(z=z, overlap=overlap)


def _robust_sigma(z: F64) -> tuple[float, Bools]:
    """The noise's 1-sigma from standardised residuals, and which were kept (module doc)."""
    a = np.abs(z)
    if not a.size:
        return math.nan, np.zeros(0, dtype=bool)
    sigma = float(np.quantile(a, _START_QUANTILE)) / _NORMAL_ABS_Q20
    if sigma == 0.0:  # a fifth or more exactly 0 (detections repeated): start from above
        sigma = math.sqrt(float(np.mean(a**2)))
    kept = np.ones(a.size, dtype=bool)
    for _ in range(100):
        kept = a <= CLIP_SIGMA * sigma
        if not kept.any():
            break
        new = math.sqrt(float(np.mean(a[kept] ** 2)) / _KEPT)
        if abs(new - sigma) <= 1e-9 * max(sigma, 1e-300):
            sigma = new
            break
        sigma = new
    return sigma, a <= CLIP_SIGMA * sigma


def _estimate(series: list[_Residuals]) -> tuple[float, float]:
    """The 1-sigma and its degrees of freedom from every series' residuals, pooled."""
    if not series:
        return math.nan, 0.0
    z = np.concatenate([s.z for s in series])
    good = np.isfinite(z)
    sigma, kept_good = _robust_sigma(z[good])
    kept = np.zeros(z.size, dtype=bool)
    kept[good] = kept_good
    # Satterthwaite: m^2 / sum_kl (c_k . c_l)^2 over the kept residuals.
    square, start = 0.0, 0
    for s in series:
        k = kept[start : start + s.z.size]
        start += s.z.size
        square += float(k.sum())
        for d in range(1, WINDOW_FRAMES):
            both = k[:-d] & k[d:] if k.size > d else np.zeros(0, dtype=bool)
            square += 2.0 * float(np.sum(s.overlap[: k.size - d, d - 1][both] ** 2))
    m = float(kept.sum())
    return sigma, (m * m / square if square > 0 else 0.0)


def _with_floor(scatter: float, dof: float, floor: float) -> float:
    """The degrees of freedom of ``scatter^2 + floor^2``, the floor known.

    Welch-Satterthwaite: the scatter's, times the square of the sum over the scatter's part.
    """
    if not (dof > 0 and math.isfinite(scatter)):
        return 0.0
    if scatter == 0.0:
        return math.inf
    return dof * ((scatter**2 + floor**2) / scatter**2) ** 2


def _doubled_unwrapped(theta_deg: F64) -> F64:
    """A line's direction unwrapped through its doubled angle (degrees)."""
    return np.asarray(0.5 * np.degrees(np.unwrap(np.radians(2.0 * theta_deg))))


def camera_noise(
    tracks: Sequence[CameraTrack],
    *,
    lines: bool,
    floor: tuple[float, float],
    assumed: StreamNoise,
    size: tuple[int, int] | None = None,
) -> CameraNoise:
    """One camera's detection noise per frame from its tracks' frames (the module docstring).

    Parameters
    ----------
    tracks : sequence of CameraTrack
        The camera's tracks (a session's stream trials, or a live pointing's last frames),
        pooled.
    lines : bool
        Whether the image line's direction is measured (its scatter estimated too).
    floor : (float, float)
        The detector's systematic error per frame (centroid px, direction deg; the method's
        :attr:`twopose.methods.specs.MethodSpec.floor_in_pair`), added to the scatter.
    assumed : StreamNoise
        The noise used when too few frames give an estimate (said so).
    size : (int, int), optional
        The camera's image size (width, height): where the floor was not measured at it,
        the noise says so (:func:`twopose.methods.specs.floor_unmeasured`).

    Returns
    -------
    CameraNoise
    """
    px, deg, frames = [], [], 0
    for track in tracks:
        frames += int(track.found.sum())
        interval = float(np.median(np.diff(track.t_ns))) if track.t_ns.size > 1 else 0.0
        keep = track.found & np.isfinite(track.centroid_px).all(axis=1)
        if lines:
            keep &= np.isfinite(track.theta_deg)
        t, c = track.t_ns[keep], track.centroid_px[keep]
        u, v = _residuals(t, c[:, 0], interval), _residuals(t, c[:, 1], interval)
        if not lines:
            px += [u, v]
            continue
        # Across the line only: along it the centroid moves no plane through the line.
        half = WINDOW_FRAMES // 2
        middle = np.radians(track.theta_deg[keep][half : t.size - half])
        across = -np.sin(middle) * u.z + np.cos(middle) * v.z
        px.append(_Residuals(z=across, overlap=u.overlap))
        deg.append(_residuals(t, _doubled_unwrapped(track.theta_deg[keep]), interval))
    s_px, dof_px = _estimate(px)
    s_deg, dof_deg = _estimate(deg) if lines else (0.0, math.nan)
    with_floor = (
        _with_floor(s_px, dof_px, floor[0]) if dof_px >= MIN_SCATTER_DOF else dof_px,
        _with_floor(s_deg, dof_deg, floor[1]) if dof_deg >= MIN_SCATTER_DOF else dof_deg,
    )
    short = [
        f"{what} {dof:.0f} degrees of freedom"
        for what, dof, needed in (
            ("the centroid's", with_floor[0], True),
            ("the line's", with_floor[1], lines),
        )
        if needed and not dof >= MIN_DOF
    ]
    if short:
        why = (
            f"too few frames: {frames} found, {' and '.join(short)} where {MIN_DOF:.0f} are needed"
        )
        return CameraNoise(
            noise=assumed, source="assumed", dof_px=dof_px, dof_deg=dof_deg, frames=frames,
            why=why,
        )  # fmt: skip
    scatter = StreamNoise(centroid_px=s_px, theta_deg=s_deg)
    noise = StreamNoise(
        centroid_px=math.hypot(s_px, floor[0]),
        theta_deg=math.hypot(s_deg, floor[1]) if lines else assumed.theta_deg,
        shared_px=floor[0],
        shared_deg=floor[1] if lines else 0.0,
    )
    return CameraNoise(
        noise=noise, source="estimated", scatter=scatter, floor=floor, dof_px=dof_px,
        dof_deg=dof_deg, frames=frames, noise_dof=with_floor,
        unmeasured=floor_unmeasured(*size) if size is not None else "",
    )  # fmt: skip
