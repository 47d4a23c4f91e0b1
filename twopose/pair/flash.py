"""The two cameras' clock offset from a flash both cameras see, with its 1-sigma.

Each camera's frame brightness steps up; a frame whose exposure the onset falls in is lit
for the share of its exposure after it, so the onset is found to a fraction of a frame (a
capture time is taken as the middle of its exposure; the exposure is the frame interval
unless given, as an auto-exposed webcam's is indoors). Its 1-sigma: the brightness noise
over the step, times the exposure; an onset in the gap between two exposures (or a dropped
frame's) is known only to that gap, and says so. The offset's sign and the frames' regular
clocks are :mod:`twopose.pair.clock`'s (:func:`twopose.pair.clock_fit.regular_times`);
the other way to measure it, a moving target's rays, is
:func:`twopose.pair.clock.offset_from_ray_gap`. No I/O.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from twopose.arrays import F64
from twopose.errors import InputValueError
from twopose.pair.clock_fit import ClockOffset, RegularTimes, regular_times

__all__ = ["FLASH_SIGMAS", "LIT_PRIOR_FRAMES", "offset_from_flash"]

#: The span of onsets a flash's frames agree with, in their lit shares' 1-sigmas: 5, so
#: that an onset in a gap between exposures the shares miss by 3 to 5 of their sigmas is
#: still among them (at 3, one such draw in a thousand was taken for an onset inside the
#: next exposure: 59 ms off, with a sigma of 1.2).
FLASH_SIGMAS = 5.0
#: The lit frames' scatter is shrunk toward a flicker's (a share of the level) as if this
#: many frames had shown it: a flash lights a dozen frames or fewer, whose own scatter is
#: a poor estimate; a long one's own wins.
LIT_PRIOR_FRAMES = 4


def _onset(
    brightness: F64, times: RegularTimes, exposure_ns: float | None
) -> tuple[float, float, float]:
    """One camera's flash onset (its clock, ns), its 1-sigma and its fitted clock's part.

    Over the two frames about the step, the lit share of each exposure after an onset ``tau``
    is ``clip((t_k + E/2 - tau) / E, 0, 1)``; their sum ``L(tau)`` falls steadily through
    exposures and stays flat across the gaps between them (and a dropped frame's). The
    onset is where ``L`` meets the frames' measured lit shares' sum: the middle of the
    ``tau`` where they agree within :data:`FLASH_SIGMAS` of its 1-sigma, which is that
    span over twice as many; where ``L`` is flat anywhere in it, the whole span's middle,
    uniform over it (``span / sqrt 12``). Shares no onset fits are refused.
    """
    b = brightness
    span = float(b.max() - b.min())
    if span <= 0:
        raise InputValueError("no flash: the brightness never changes")
    first_lit = int(np.argmax(b > b.min() + 0.5 * span))
    if first_lit < 3:
        raise InputValueError("the flash is in the first frames: start recording before it")
    lit_end = first_lit + int(np.argmax(np.r_[b[first_lit:] < b.min() + 0.5 * span, True]))
    if lit_end < first_lit + 3:
        raise InputValueError("the flash is lit in fewer than three frames: light it longer")
    before, after = b[: first_lit - 2], b[first_lit + 2 : lit_end]
    base, peak = float(np.median(before)), float(np.median(after))
    window = np.arange(first_lit - 1, first_lit + 1)  # the onset is in one of these two
    shares = (b[window] - base) / (peak - base)
    # The shares' sum's 1-sigma: each frame's scatter at its level, the dark frames' and
    # the lit frames' apart and in between by its share. A sensor's noise is the same at
    # both levels, a light's flicker a share of the level (a lit frame's the larger); the
    # few lit frames' own scatter is shrunk toward the flicker's (the dark frames' scaled
    # by the levels) as :data:`LIT_PRIOR_FRAMES` frames would: pooled as one noise, an
    # onset in a gap between exposures was once put 5.7 of its sigmas inside the next
    # exposure, 67 ms off.
    dark = float(np.std(before - base, ddof=1)) if before.size > 1 else 0.0
    flicker = dark * peak / base if base > 0 else dark
    own = float(((after - peak) ** 2).sum())
    lit = float(np.sqrt((own + LIT_PRIOR_FRAMES * flicker**2) / (after.size + LIT_PRIOR_FRAMES)))
    each = dark + (lit - dark) * np.clip(shares, 0.0, 1.0)
    # ... and the levels' own errors, which every share carries (a short flash's lit level
    # rests on a frame or two).
    levels = np.hypot(
        shares.sum() * lit / np.sqrt(max(after.size, 1)),
        (1 - shares).sum() * dark / np.sqrt(max(before.size, 1)),
    )
    s_sum = float(np.sqrt((each**2).sum() + levels**2)) / (peak - base)
    E = times.interval_ns if exposure_ns is None else float(exposure_ns)
    t = times.times_ns[window]
    grid = np.linspace(t[0] - E, t[-1] + E, 4001)
    step = grid[1] - grid[0]
    L = np.clip((t[None, :] + E / 2 - grid[:, None]) / E, 0.0, 1.0).sum(axis=1)
    miss = np.abs(L - shares.sum())
    agree = miss <= FLASH_SIGMAS * max(s_sum, 1e-9)
    if not agree.any():
        raise InputValueError(
            "the flash's frames fit no onset (their brightness is not a step: a light that "
            "flickered, or an exposure that changed with it): fire it again, the cameras' "
            "automatic exposure off"
        )
    # Where L is flat (between two exposures: a gap, or a dropped frame's) every onset in it
    # gives the same shares: known to the span only (uniform), else to its slope.
    flat = agree & (np.abs(np.gradient(L)) < 1e-12)
    s_time = float(times.sigma_ns[window].max())
    lo, hi = grid[agree].min(), grid[agree].max()
    if flat.any():
        sigma = float(np.sqrt((hi - lo + step) ** 2 / 12 + (s_sum * E) ** 2))
    else:
        sigma = max(0.5 * (hi - lo) / FLASH_SIGMAS, step)
    return 0.5 * (lo + hi), float(np.hypot(sigma, s_time)), s_time


def offset_from_flash(
    brightness1: ArrayLike,
    t1_ns: ArrayLike,
    brightness2: ArrayLike,
    t2_ns: ArrayLike,
    *,
    exposure_ns: tuple[float | None, float | None] = (None, None),
) -> ClockOffset:
    """The clock offset from a flash both cameras see (the module docstring).

    Parameters
    ----------
    brightness1, brightness2 : (N1,), (N2,) array_like
        Each frame's mean brightness (any linear unit), camera 1's and camera 2's.
    t1_ns, t2_ns : (N1,), (N2,) array_like
        Their capture times (nanoseconds, each camera's clock).
    exposure_ns : (float or None, float or None)
        Each camera's exposure (None: its frame interval).

    Returns
    -------
    ClockOffset
    """
    onsets = []
    for b, t, e in ((brightness1, t1_ns, exposure_ns[0]), (brightness2, t2_ns, exposure_ns[1])):
        values = np.asarray(b, dtype=np.float64).reshape(-1)
        times = np.asarray(t, dtype=np.float64).reshape(-1)
        if values.shape != times.shape or not np.isfinite(values).all():
            raise InputValueError("each frame needs one finite brightness and one time")
        onsets.append(_onset(values, regular_times(times), e))
    (a, sa, ca), (b2, sb, cb) = onsets
    n = int(np.asarray(t1_ns).size + np.asarray(t2_ns).size)
    return ClockOffset(
        offset_ns=b2 - a, sigma_ns=float(np.hypot(sa, sb)), method="flash", n=n,
        clock_sigma_ns=float(np.hypot(ca, cb)),
    )  # fmt: skip
