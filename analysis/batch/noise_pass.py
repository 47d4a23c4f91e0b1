"""A run's first pass: each session's placing statistics, then every session's prior from
its operator's other sessions (issue 54).

A session's regions depend on its operator's other sessions in the run (the placing
variance's multiplier is shrunk toward theirs:
:func:`twopose.uncertainty.operator_pool.operator_priors`).
So a run whose sessions share an operator (the session entry's ``operator``, the same
method: one setup) analyses them in two passes:

1. :func:`noise_pass`: each such session replayed and detected once, its trials'
   misclosures (:class:`twopose.uncertainty.operator_pool.SessionNoise`, a few numbers per
   trial),
   kept by the session cache under the session's own key, and its detections handed on;
2. the run's priors (:func:`operator_priors_of`, cheap: every trial's likelihood on one
   grid), then each session analysed with its prior in its options (the detections of the
   first pass reused: nothing is detected twice). The prior is part of the session's
   cache key (its digest, :func:`prior_salt`), so a kept analysis is reused exactly when
   its prior is the same: a re-run equals a ``--no-reuse`` run byte for byte.

A session with no operator named, or the only one of its operator and method, is analysed
in one pass, as before, its prior the anchor alone (the typed resolution, or the rig
file's ``[placing]``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from analysis.results import AnalysisOptions
from analysis.session.detection import Detections
from analysis.session.pipeline import corrected_trials, replay_views
from twopose.solve.session import estimate_session
from twopose.uncertainty.noise import PlacingPrior
from twopose.uncertainty.operator_pool import SessionNoise, operator_priors
from twopose.uncertainty.session_noise import (
    operator_group,
    session_base_in,
    session_statistics,
)
from twopose.values.operators import operator_key

if TYPE_CHECKING:
    from analysis.batch.inputs import InputSet

__all__ = [
    "NoisePass",
    "by_rig_file",
    "first_pass",
    "noise_pass",
    "operator_heads",
    "operator_priors_of",
    "pooled_groups",
    "prior_salt",
    "statistics_from_json",
    "statistics_json",
    "with_prior",
]


@dataclass(frozen=True, kw_only=True)
class NoisePass:
    """One session's first pass: its statistics, and (when it was detected here, not
    read from the cache) every part's detections for the second."""

    session: str
    statistics: SessionNoise
    detections: list[list[Detections]] | None = None


def pooled_groups(heads: Mapping[str, tuple[str, str]], options: AnalysisOptions) -> dict[str, str]:
    """The sessions analysed in two passes, by their first part's path: their group, for
    those whose operator and method (``heads``: path -> (operator, method)) another
    session of the run shares; none when the options test no redundancy or fix a factor."""
    noise = options.estimate.noise
    if not noise.test_redundancy or noise.factor is not None:
        return {}
    from twopose.methods.specs import Method

    shown: dict[str, str] = {}  # one operator's name as first typed ("ada" is "Ada")
    for op, _ in heads.values():
        shown.setdefault(operator_key(op), op.strip())
    groups = {
        p: operator_group(shown[operator_key(op)], Method(m)) for p, (op, m) in heads.items() if m
    }
    count: dict[str, int] = {}
    for g in groups.values():
        count[g] = count.get(g, 0) + 1
    return {p: g for p, g in groups.items() if g and count[g] > 1}


_Batch = TypeVar("_Batch")


def operator_heads(inputs: InputSet, files: Sequence[str]) -> dict[str, tuple[str, str]]:
    """The sessions among ``files`` (first parts' paths) that may pool with their
    operator's others: their operator and method.

    Not a two-camera session (no typed pose), nor one whose parts two operators recorded
    (one multiplier for two hands: :attr:`analysis.batch.inputs.InputSet.of_operators`,
    said).
    """
    mixed = inputs.of_operators
    return {
        f.path: (f.info.operator, str(f.info.method))
        for f in inputs.found
        if f.path in files and f.info is not None and not f.pair and f.path not in mixed
    }


def first_pass(
    batch: _Batch, inputs: InputSet, execute: Callable[[_Batch], Sequence[object]]
) -> _Batch:
    """The batch (:class:`analysis.batch.runner._Batch`) with each session's prior from its
    operator's other sessions and the detections its first pass found; unchanged when no
    two sessions share an operator and a method. ``execute`` runs a batch wherever the run
    runs its sessions (this process, worker processes, a Dask cluster)."""
    from analysis.results import SessionFailure

    b: Any = batch
    heads = operator_heads(inputs, b.files)
    options_for: Callable[[str], AnalysisOptions] = b.options_for
    groups = by_rig_file(pooled_groups(heads, b.options), options_for)
    if not groups:
        return batch
    files = [f for f in b.files if f in groups]
    first = dataclasses.replace(
        b, files=files, results_mcap=[None] * len(files), images=False, on_done=None,
        stage="noise",
    )  # fmt: skip
    passes = execute(first)
    done = {o.session: o for o in passes if isinstance(o, NoisePass)}
    ids = {f.path: f.session_id for f in inputs.found}
    statistics = {
        f: dataclasses.replace(p.statistics, name=ids.get(f, "")) for f, p in done.items()
    }
    priors = operator_priors_of(statistics, groups, b.options, options_for)
    return dataclasses.replace(  # type: ignore[no-any-return]
        b,
        priors=priors,
        detections={f: p.detections for f, p in done.items() if p.detections is not None},
        failed={o.session: o for o in passes if isinstance(o, SessionFailure)},
    )


