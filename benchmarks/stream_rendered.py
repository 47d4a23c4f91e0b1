"""The stream regions' coverage on the simulator's rendered frames (bench_stream.py, part 5).

Two-camera sessions rendered by ``twopose-record simulate --cameras 2`` (the finger or the
dot moving at 10 in/s through four touches per trial, the clocks 12.5 ms apart), replayed
as ``twopose-analyze run`` replays them (``analysis.session.stream.replay_pair_session``:
the detections, the clock offset measured by the ray gap, one estimate per frame pair) and
each pair's estimate set against the simulator's true trajectory at camera 2's true
capture instant: the dot's centre (point), the fingertip (line: the estimated line's point
nearest it), the finger's axis on the floor (ground). Each pair's 95% region covers the
truth or not (its NEES against the chi-square's 95% quantile); per method, the share of
pairs covered and the mean NEES over its degrees of freedom (1 when the regions are
right), with each camera's detection noise the session estimated from its own frames and,
for comparison, with the 0.25 px and 0.25 degrees assumed before.
"""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import numpy as np

from analysis.session.stream import DEFAULT_NOISE, PairReplay, replay_pair_session
from recorder.simulate.pair import PairTiming, simulate_pair_session
from twopose.format.reader import SessionReader
from twopose.format.streams import read_pair_session
from twopose.methods.specs import Method, spec_of
from twopose.pair.stream import StreamNoise, StreamSettings, estimate_stream
from twopose.uncertainty.propagate import CHI2_95, nees

__all__ = ["RenderedCoverage", "rendered_coverage"]


@dataclasses.dataclass(frozen=True)
class RenderedCoverage:
    """One method's pairs: covered share, count, mean NEES / dof, the noise used in words."""

    covered: float
    pairs: int
    nees_per_dof: float
    noise: str


def _truths(replay: PairReplay, path: Path) -> list[np.ndarray]:
    """Per trial, (P, 3) the truth at each pair's camera-2 frame's true instant."""
    with SessionReader(path) as reader:
        session = read_pair_session(reader)
    out = []
    floor = replay.pair.floor
    for trial, replayed in zip(session.trials, replay.trials, strict=True):
        truth = trial.trajectory
        assert truth is not None
        t = np.array(truth.t_ns)
        instants = np.array(truth.frames[1].true_ns)[replayed.estimate.i2]
        k = np.searchsorted(t, instants)
        p = np.array(truth.points)[k]
        if spec_of(replay.method).needs_ground:  # the finger's axis on the floor
            assert truth.directions is not None
            assert floor is not None
            d = np.array(truth.directions)[k]
            s = (floor.height - p @ floor.normal) / (d @ floor.normal)
            p = p + s[:, None] * d
        out.append(p)
    return out


def _covered(replay: PairReplay, truths: list[np.ndarray], noise: tuple[StreamNoise, ...]):
    """Covered pairs, all pairs and the NEES / dof of each, with ``noise`` per camera."""
    inside, total, per_dof = 0, 0, []
    for replayed, truth in zip(replay.trials, truths, strict=True):
        settings = StreamSettings(noise=(noise[0], noise[1]))
        if spec_of(replay.method).estimates_line:  # the line's point nearest the truth
            settings = dataclasses.replace(settings, line_reference=truth)
        est = estimate_stream(
            replay.method, replay.pair, *replayed.tracks, replayed.offset, settings
        )
        score, dof = nees(est.point - truth, est.cov)
        ok = np.isfinite(score)
        limit = np.array([CHI2_95.get(int(k), np.nan) for k in dof[ok]])
        inside += int((score[ok] <= limit).sum())
        total += int(ok.sum())
        per_dof += list(score[ok] / dof[ok])
    return inside, total, per_dof


def rendered_coverage(
    method: Method, sessions: int, trials: int, seed: int
) -> tuple[RenderedCoverage, RenderedCoverage]:
    """The method's pairs' coverage over ``sessions`` rendered sessions of ``trials`` stream
    trials each: with the noise each session estimated, and with the noise assumed."""
    counts = {"estimated": [0, 0, []], "assumed": [0, 0, []]}
    said: list[str] = []
    timing = PairTiming(speed=10.0, clock_offset_ms=12.5)
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(sessions):
            path = Path(tmp) / f"{method}_{k}.mcap"
            simulate_pair_session(path, method=method, timing=timing, trials=trials,
                                  seed=seed + k)  # fmt: skip
            replay = replay_pair_session(path)
            assert replay.noise is not None
            truths = _truths(replay, path)
            said.append(replay.noise[0].said(lines=spec_of(method).uses_image_lines))
            for name, noise in (
                ("estimated", (replay.noise[0].noise, replay.noise[1].noise)),
                ("assumed", (DEFAULT_NOISE, DEFAULT_NOISE)),
            ):
                inside, total, per_dof = _covered(replay, truths, noise)
                counts[name][0] += inside  # type: ignore[operator]
                counts[name][1] += total  # type: ignore[operator]
                counts[name][2] += per_dof  # type: ignore[operator]
    out = []
    for name in ("estimated", "assumed"):
        inside, total, per_dof = counts[name]
        out.append(
            RenderedCoverage(
                covered=inside / max(total, 1),  # type: ignore[operator]
                pairs=int(total),  # type: ignore[arg-type]
                nees_per_dof=float(np.mean(per_dof)),
                noise=said[0] if name == "estimated" else "assumed 0.25 px, 0.25 deg",
            )
        )
    return out[0], out[1]
