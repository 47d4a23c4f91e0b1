"""Many sessions: discovery, execution (in this process, worker processes:
:mod:`analysis.batch.workers`, or on a Dask cluster), gathering in input order (so results never
depend on ``jobs``), and the outputs; the run's first pass over the sessions that share an
operator (:mod:`analysis.batch.noise_pass`) runs on the same executors.

Everything the CLI's ``run`` does is :func:`run`, one call.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import signal
import threading
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any, Literal, TypeVar

import pandas as pd

from analysis.batch.cache import SessionCache
from analysis.batch.inputs import InputSet, SessionIdentity, resolve_inputs
from analysis.batch.noise_pass import NoisePass, first_pass, noise_pass, prior_salt, with_prior
from analysis.batch.outputs import OutputFolder, printable_stem
from analysis.batch.workers import Outcome, run_processes
from analysis.gate.settings import settings_of
from analysis.report.figures.cache import FigureCache, FigureJob
from analysis.report.figures.drawer import FigureDrawer, note
from analysis.results import AnalysisOptions, RunResult, SessionFailure, SessionResult
from analysis.rig.scope import RigScope, run_rig_sources
from analysis.session.detection import Detections
from analysis.session.metrics import summarize
from analysis.session.pipeline import _with_figures, analyse_session
from analysis.tables.columns import (
    AVERAGING_COLUMNS,
    ERROR_COLUMNS,
    FRAME_COLUMNS,
    RIG_TABLE_COLUMNS,
    TRIAL_TABLE_COLUMNS,
    VIEW_COLUMNS,
    typed,
)
from twopose.errors import InputValueError, TwoposeError
from twopose.uncertainty.noise import PlacingPrior

__all__ = ["Outcome", "analyse_or_fail", "results_mcap_name", "run"]

#: What a session's analysis (its second pass, or its only one) gives.
Analysed = SessionResult | SessionFailure
_Done = TypeVar("_Done", SessionResult, NoisePass)

#: Called as each session finishes: its path and whether it succeeded (progress bars).
OnDone = Callable[[str, bool], None]


def run(  # noqa: PLR0913 - keyword-only settings, one per command-line option
    paths: str | Path | Sequence[str | Path] | InputSet,
    out_dir: str | Path | None = None,
    *,
    jobs: int = 1,
    dask_address: str | None = None,
    options: AnalysisOptions | None = None,
    on_session_done: OnDone | None = None,
    on_sessions_found: Callable[[int], None] | None = None,
    scene: bool = True,
    reuse: bool = True,
    rigs: RigScope | Literal["scope"] | None = None,
) -> RunResult:
    """Analyse every session under ``paths`` and (with ``out_dir``) write the results.

    Parameters
    ----------
    paths : path-like, sequence of path-like, or InputSet
        A session file or folder, or several (folders searched recursively for ``*.mcap``
        in any case, through links), or the set a caller already resolved
        (:func:`analysis.batch.inputs.resolve_inputs`).
    out_dir : path-like, optional
        Where to write ``trials.csv``, ``summary.csv``, ``averaging.csv``, ``frames.csv``,
        ``errors.csv``, ``views.csv``, ``sensitivity.csv``, the figures and
        ``report.html``, and (with ``scene``) one ``results_<index>_<session>.mcap`` per
        session for Foxglove (:mod:`analysis.session.results_mcap`). A run that finds no session
        to analyse, or stops before it has analysed one (an error, Ctrl-C), leaves it
        exactly as it was: the previous run's results and cache.
    jobs : int
        Worker processes; results are identical whatever the number.
    options : AnalysisOptions, optional
        Detection, estimation and rig settings (default: the thesis' procedure).
    dask_address : str, optional
        Run the per-session tasks on this existing Dask distributed scheduler instead.
    on_session_done : callable(path, ok), optional
        Called as each session finishes (progress bars).
    on_sessions_found : callable(n), optional
        Called once with the number of sessions found, before the first is analysed.
    scene : bool
        With ``out_dir``: also write each session's results.mcap.
    reuse : bool
        With ``out_dir``: reuse what the previous run into it kept where nothing it depends
        on changed (each session's analysis, :mod:`analysis.batch.cache`; its figures,
        :mod:`analysis.report.figures.cache`); False: everything computed afresh.
    rigs : RigScope or "scope", optional
        Which rig file each session uses (:func:`analysis.rig.scope.rig_scope`; "scope":
        each session's nearest ``rig.toml`` up the tree, as ``twopose-analyze run`` does);
        default none but ``options.rig``, for every session.

    Returns
    -------
    RunResult
        Every session's tables, concatenated, with the failures (``errors``), the notes
        on the inputs, the verdict and the thesis table; ``written_to``: ``out_dir`` when
        the outputs were written there.
    """
    options = options or AnalysisOptions()
    if jobs < 1:
        raise InputValueError(f"jobs must be >= 1, got {jobs}")
    inputs = resolve_inputs(paths)  # once: copies, kinds, empty sessions, units
    if rigs == "scope":
        from analysis.rig.scope import rig_scope

        if options.rig is not None:
            raise InputValueError("a rig in the options and rig files found up the tree: give one")
        rigs = rig_scope(inputs, on_note=note)
    files, skipped = inputs.files, list(inputs.skipped)
    if on_sessions_found is not None:
        on_sessions_found(len(files))
    if not files:  # nothing to analyse: not a run that replaces --out's results
        return dataclasses.replace(
            gather([], include_warned=options.include_warned),
            skipped=tuple(skipped),
            rig_source=options.rig_source,
            input_notes=tuple(inputs.run_notes()),
        )
    folder = OutputFolder.prepare(out_dir) if out_dir is not None else None
    with folder or contextlib.nullcontext():
        batch = _batch_of(
            inputs, folder, options, on_session_done, scene=scene, reuse=reuse, rigs=rigs
        )
        batch = first_pass(
            batch, inputs, lambda b: _execute(b, jobs=jobs, dask_address=dask_address)
        )
        outcomes = [
            o for o in _execute(batch, jobs=jobs, dask_address=dask_address)
            if not isinstance(o, NoisePass)  # never: the second pass analyses each session
        ]  # fmt: skip
        every, used = run_rig_sources(rigs, options, files)
        result = dataclasses.replace(
            gather(outcomes, include_warned=options.include_warned),
            skipped=tuple(skipped),
            rig_source=every,
            rig_files=used,
            input_notes=tuple(inputs.run_notes()),
            inputs_set_aside=inputs.set_aside,
            written_to=None if folder is None else str(folder.destination),
            settings=settings_of(options),
        )
        if folder is not None:
            _write_run(result, folder, batch, outcomes)
    if batch.session_cache is not None:  # committed: what this run did not use goes
        batch.session_cache.prune()
    return result


def _batch_of(
    inputs: InputSet,
    folder: OutputFolder | None,
    options: AnalysisOptions,
    on_done: OnDone | None,
    *,
    scene: bool,
    reuse: bool,
    rigs: RigScope | None = None,
) -> _Batch:
    """The run's sessions with their settings (each one's rig file: ``rigs``), caches and
    results.mcap names."""
    files = inputs.files
    session_cache = SessionCache.of(folder.destination, options, reuse=reuse) if folder else None
    results_mcap: list[str | None] = [None] * len(files)
    if folder is not None and scene:
        labels = inputs.labels
        results_mcap = [
            str(folder.path / results_mcap_name(i, labels.get(f, f))) for i, f in enumerate(files)
        ]
    return _Batch(
        files=files,
        results_mcap=results_mcap,
        options=options,
        images=folder is not None and "png" in options.figures,  # run --figures
        on_done=on_done,
        figure_cache=(
            FigureCache.of(
                folder.destination, folder.previous_outputs(), session_cache.written_digests()
            )
            if folder is not None and session_cache is not None and reuse
            else None
        ),
        session_cache=session_cache,
        continuations=inputs.continuations,
        identities=inputs.identities,
        rigs=rigs,
    )


def _write_run(
    result: RunResult,
    folder: OutputFolder,
    batch: _Batch,
    outcomes: Sequence[SessionResult | SessionFailure],
) -> None:
    """The run's tables, figures and report into the staging folder, listed for the commit
    (reused from the cache where nothing they show changed)."""
    from analysis.report.writer import write_outputs

    # The sweeps are in the thesis' geometry, not the sessions': what the method can do,
    # beside what each trial's own covariance says dominated it.
    cache = batch.session_cache

    def write() -> list[str]:
        sweeps = cache.computed("sweeps", _thesis_sweeps) if cache else _thesis_sweeps()
        return write_outputs(
            result,
            folder.path,
            sweeps.copy(),
            figure_cache=batch.figure_cache,
            figures=batch.options.figures,
        )

    notes = [*result.input_notes, *result.skipped]  # with the sessions: the outputs
    written = cache.outputs(outcomes, notes, folder.path, write) if cache else write()
    folder.record(written + [Path(r).name for r in batch.results_mcap if r is not None])


@functools.lru_cache(maxsize=1)
def _thesis_sweeps() -> pd.DataFrame:
    """The report's sensitivity sweeps (seeded, so the same every time: computed once)."""
    from analysis.tools.sensitivity import sensitivity

    return sensitivity()


@dataclasses.dataclass(frozen=True, kw_only=True)
class _Batch:
    """The sessions of one run and what each one's analysis needs, wherever it runs."""

    files: list[str]
    results_mcap: list[str | None]  # each session's results.mcap path (None: not written)
    options: AnalysisOptions
    images: bool  # whether the session figures are drawn (only when an --out is written)
    on_done: OnDone | None
    # The figures the previous run into --out drew: reused where nothing they show changed.
    figure_cache: FigureCache | None = None
    #: per session's first part, its continuations (InputSet.continuations): one session
    continuations: dict[str, tuple[str, ...]] = dataclasses.field(default_factory=dict)
    #: per session's first part, what it is (InputSet.identities): its id, label, parts
    identities: dict[str, SessionIdentity] = dataclasses.field(default_factory=dict)
    #: each session's analysis as the previous run into --out kept it (None: no --out)
    session_cache: SessionCache | None = None
    #: which rig file each session uses (analysis.rig.scope; None: ``options.rig``, all)
    rigs: RigScope | None = None
    #: "noise": the run's first pass (analysis.batch.noise_pass); "analysis": the sessions' own
    stage: str = "analysis"
    #: per session's first part, its prior from its operator's other sessions of the run
    priors: dict[str, PlacingPrior] = dataclasses.field(default_factory=dict)
    #: per session's first part, what its first pass detected (not detected again)
    detections: dict[str, list[list[Detections]]] = dataclasses.field(default_factory=dict)
    #: per session's first part, the failure of its first pass (the session's outcome)
    failed: dict[str, SessionFailure] = dataclasses.field(default_factory=dict)

    def options_for(self, path: str) -> AnalysisOptions:
        """The options session ``path`` is analysed with: the run's, with its rig."""
        return self.options if self.rigs is None else self.rigs.options_for(path, self.options)

    def analyse(self, index: int, results: str | None = None, *, images: bool) -> Outcome:
        """Session ``index``'s outcome (:func:`analyse_or_fail`), wherever it runs."""
        path, cache = self.files[index], self.session_cache
        continuations, identity = self.continuations.get(path, ()), self.identities.get(path)
        options = self.options_for(path)
        if cache is not None and options is not self.options:  # keyed on its own rig too
            cache = cache.with_options(options)
        if self.stage == "noise":
            first = functools.partial(_noise_or_fail, path, options, continuations)
            return first() if cache is None else cache.noise(path, continuations, identity, first)
        if path in self.failed:
            return self.failed[path]
        prior = self.priors.get(path)
        analysed = functools.partial(
            analyse_or_fail, path, with_prior(options, prior), images=images,
            results=results, figure_cache=self.figure_cache, continuations=continuations,
            identity=identity, detections=self.detections.get(path),
        )  # fmt: skip
        outcome = (
            analysed()
            if cache is None
            else cache.outcome(path, continuations, identity, results, analysed, prior_salt(prior))
        )
        if images and isinstance(outcome, SessionResult) and outcome.analysis_reused:
            outcome = _with_figures(outcome, self.options, self.figure_cache)
        return (
            dataclasses.replace(outcome, index=index)
            if isinstance(outcome, SessionResult)
            else outcome
        )

    def for_workers(self) -> _Batch:
        """The same batch without its progress callback (it stays in this process)."""
        return dataclasses.replace(self, on_done=None)

    def for_session(self, index: int) -> _Batch:
        """What a worker needs for session ``index``: the batch with its detections alone
        (not every session's, sent with each task)."""
        if not self.detections:
            return self
        mine = self.detections.get(self.files[index])
        return dataclasses.replace(
            self, detections={} if mine is None else {self.files[index]: mine}
        )

    def without_images(self) -> _Batch:
        """The same batch, its figures drawn elsewhere (by a :class:`FigureDrawer`)."""
        return dataclasses.replace(self, images=False)


def _execute(batch: _Batch, *, jobs: int, dask_address: str | None) -> list[Outcome]:
    """Every session's outcome, in input order, wherever it ran."""
    n = len(batch.files)
    if dask_address is not None:
        return _run_dask(batch, dask_address)
    if jobs > 1 and n > 1:  # each process draws its own sessions' figures
        return run_processes(batch, min(jobs, n))
    if not batch.images or n <= 1:
        return _run_here(batch, None)
    with FigureDrawer.started() as drawer:
        return _run_here(batch if drawer is None else batch.without_images(), drawer)


def _run_here(batch: _Batch, drawer: FigureDrawer | None) -> list[Outcome]:
    """The sessions one after the other in this process; with a ``drawer``, each one's
    figures are drawn in its process while this one analyses the next."""
    files, options, on_done, cache = batch.files, batch.options, batch.on_done, batch.figure_cache
    outcomes: list[Outcome] = []
    for i, (f, r) in enumerate(zip(files, batch.results_mcap, strict=True)):
        outcome = batch.analyse(i, r, images=batch.images)
        if drawer is not None and isinstance(outcome, SessionResult):
            job = FigureJob.of(outcome, include_warned=options.include_warned)
            reused = cache.reuse(job) if cache is not None else None
            if reused is None:
                drawer.submit(i, job)
            else:
                outcome = dataclasses.replace(outcome, images=reused, figures_reused=True)
        outcomes.append(outcome)
        _report(on_done, f, outcome)
    if drawer is None:
        return outcomes
    for i, (figures, why_not) in sorted(drawer.collect().items()):
        done = outcomes[i]
        assert isinstance(done, SessionResult)
        if why_not:
            note(f"the figures of {done.session} were not drawn ({why_not}); the report says so")
        outcomes[i] = dataclasses.replace(done, images=figures)
    return outcomes


def _report(on_done: OnDone | None, path: str, outcome: Outcome) -> None:
    """Tell ``on_done`` (if any) that session ``path`` finished, and whether it succeeded."""
    if on_done is not None:
        on_done(path, isinstance(outcome, SessionResult))


def gather(outcomes: Sequence[Analysed], *, include_warned: bool = False) -> RunResult:
    """The run's tables: every session's rows concatenated in input order; the summary
    leaves warned trials out unless ``include_warned``
    (:func:`analysis.session.metrics.summarize`)."""
    results = tuple(o for o in outcomes if isinstance(o, SessionResult))
    errors = typed(
        pd.DataFrame(
            [
                {"session": o.session, "error": o.reason}
                for o in outcomes
                if isinstance(o, SessionFailure)
            ],
            columns=ERROR_COLUMNS,
        )
    )
    trials = _concat([r.trials for r in results], TRIAL_TABLE_COLUMNS)
    return RunResult(
        trials=trials,
        summary=summarize(trials, include_warned=include_warned),
        averaging=_concat([r.averaging for r in results], AVERAGING_COLUMNS),
        frames=_concat([r.frames for r in results], FRAME_COLUMNS),
        errors=errors,
        sessions=results,
        views=_concat([r.views for r in results], VIEW_COLUMNS),
        include_warned=include_warned,
        rig=_concat([r.rig for r in results], RIG_TABLE_COLUMNS),
    )


def _concat(frames: list[pd.DataFrame], columns: list[str]) -> pd.DataFrame:
    """The sessions' tables as one, each column its declared dtype (:func:`typed`)."""
    present = [f for f in frames if not f.empty]
    if not present:
        return typed(pd.DataFrame(columns=columns))
    return typed(pd.concat(present, ignore_index=True), columns)


def results_mcap_name(index: int, session: str | Path) -> str:
    """File name of a session's results.mcap in a run's output folder: the session's stem,
    made printable and cut to 100 characters (file names are limited to 255 bytes)."""
    return f"results_{index:02d}_{printable_stem(session)}.mcap"


def analyse_or_fail(
    path: str,
    options: AnalysisOptions,
    *,
    images: bool,
    results: str | None = None,
    figure_cache: FigureCache | None = None,
    continuations: Sequence[str] = (),
    identity: SessionIdentity | None = None,
    detections: list[list[Detections]] | None = None,
) -> Analysed:
    """One session's result, or a :class:`SessionFailure` saying why (never raises but for
    Ctrl-C); a session over ``options.session_timeout_s`` is stopped and fails."""
    analyse = functools.partial(
        analyse_session, path, options, render_images=images, results_path=results,
        figure_cache=figure_cache, continuations=continuations, identity=identity,
        detections=detections,
    )  # fmt: skip
    return _or_fail(path, options, analyse)


def _noise_or_fail(
    path: str, options: AnalysisOptions, continuations: Sequence[str]
) -> NoisePass | SessionFailure:
    """A session's first pass, or why it failed (:func:`analyse_or_fail`'s rules)."""
    return _or_fail(path, options, lambda: noise_pass(path, options, continuations))


def _or_fail(
    path: str, options: AnalysisOptions, work: Callable[[], _Done]
) -> _Done | SessionFailure:
    """``work()``'s result, or a :class:`SessionFailure` saying why it failed or ran out
    of ``options.session_timeout_s``."""
    try:
        with _time_limit(options.session_timeout_s):
            return work()
    except _SessionTimeoutError:
        return SessionFailure(
            session=path,
            reason=f"{path}: stopped after {options.session_timeout_s:g} s (--session-timeout); "
            "the session is too large or pathological for one analysis",
        )
    except TwoposeError as err:  # the message names the file, once
        return SessionFailure(
            session=path, reason=str(err) if path in str(err) else f"{path}: {err}"
        )
    except Exception as err:  # one bad file never stops the batch; the reason is kept
        return SessionFailure(
            session=path, reason=f"{path}: unexpected {type(err).__name__}: {err}"
        )


class _SessionTimeoutError(BaseException):
    """A session ran past its time limit (a BaseException, like KeyboardInterrupt, so that
    no ``except Exception`` on the way turns it into another error)."""


@contextlib.contextmanager
def _time_limit(seconds: float | None) -> Iterator[None]:
    """Raise :class:`_SessionTimeoutError` after ``seconds`` (SIGALRM: the main thread of a
    process, as in this process and the pool's workers; elsewhere, e.g. a Dask worker
    thread, no limit applies)."""
    if seconds is None or threading.current_thread() is not threading.main_thread():
        yield
        return

    def expired(_signum: int, _frame: Any) -> None:
        raise _SessionTimeoutError

    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


# --------------------------------------------------------------------------- Dask


def _analyse_at(index: int, results: str | None, batch: _Batch) -> Outcome:
    """:meth:`_Batch.analyse` with the per-session arguments, for ``client.map``."""
    return batch.analyse(index, results, images=batch.images)


def _run_dask(batch: _Batch, address: str) -> list[Outcome]:
    """The sessions on a Dask cluster (``--dask ADDRESS``), in input order."""
    files, results, on_done = batch.files, batch.results_mcap, batch.on_done
    try:
        from distributed import Client
    except ImportError as err:
        raise InputValueError(
            "--dask needs the optional Dask extra: pip install 'twopose[dask]'"
        ) from err
    try:
        client = Client(address, timeout=10)
    except ValueError as err:
        raise InputValueError(f"--dask {address!r} is not a scheduler address: {err}") from err
    except OSError as err:
        raise InputValueError(f"cannot reach the Dask scheduler at {address}: {err}") from err
    from distributed import as_completed

    try:
        # A worker that dies mid-session (killed, out of memory) loses its task to the
        # scheduler, which runs it again on another worker (``allowed-failures``, 3).
        task = batch.for_workers()  # what a worker needs
        tasks = [task.for_session(i) for i in range(len(files))]
        futures = client.map(_analyse_at, range(len(files)), results, tasks, pure=False)
        index = {fut.key: i for i, fut in enumerate(futures)}
        outcomes: list[Outcome | None] = [None] * len(files)
        for fut in as_completed(futures):  # progress as sessions finish, in any order
            i = index[fut.key]
            outcome: Outcome = fut.result()
            outcomes[i] = outcome
            _report(on_done, files[i], outcome)
        return [o for o in outcomes if o is not None]
    finally:
        client.close()
