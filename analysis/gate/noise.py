"""``check`` compares the noise model too (issue 56, item 4).

A run's 95% regions assume a noise model: the rig file each session used (its constants'
covariance carried into every region, its ``[placing]`` the placing sigma), or none (each
pose's typed resolution). A run and a baseline that used different rig files (their
contents: ``summary.csv``'s ``rig_sha256``) hold regions that claim different things, so
the metrics of the regions (``coverage95``) are not compared for that session, and the
check says so, naming both models; the errors (RMSE, median, biases, ok trials) are
compared as ever, the rig's correction being part of what is checked. A baseline from
before the column is said too: its noise model cannot be compared. So is the operator's
prior (issue 54): a session whose regions pooled other sessions of its operator in one run
and not, or other ones, in the other (``placing_source``'s "3 other sessions of operator
Ada (point)") claims different regions, said the same way.
"""

from __future__ import annotations

import math

import pandas as pd

from analysis.gate.match import Pair

__all__ = ["NOISE_MODEL_METRICS", "noise_model_difference"]

#: The summary columns a noise model shapes (its regions'): not compared across models.
NOISE_MODEL_METRICS = ("coverage95",)


def noise_model_difference(pair: Pair) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The notes on ``pair``'s noise models, and the columns not to compare (none when the
    run and the baseline used the same)."""
    if pair.baseline is None or pair.result is None:
        return (), ()
    where = f"{pair.session} ({pair.method})"
    if "rig_sha256" not in pair.baseline.index or "rig_sha256" not in pair.result.index:
        return (
            "not compared: the noise models (the baseline predates rig_sha256; replace the "
            "baseline to check that both runs assumed the same)",
        ), ()
    if _text(pair.baseline, "rig_sha256") == _text(pair.result, "rig_sha256"):
        return _prior_difference(pair, where)
    note = (
        f"{where}: the run and the baseline used different noise models (the run: "
        f"{_model(pair.result)}; the baseline: {_model(pair.baseline)}): "
        f"{', '.join(NOISE_MODEL_METRICS)} not compared (their regions assume different "
        "noise); the errors are compared, the rig's correction included"
    )
    return (note,), NOISE_MODEL_METRICS


def _model(row: pd.Series) -> str:
    """A run's noise model for one session, in words."""
    rig = _text(row, "rig_file")
    sigma = pd.to_numeric(pd.Series([row.get("placing_sigma")]), errors="coerce").iloc[0]
    placing = f"placing sigma {sigma:.3g} {_text(row, 'units')}" if math.isfinite(sigma) else ""
    source = _text(row, "placing_source")
    said = f"rig file {rig}" if rig else "no rig file"
    return ", ".join(p for p in (said, placing, source) if p)


def _text(row: pd.Series, column: str) -> str:
    value = row.get(column, "")
    return "" if value is None or (isinstance(value, float) and math.isnan(value)) else str(value)


def _prior_difference(pair: Pair, where: str) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The operator's prior each run's regions took (the other sessions of the operator it
    pooled: ``placing_source``), compared: a different one is said, its coverage left out."""
    if pair.result is None or pair.baseline is None:
        return (), ()
    run, base = (_prior(_text(row, "placing_source")) for row in (pair.result, pair.baseline))
    pooled = [_text(row, "prior_sessions") for row in (pair.result, pair.baseline)]
    if (
        run == base
        and pooled[0] != pooled[1]
        and all("prior_sessions" in row.index for row in (pair.result, pair.baseline))
    ):
        # the same words ("2 other sessions of operator Eve"), other sessions pooled
        run, base = (f"{said} ({_ids(ids)})" for said, ids in zip((run, base), pooled, strict=True))
    if run == base:
        return (), ()
    note = (
        f"{where}: the run and the baseline took different priors for the placing error (the "
        f"operator's other sessions pooled: in the run, {run or 'none'}; in the baseline, "
        f"{base or 'none'}): {', '.join(NOISE_MODEL_METRICS)} not compared (their regions "
        "assume different noise); the errors are compared"
    )
    return (note,), NOISE_MODEL_METRICS


def _ids(pooled: str) -> str:
    """``prior_sessions`` in words: the session ids pooled, each cut to 8 characters."""
    ids = [i[:8] for i in pooled.split(";") if i]
    return "sessions " + ", ".join(ids) if ids else "no session named"


def _prior(source: str) -> str:
    """The operator's prior in ``placing_source``'s words (``""``: none).

    Its sources, ``(estimated from <this session's trials>, <the prior>, <the anchor>)``
    (:func:`twopose.uncertainty.session_noise.placing_source`), less the session's own
    trials and the anchor.
    """
    head = "(estimated from "
    if head not in source or not source.endswith(")"):
        return ""
    parts = source[source.index(head) + len(head) : -1].split(", ")
    own = ("this session's ", "the scatter of ")  # its trials, their scatter about one target
    parts = [p for p in parts if not p.startswith(own)]
    return ", ".join(parts[:-1])
