"""``check`` compares the settings a run's results depend on (issue 54, item 4).

A run's tables depend on more than its sessions and twopose's code: how frames are combined
(``--combine``), when a trial warns (``--min-parallax``, ``--min-plane-angle``,
``--min-ground-angle``; the summary leaves warned trials out unless ``--include-warned``),
whether the noise model is tested and its multiplier estimated (``--sigma0`` /
``--no-sigma0``), a placing sigma given in the options, ``--rig-calibration`` and the
detector's thresholds. ``summary.json`` records them (:func:`settings_of`, its ``settings``)
and ``check`` compares the run's with the baseline's (:func:`settings_difference`): every
setting that differs is said, naming both values. The regions' metric (``coverage95``) is
not compared across different noise settings (their regions assume different noise, as
across rig files: :mod:`analysis.gate.noise`); the errors are compared as ever, and the
verdict says it was reached across different settings. A baseline from before the record
is said too: its settings cannot be compared.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path
from typing import TYPE_CHECKING

from analysis.gate.noise import NOISE_MODEL_METRICS

if TYPE_CHECKING:
    from analysis.results import AnalysisOptions

__all__ = ["NOISE_SETTINGS", "SettingsDifference", "settings_difference", "settings_of"]

#: The settings that shape the regions' noise: across them ``coverage95`` is not compared.
NOISE_SETTINGS = ("sigma0", "placing_sigma")
#: How each setting is said (the command line's option where it has one).
_SAID = {
    "combine": "--combine",
    "min_parallax_deg": "--min-parallax",
    "min_plane_angle_deg": "--min-plane-angle",
    "min_ground_angle_deg": "--min-ground-angle",
    "min_conditioning": "the least conditioning",
    "include_warned": "--include-warned",
    "sigma0": "--sigma0",
    "placing_sigma": "the placing sigma given in the options",
    "rig_calibration": "--rig-calibration",
    "detector": "the detector's thresholds",
}


def settings_of(options: AnalysisOptions) -> dict[str, object]:
    """The settings a run's results depend on, as ``summary.json`` records them.

    The rig file each session used is recorded apart (``rig_files``, ``summary.csv``'s
    ``rig_sha256``); the detector's thresholds as one digest.
    """
    estimate, noise = options.estimate, options.estimate.noise
    placing = noise.placing
    thresholds = [repr(t) for t in (options.glove, options.dot, *options.thresholds)]
    detector = hashlib.sha256(json.dumps(thresholds, sort_keys=True, default=repr).encode())
    return {
        "combine": estimate.combine,
        "min_parallax_deg": estimate.min_parallax_deg,
        "min_plane_angle_deg": estimate.min_plane_angle_deg,
        "min_ground_angle_deg": estimate.min_ground_angle_deg,
        "min_conditioning": estimate.min_conditioning,
        "include_warned": options.include_warned,
        "sigma0": noise.test_redundancy,
        "placing_sigma": None if placing is None else repr(placing),
        "rig_calibration": options.rig_calibration,
        "detector": detector.hexdigest()[:16],
    }


@dataclasses.dataclass(frozen=True, kw_only=True)
class SettingsDifference:
    """What differs between a run's settings and a baseline's: ``notes`` (words), the
    metrics not compared (``apart``) and whether any setting differs (``differ``)."""

    notes: tuple[str, ...] = ()
    apart: tuple[str, ...] = ()
    differ: bool = False


def _recorded(folder: str | Path) -> dict[str, object] | None:
    """The settings ``folder``'s ``summary.json`` records (None: none recorded)."""
    try:
        document = json.loads((Path(folder) / "summary.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    settings = document.get("settings") if isinstance(document, dict) else None
    return settings if isinstance(settings, dict) else None


def settings_difference(results_dir: str | Path, baseline_dir: str | Path) -> SettingsDifference:
    """The run's settings against the baseline's (see the module)."""
    run, base = _recorded(results_dir), _recorded(baseline_dir)
    if run is None or base is None:
        which = "the baseline's" if base is None else "the run's"
        return SettingsDifference(notes=(
            f"not compared: the settings ({which} summary.json records none: it predates the "
            "record, or is missing; replace it to check that both runs used the same --combine, "
            "--sigma0, thresholds and the rest)",
        ))  # fmt: skip
    differ = [k for k in sorted(set(run) | set(base)) if run.get(k) != base.get(k)]
    if not differ:
        return SettingsDifference()
    notes = tuple(
        f"different settings: {_SAID.get(k, k)} is {_value(k, run.get(k))} in the run and "
        f"{_value(k, base.get(k))} in the baseline"
        for k in differ
    )
    noise = [k for k in differ if k in NOISE_SETTINGS]
    if noise:
        notes += (
            f"{', '.join(NOISE_MODEL_METRICS)} not compared: the run and the baseline assumed "
            "different noise (" + ", ".join(_SAID.get(k, k) for k in noise) + "); the errors "
            "are compared, across different settings",
        )
    else:
        notes += ("the errors are compared across different settings: a change may be theirs",)
    return SettingsDifference(notes=notes, apart=NOISE_MODEL_METRICS if noise else (), differ=True)


def _value(key: str, value: object) -> str:
    if key == "sigma0" and isinstance(value, bool):
        return "on (--sigma0)" if value else "off (--no-sigma0)"
    if value is None:
        return "none"
    return str(value)
