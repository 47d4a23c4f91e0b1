"""A stream trial's clock offset from all it saw: a flash and the rays' gap, pooled honestly.

The recorder (:mod:`recorder.procedure.stream_offset`, as a pair records) and the analysis
(:mod:`analysis.session.stream`, a session that recorded none) measure a trial's offset by
this one path, from each camera's frames' capture times, the target's track and each
frame's brightness:

- **brightness** (:class:`BrightnessMeter`): the mean linear level (the 2.2 gamma undone)
  of the pixels that were in the darkest tenth of the stream's first frame. A flash
  multiplies each pixel's light; those pixels it lights without saturating them, so the
  brightness stays linear in a frame's lit share, which :func:`twopose.pair.flash.
  offset_from_flash` assumes (the mean of the encoded values is not: a half-lit frame reads
  some 5% of a frame interval late);
- **a flash** is measured where both cameras' brightness steps up within two frames by
  :data:`FLASH_RISE` of its level and :data:`FLASH_NOISE` times its frame-to-frame scatter
  (:func:`flashed`: a deliberate flash, not a moving hand or the exposure settling);
- **the rays' gap** (:func:`twopose.pair.clock.offset_from_ray_gap`) wherever the target
  was tracked; for a target with an image line (the glove) its point's place along the
  line is fitted, not taken as one point both cameras see (:mod:`twopose.pair.dot_tracks`).

Both measured, they are one offset seen twice: pooled by their inverse variances, the
fitted clocks' error they share (:attr:`ClockOffset.clock_sigma_ns`: the same stamps'
fit) kept whole rather than averaged down (generalised least squares). Two that disagree
beyond :data:`AGREE_SIGMAS` of their combined 1-sigma are not pooled: the trial is said not
to fix the offset, both named (one of them is wrong, and a pool would hide which). Two
copies of one recording fix none: the target at one pixel in both cameras' every pair
(:mod:`twopose.pair.copied_view`) is said in place of any offset.

Over a session's trials the offsets are pooled by :func:`pooled_offset` (their
inverse-variance mean, widened by the Birge ratio where they scatter beyond their sigmas).
No I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from twopose.errors import InputValueError
from twopose.pair.calibration import PairCalibration
from twopose.pair.clock import offset_from_ray_gap
from twopose.pair.clock_fit import ClockOffset
from twopose.pair.copied_view import copied_view
from twopose.pair.flash import offset_from_flash

__all__ = [
    "AGREE_SIGMAS",
    "FLASH_NOISE",
    "FLASH_RISE",
    "BrightnessMeter",
    "TrialOffset",
    "flashed",
    "measure_trial_offset",
    "pooled_offset",
]

#: A flash: a camera's brightness rises by this share of its level before, at least ...
FLASH_RISE = 0.25
#: ... and by this many times its frame-to-frame scatter (robust: the median deviation).
FLASH_NOISE = 10.0
#: A flash's and the rays' gap's offsets of one trial further apart than this many of
#: their combined 1-sigma are not pooled (a 1-in-1.7-million chance for two honest ones).
AGREE_SIGMAS = 5.0
#: The share of the first frame's pixels, darkest first, whose level is the brightness.
DARK_SHARE = 0.1
#: The encoded level -> linear light (the sensor's 2.2 gamma undone), per 8-bit value.
_LINEAR = (np.arange(256, dtype=np.float64) / 255.0) ** 2.2


class BrightnessMeter:
    """One camera's frames' brightness over one stream (the module docstring).

    The first frame fixes the pixels measured (every fourth row and column, the darkest
    :data:`DARK_SHARE` of them); each frame's brightness is their mean linear level.
    """

    def __init__(self) -> None:
        self._mask: NDArray[np.bool_] | None = None

    def __call__(self, image: NDArray[np.uint8]) -> float:
        """The frame's brightness (linear, 0-1); NaN for an image of another size."""
        small = np.asarray(image)[::4, ::4]
        level = small.max(axis=2) if small.ndim == 3 else small
        if self._mask is None:
            self._mask = np.asarray(level <= np.quantile(level, DARK_SHARE))
        if level.shape != self._mask.shape:
            return math.nan
        return float(_LINEAR[level[self._mask]].mean())


def flashed(brightness: ArrayLike) -> bool:
    """Whether a camera's frames saw a flash.

    Its brightness steps up within two frames (an onset falls in one exposure or across
    two) by at least :data:`FLASH_RISE` of its level before, and by :data:`FLASH_NOISE`
    times the frames' own scatter. A moving target, a hand, a camera's exposure settling
    change it by far less, or slowly.
    """
    b = np.asarray(brightness, dtype=np.float64).reshape(-1)
    b = b[np.isfinite(b)]
    if b.size < 8:
        return False
    step = np.abs(np.diff(b))
    noise = 1.4826 * float(np.median(np.abs(step - np.median(step)))) + 1e-6
    rise = b[2:] - b[:-2]  # over two frames
    k = int(np.argmax(rise))
    level = float(np.median(b[: k + 1]))
    return float(rise[k]) > max(FLASH_RISE * level, FLASH_NOISE * noise)