def noise_pass(path: str, options: AnalysisOptions, continuations: Sequence[str] = ()) -> NoisePass:
    """The session's trials replayed and detected, corrected by the rig, their misclosures
    (the group is the caller's to set: :func:`operator_priors_of`)."""
    keep: list[list[Detections]] = []
    trials = corrected_trials(replay_views(path, options, continuations, keep=keep), options.rig)
    estimate = estimate_session(trials, options.estimate, line_fits=False)
    return NoisePass(
        session=path,
        statistics=session_statistics(
            "", estimate.misclosure, estimate.tests, session_base_in(trials, options.estimate)
        ),
        detections=keep,
    )


def operator_priors_of(
    passes: Mapping[str, SessionNoise],
    groups: Mapping[str, str],
    options: AnalysisOptions,
    options_for: Callable[[str], AnalysisOptions] | None = None,
) -> dict[str, PlacingPrior]:
    """Every pooled session's prior from the other sessions of its group (in the run's
    order; a session with none to pool left out). ``options_for``: each session's own
    options (its rig file's ``[placing]`` is its anchor); default ``options`` for all."""
    paths = [p for p in groups if p in passes]
    anchors = {
        p: (options_for(p) if options_for else options).estimate.noise.anchor() for p in paths
    }
    out: dict[str, PlacingPrior] = {}
    for anchor in dict.fromkeys(anchors.values()):  # one rig's sessions share their anchor
        mine = [p for p in paths if anchors[p] == anchor]
        stats = [dataclasses.replace(passes[p], group=groups[p]) for p in mine]
        priors = operator_priors(stats, anchor)
        out |= {p: prior for p, prior in zip(mine, priors, strict=True) if prior is not None}
    return {p: out[p] for p in paths if p in out}


def by_rig_file(
    groups: Mapping[str, str], options_for: Callable[[str], AnalysisOptions]
) -> dict[str, str]:
    """``groups`` (:func:`pooled_groups`) split where their sessions use different rig files
    (:mod:`analysis.rig.scope`): a rig is part of the setup, and its ``[placing]`` the
    sigma the regions start from, so an operator's sessions under two rigs pool apart (the
    group then names its rig file); a group left with one session is not pooled."""
    rig = {p: _rig_said(options_for(p)) for p in groups}
    rigs: dict[str, set[str]] = {}
    for p, g in groups.items():
        rigs.setdefault(g, set()).add(rig[p])
    split = {p: g if len(rigs[g]) == 1 else f"{g} under {rig[p]}" for p, g in groups.items()}
    count: dict[str, int] = {}
    for g in split.values():
        count[g] = count.get(g, 0) + 1
    return {p: g for p, g in split.items() if count[g] > 1}


def _rig_said(options: AnalysisOptions) -> str:
    """A session's rig file in a group's words (its path; none: "no rig file")."""
    source = options.rig_source
    if source is not None:
        return f"rig file {source.path}"
    return "no rig file" if options.rig is None else "the constants given"


def with_prior(options: AnalysisOptions, prior: PlacingPrior | None) -> AnalysisOptions:
    """``options`` with the session's prior from its operator (unchanged without one)."""
    if prior is None:
        return options
    noise = dataclasses.replace(options.estimate.noise, prior=prior)
    return dataclasses.replace(options, estimate=dataclasses.replace(options.estimate, noise=noise))


def prior_salt(prior: PlacingPrior | None) -> str:
    """What the session's cache key adds for its prior (``""``: none): its digest."""
    if prior is None:
        return ""
    text = json.dumps(
        [repr(prior.scale), repr(prior.dof), prior.source, prior.sessions, repr(prior.anchor_p)]
    )
    return hashlib.sha256(text.encode()).hexdigest()


def statistics_json(stats: SessionNoise) -> dict[str, object]:
    """The statistics as plain values (what the session cache keeps)."""
    return {
        "chi2": np.asarray(stats.chi2, dtype=np.float64),
        "dof": np.asarray(stats.dof, dtype=np.int64),
        "share": np.asarray(stats.share, dtype=np.float64),
        "z2": np.asarray(stats.z2, dtype=np.float64),
        "placing_in": float(stats.placing_in),
    }


def statistics_from_json(values: Mapping[str, object]) -> SessionNoise:
    """The statistics :func:`statistics_json` kept (refused, as KeyError or TypeError,
    when they are not its arrays)."""
    arrays = {k: values[k] for k in ("chi2", "dof", "share", "z2")}
    base = values["placing_in"]  # an entry kept before the base was: computed again
    if not all(isinstance(v, np.ndarray) for v in arrays.values()) or not isinstance(base, float):
        raise TypeError("not a session's noise statistics")
    return SessionNoise(group="", placing_in=base, **arrays)  # type: ignore[arg-type]
