"""A simulated session's identity: who it names as its operator, and its ids.

A simulated session names an operator (:data:`SIMULATED_OPERATOR` unless ``simulate
--operator`` gives another: an analysis pools the placing error of one operator's
sessions) and carries a ``session_id`` and a ``part_id`` like a recorded one, each a digest
of what made it, so that the same settings write the same session and other settings (an
operator named apart included) another.
"""

from __future__ import annotations

import hashlib
import json

from twopose.errors import InputValueError
from twopose.methods.specs import Method
from twopose.sim.scene import Scene

__all__ = ["SIMULATED_OPERATOR", "checked_operator", "operator_digest", "simulated_ids"]

#: The operator a simulated session names unless ``--operator`` gives another: sessions of
#: one operator pool their placing error in an analysis (docs/uncertainty.md).
SIMULATED_OPERATOR = "twopose simulator"


def checked_operator(operator: str) -> str:
    """``--operator`` as recorded: spaces around it dropped; empty or holding a control
    character (a terminal would obey it) refused."""
    from twopose.values.text import first_control

    name = operator.strip()
    if not name:
        raise InputValueError("--operator needs a name (leave it out: 'twopose simulator')")
    char = first_control(name)
    if char is not None:
        raise InputValueError(f"--operator holds a control character ({char!r}): type a name")
    return name


def operator_digest(operator: str) -> str:
    """What an operator other than :data:`SIMULATED_OPERATOR` adds to the ids' digest
    (nothing for it: sessions simulated before ``--operator`` keep their ids and bytes)."""
    return "" if operator == SIMULATED_OPERATOR else json.dumps(["operator", operator])


def simulated_ids(
    method: Method, trials: int, frames: int, seed: int, scene: Scene,
    operator: str = SIMULATED_OPERATOR,
) -> tuple[str, str]:  # fmt: skip
    """A simulated session's ``session_id`` and ``part_id`` (32 hex digits each): halves
    of one SHA-256 of everything that makes it (``scene`` as simulated: its overrides and
    drawn calibration applied; an ``operator`` named), so the same settings give the same
    ids (and bytes)."""
    made = json.dumps(["twopose simulate", method.value, trials, frames, seed, repr(scene)])
    made += operator_digest(operator)
    digest = hashlib.sha256(made.encode()).hexdigest()
    return digest[:32], digest[32:]
