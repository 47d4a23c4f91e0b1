"""A camera's frame times fitted by a regular clock, and a measured clock offset.

:func:`regular_times`: a camera's frames are taken at a fixed rate; its stamps' jitter is
the host's, so a line through the stamps over the frame numbers (dropped frames keep their
place) averages the jitter out instead of letting it enter every frame.
:class:`ClockOffset`: what :mod:`twopose.pair.clock` measures. No I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from twopose.arrays import F64
from twopose.errors import InputValueError

__all__ = ["MAX_JITTER_SHARE", "ClockOffset", "RegularTimes", "regular_times"]

#: The stamps are too irregular to be fitted by one rate beyond this share of an interval
#: (their frame numbers would be ambiguous): they are then used as they are.
MAX_JITTER_SHARE = 1 / 6


@dataclass(frozen=True, kw_only=True)
class ClockOffset:
    """A measured clock offset: camera 2's clock minus camera 1's (nanoseconds).

    ``sigma_ns`` its 1-sigma, ``method`` how it was measured (``"flash"``, ``"ray gap"``),
    ``n`` the frames (flash: both cameras') or pairs (ray gap) it rests on;
    ``clock_sigma_ns`` the part of ``sigma_ns`` that is the fitted clocks' own error
    (:func:`regular_times`), which two measurements from the same stamps share (0:
    unknown, as for an offset read back from a session).
    """

    offset_ns: float
    sigma_ns: float
    method: str
    n: int
    clock_sigma_ns: float = 0.0


@dataclass(frozen=True, kw_only=True, eq=False)
class RegularTimes:
    """A camera's stamps fitted by a regular clock (:func:`regular_times`).

    ``times_ns`` (N,) the fitted capture times, ``frame`` (N,) each stamp's frame number
    from the first (gaps: dropped frames), ``interval_ns`` the fitted interval,
    ``jitter_ns`` the stamps' scatter about the fit, ``sigma_ns`` (N,) each fitted time's
    1-sigma; ``regular`` False when the stamps were too irregular to fit (then
    ``times_ns`` are the stamps and ``sigma_ns`` their scatter).
    """

    times_ns: F64
    frame: F64
    interval_ns: float
    jitter_ns: float
    sigma_ns: F64
    regular: bool


def regular_times(t_ns: ArrayLike, *, interval_ns: float | None = None) -> RegularTimes:
    """A camera's frame times fitted by a fixed rate: ``t = a + b k`` over frame numbers k.

    The frame numbers come from the stamps (rounded by the interval, so dropped frames
    keep their place); with ``interval_ns`` unknown, the stamps' median difference starts
    the fit. Stamps too irregular for that (scatter beyond :data:`MAX_JITTER_SHARE` of an
    interval) are returned as they are (``regular`` False).
    """
    t = np.asarray(t_ns, dtype=np.float64).reshape(-1)
    if t.size < 3 or not np.isfinite(t).all():
        raise InputValueError("a camera's clock needs three finite frame times at least")
    origin = t[0]
    x = t - origin
    b = float(np.median(np.diff(x))) if interval_ns is None else float(interval_ns)
    if not b > 0:
        raise InputValueError("the frame times must increase")
    # Frame numbers from each step (one interval, or more across dropped frames), so that
    # a slightly wrong first interval does not slip them over a long stream; then the
    # line, and the numbers again from it.
    k = np.r_[0.0, np.cumsum(np.maximum(np.round(np.diff(x) / b), 1.0))]
    for _ in range(2):
        A = np.column_stack([np.ones_like(k), k])
        (a, b), *_ = np.linalg.lstsq(A, x, rcond=None)
        k = np.round((x - a) / b)
    residual = x - (a + b * k)
    jitter = float(np.sqrt((residual**2).sum() / max(t.size - 2, 1)))
    if jitter > MAX_JITTER_SHARE * b or len(np.unique(k)) != k.size:
        return RegularTimes(
            times_ns=t, frame=k, interval_ns=b, jitter_ns=jitter,
            sigma_ns=np.full(t.size, jitter), regular=False,
        )  # fmt: skip
    # Each fitted time's 1-sigma: the line's prediction error at its frame number.
    km = k.mean()
    spread = max(float(((k - km) ** 2).sum()), 1e-300)
    sigma = jitter * np.sqrt(1.0 / k.size + (k - km) ** 2 / spread)
    return RegularTimes(
        times_ns=origin + a + b * k, frame=k, interval_ns=float(b), jitter_ns=jitter,
        sigma_ns=sigma, regular=True,
    )  # fmt: skip
