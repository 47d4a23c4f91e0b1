"""The next pose as the operator is told it: where, what it would give, and what was left out.

:class:`Suggestion` is what :mod:`twopose.guidance.advice` finds (the map's best): its pose on the
grid paper, its predicted 95% region (with one pose, a range over the depths weighed), the
thesis' move's beside it at the same depths, and how many grid poses in reach were left
out and why (:data:`twopose.guidance.paper.REASONS`), in one line for the terminal and a plan's log
(:meth:`Suggestion.text`) and as JSON for the console (:meth:`Suggestion.to_json`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from twopose.guidance.paper import CLUTTER, EDGE, TAKEN, UNSOLVED
from twopose.values.bounds import shown
from twopose.values.units import Units

__all__ = ["Suggestion"]

#: Why a lattice pose was left out, in the operator's words.
_LEFT_OUT_WORDS = {
    EDGE: "would put the target near the image's edge",
    TAKEN: "already taken",
    CLUTTER: "would show the target over known clutter",
    UNSOLVED: "would leave the trial unsolved",
}


@dataclass(frozen=True, kw_only=True)
class Suggestion:
    """The next pose that shrinks the trial's predicted 95% region most."""

    t_grid: tuple[float, float, float]
    r_deg: tuple[float, float, float]
    predicted95: float  # session units: the region with that pose added
    thesis_t_grid: tuple[float, float, float]
    thesis95: float  # the region with the thesis' default move instead (NaN: out of view)
    provisional: bool  # one pose: the target's place along its ray was assumed
    n_candidates: int  # lattice poses in reach that keep the target in view, not taken
    #: How many lattice poses in reach were left out, and why (:data:`EDGE`, :data:`TAKEN`,
    #: :data:`CLUTTER`, :data:`UNSOLVED`: of those predicted), the reasons with none omitted.
    left_out: tuple[tuple[str, int], ...] = ()
    n_predicted: int = 0  # candidates whose region was predicted (the search's cost)
    #: One pose: the least and the most predicted region over the depths weighed (None:
    #: the target was located).
    predicted95_range: tuple[float, float] | None = None
    #: One pose: the nearest and farthest depth weighed along the first view's ray
    #: (session units; one depth twice when taped).
    depth_range: tuple[float, float] | None = None
    taped: bool = False  # one pose: the depth is the operator's taped distance
    #: One pose, the depth not taped: the thesis' move's least and most predicted region
    #: over the same depths (None: out of view at every depth, or the target located).
    thesis95_range: tuple[float, float] | None = None
    #: One pose: the depth ``predicted95`` and ``thesis95`` assume (session units).
    assumed_depth: float | None = None
    clutter: str = ""  # where the clutter left out is known from ("": none known)

    def region_text(self, units: Units) -> str:
        """The predicted region in words: a range over the depths with one pose."""
        if self.predicted95_range is None or self.depth_range is None:
            return f"predicted 95% within {self.predicted95:.3g} {units}"
        lo, hi = self.predicted95_range
        near, far = self.depth_range
        if self.taped:
            taped = f"for the target taped at {shown(near)} {units}"
            return f"predicted 95% within {self.predicted95:.3g} {units} {taped}"
        return (
            f"predicted 95% within {lo:.3g}-{hi:.3g} {units} for a target "
            f"{shown(round(near, 2))}-{shown(round(far, 2))} {units} away"
        )

    def thesis_text(self, units: Units) -> str:
        """What the thesis' move would give, at the depths the suggestion's figure assumes."""
        moved = ", ".join(shown(v) for v in self.thesis_t_grid)
        if self.provisional and not self.taped:
            if self.thesis95_range is None:
                return f"the thesis' move to {moved} would lose the target at every depth"
            lo, hi = self.thesis95_range
            return f"the thesis' move to {moved} would give {lo:.3g}-{hi:.3g} {units} there"
        if not math.isfinite(self.thesis95):
            return ""
        return f"the thesis' move to {moved} would give {self.thesis95:.3g} {units}"

    def text(self, units: Units) -> str:
        """One line for the operator."""
        x, y, z = self.t_grid
        line = f"next pose: x {shown(x)}, y {shown(y)}, z {shown(z)} {units} "
        line += f"({self.region_text(units)}"
        thesis = self.thesis_text(units)
        line += f"; {thesis})" if thesis else ")"
        if self.provisional:
            line += (
                "; one pose cannot locate the target yet: this move best conditions the "
                "next intersection wherever along the first view's ray the target is"
                if not self.taped
                else "; one pose cannot locate the target yet: this move best conditions "
                "the next intersection for the taped distance"
            )
        said = self.left_out_text()
        if said:
            line += f"; {said}"
        return line

    def left_out_text(self) -> str:
        """Why reachable grid poses were not suggested, in words ("" when none was)."""
        parts = []
        for reason, n in self.left_out:
            words = _LEFT_OUT_WORDS.get(reason, reason)
            if reason == CLUTTER and self.clutter:
                words += f" (seen in {self.clutter})"
            parts.append(f"{n} {words}")
        return "left out of the grid poses in reach: " + ", ".join(parts) if parts else ""

    def to_json(self) -> dict[str, object]:
        """What the browser console shows (its marker and the values the pose form takes)."""
        return {
            "t_grid": list(self.t_grid),
            "r_deg": list(self.r_deg),
            "predicted95": self.predicted95,
            "thesis_t_grid": list(self.thesis_t_grid),
            "thesis95": self.thesis95,
            "thesis95_range": self.thesis95_range and list(self.thesis95_range),
            "provisional": self.provisional,
            "left_out": self.left_out_text(),
            "predicted95_range": self.predicted95_range and list(self.predicted95_range),
            "depth_range": self.depth_range and list(self.depth_range),
            "assumed_depth": self.assumed_depth,
            "taped": self.taped,
        }