def pooled_offset(offsets: list[ClockOffset]) -> ClockOffset:
    """Independent offsets (a session's trials') pooled.

    Their inverse-variance mean, its 1-sigma widened by the Birge ratio where they scatter
    beyond their sigmas.
    """
    x = np.array([o.offset_ns for o in offsets], dtype=np.float64)
    s = np.array([max(o.sigma_ns, 1.0) for o in offsets], dtype=np.float64)
    w = 1.0 / s**2
    mean = float((w * x).sum() / w.sum())
    sigma = math.sqrt(1.0 / float(w.sum()))
    if len(offsets) > 1:
        chi2 = float((w * (x - mean) ** 2).sum()) / (len(offsets) - 1)
        sigma *= max(1.0, math.sqrt(chi2))
    method = offsets[0].method if len({o.method for o in offsets}) == 1 else "pooled"
    clock = min(o.clock_sigma_ns for o in offsets)
    return ClockOffset(
        offset_ns=mean, sigma_ns=sigma, method=method, n=sum(o.n for o in offsets),
        clock_sigma_ns=min(clock, sigma),
    )  # fmt: skip


def _one_trial(flash: ClockOffset, gap: ClockOffset) -> ClockOffset:
    """A flash's and the rays' gap's offsets of one trial pooled.

    Generalised least squares, their shared clock error ``c^2`` the covariance of the two.
    """
    c2 = min(flash.clock_sigma_ns, gap.clock_sigma_ns) ** 2
    cov = np.array([[flash.sigma_ns**2, c2], [c2, gap.sigma_ns**2]])
    inv = np.linalg.inv(cov + 1e-6 * np.eye(2))  # 1e-6 ns^2: never singular
    w = inv.sum(axis=1) / inv.sum()
    x = np.array([flash.offset_ns, gap.offset_ns])
    sigma = math.sqrt(1.0 / float(inv.sum()))
    return ClockOffset(
        offset_ns=float(w @ x), sigma_ns=sigma, method="flash and ray gap",
        n=flash.n + gap.n, clock_sigma_ns=min(math.sqrt(c2), sigma),
    )  # fmt: skip


@dataclass(frozen=True, kw_only=True)
class TrialOffset:
    """A trial's offset (None: not fixed), each measurement made, and why not in words.

    ``why``: each way that could not measure it, or the two measurements' disagreement.
    """

    offset: ClockOffset | None
    found: tuple[ClockOffset, ...]
    why: tuple[str, ...]


def measure_trial_offset(
    pair: PairCalibration,
    tracks: tuple[ArrayLike, ArrayLike],
    times: tuple[ArrayLike, ArrayLike],
    brightness: tuple[ArrayLike, ArrayLike] | None = None,
    angles_deg: tuple[ArrayLike, ArrayLike] | None = None,
    floor_px: float = 0.0,
) -> TrialOffset:
    """One trial's offset (the module docstring).

    ``tracks`` each camera's target pixels (N_i, 2) (NaN: not found), ``times`` their
    capture times (N_i,), ns, each camera's clock; ``brightness`` each frame's
    (:class:`BrightnessMeter`; None: no flash looked for); ``angles_deg`` each frame's
    image line's angle for a target with one (the glove: its point's place along the line
    is fitted, :mod:`twopose.pair.dot_tracks`; None: a dot's); ``floor_px`` the
    detector's systematic error per camera (the method's
    :attr:`~twopose.methods.specs.MethodSpec.floor_in_pair`, px), a term of the rays'
    gap's sigma (:meth:`twopose.pair.dot_tracks.DotTracks.systematic_ns`).
    """
    found: list[ClockOffset] = []
    why: list[str] = []
    if brightness is not None:
        b1, b2 = (np.asarray(b, dtype=np.float64).reshape(-1) for b in brightness)
        if flashed(b1) and flashed(b2):
            t1, t2 = (np.asarray(t, dtype=np.float64).reshape(-1) for t in times)
            ok1, ok2 = np.isfinite(b1), np.isfinite(b2)
            try:
                found.append(offset_from_flash(b1[ok1], t1[ok1], b2[ok2], t2[ok2]))
            except InputValueError as err:
                why.append(f"the flash: {err}")
    try:
        found.append(
            offset_from_ray_gap(
                pair,
                tracks[0],
                times[0],
                tracks[1],
                times[1],
                angles_deg=angles_deg,
                floor_px=floor_px,
            )
        )
    except InputValueError as err:
        why.append(f"the rays' gap: {err}")
    # Two copies of one recording "measure" an offset (their own: 0) that means nothing.
    copy = copied_view(tracks, times, found[-1].offset_ns if found else 0.0)
    if copy.copied:
        return TrialOffset(offset=None, found=(), why=(copy.words(),))
    if len(found) < 2:
        return TrialOffset(offset=found[0] if found else None, found=tuple(found), why=tuple(why))
    flash, gap = found
    apart = abs(flash.offset_ns - gap.offset_ns) / math.hypot(flash.sigma_ns, gap.sigma_ns)
    if apart > AGREE_SIGMAS:
        why.append(
            f"the flash gives {flash.offset_ns / 1e6:+.2f} ± {flash.sigma_ns / 1e6:.2f} ms and "
            f"the rays' gap {gap.offset_ns / 1e6:+.2f} ± {gap.sigma_ns / 1e6:.2f} ms, "
            f"{apart:.0f} sigma apart: one of them is wrong (a flash of another light, a "
            "repeating or too fast motion): fire the flash again, alone, before the target "
            "moves"
        )
        return TrialOffset(offset=None, found=tuple(found), why=tuple(why))
    return TrialOffset(offset=_one_trial(flash, gap), found=tuple(found), why=tuple(why))
