"""What figures cost a run at every batch size, a re-run's cost, and a frame's marginal cost.

    .venv/bin/python benchmarks/bench_run.py [--quick] [--workdir DIR] [--repeat 2]
        [--only share|frames]

Targets (issues 22, 34 and 47), every run ``twopose-analyze run --jobs 1`` in a fresh process
(the command line itself, so what it does by default is what is measured), of the committed
code (HEAD's ``analysis/`` and ``twopose/``, copied into ``--workdir`` at the start, so that
edits in the working tree during the run change nothing measured):

1. figures cost at most 15% of a run's CPU at every batch size: 60 sessions of 18 frames
   (``--no-scene``, as a lab's day-to-day sessions were tried in issue 47), 100 distinct
   sessions of 171 frames on average (the bundled ``sessions/*.mcap`` in turn, each copy made
   a different file so that the batch counts 100) and one session of 10,000 frames. CPU is
   the run's and every process it starts (their rusage, user + system): the run as shipped
   (its report's charts included) against the same run with figures that cost nothing
   (every chart and figure patched out), in the same interleaved rounds. A run with
   ``--figures png`` (static images, drawn only when asked) is measured beside them, once
   and on the batches (one session's three figures are a batch's few), as the cost of that
   choice; it has no target;
2. a re-run into the same folder with nothing changed costs at most 20% of the first run's
   CPU (the run's analysis and figures reused), at every size (measured once, right after
   the first round's run, against the best first run);
3. the marginal cost of a frame in ``run`` (defaults: tables, charts, report, results MCAP)
   between a 2,000-frame (100 trials) and the 10,000-frame (500 trials) session, made of the
   same real frames so that start-up and per-session costs cancel, is at most 2x that of a
   bare single-threaded decode loop over the same files (``cv2.imdecode`` of every frame
   the session reader yields): wall-clock time, as the analyst waits. CPU time (every
   thread of the process) is printed beside it, so that a ratio helped by a spare core
   shows what it costs.

Every other figure is the best of ``--repeat`` (2) runs, interleaved, because timings on
this shared 2-core machine swing by 10% or more. The full run takes about 12 CPU-minutes,
some 10 minutes here when the machine is otherwise idle and twice that when it is busy
(sessions made once per ``--workdir``: a minute more); ``--quick`` (6 sessions of 18
frames, 7 of 171, one of 1,200 frames; the marginal cost between 400 and 1,200 frames; one
round) takes 1.5 CPU-minutes, for development, and its figures are not the targets'.
Exits 1 if a target is missed.
"""

from __future__ import annotations

import argparse
import dataclasses
import io
import os
import resource
import shutil
import subprocess
import sys
import tarfile
import tempfile
from collections.abc import Callable
from pathlib import Path

from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from twopose.methods.specs import MEASURING_METHODS, Method

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(1, str(Path(__file__).resolve().parents[1]))  # tests.helpers

from bench_analysis import count_frames, replicate  # type: ignore[import-not-found]  # on sys.path at run time

from recorder.simulate.one_camera import simulate_session
from tests.helpers import distinct_copies

REPO = Path(__file__).resolve().parents[1]

#: The targets: figures' share of a run's CPU, a re-run's CPU over the first run's, and a
#: frame's marginal wall time in ``run`` over a bare decode's.
SHARE_TARGET, RERUN_TARGET, FRAME_TARGET = 0.15, 0.20, 2.0

DECODE_LOOP = """
import sys, time, cv2, numpy as np
cv2.setNumThreads(1)  # single-threaded, as the measure says
from twopose.format.messages import Frame
from twopose.format.reader import SessionReader
t, c = time.perf_counter(), time.process_time()
with SessionReader(sys.argv[1]) as r:
    for e in r.iter_entries():
        if isinstance(e, Frame):
            cv2.imdecode(np.frombuffer(e.data, np.uint8), cv2.IMREAD_COLOR)
print("BENCH", time.perf_counter() - t, time.process_time() - c)
"""

# ``twopose-analyze run ARGS`` in this process. Mode "free": every figure and chart costs
# nothing (each function below, where this version of the code has it, returns an empty
# value; a name missing is skipped, and the run fails if none was found, so that a renamed
# function can never make figures look free). Prints the run's wall and process CPU time
# (every thread), the sessions analysed, and how many sessions' analysis and figures a
# previous run into the folder gave.
RUN = """
import contextlib, importlib, io, sys, time
mode, *argv = sys.argv[1:]
import analysis.batch.runner as batch
kept = []
real_run = batch.run
def run(*args, **kwargs):
    kept.append(real_run(*args, **kwargs))
    return kept[-1]
batch.run = run
if mode == "free":
    from PIL import Image
    buf = io.BytesIO(); Image.new("RGB", (1, 1)).save(buf, "PNG"); PNG = buf.getvalue()
    values = {"dict": {}, "list": [], "none": None, "str": "", "png": PNG, "pngs": ({}, "", False)}
    empty = {kind: (lambda v: lambda *a, **k: v)(value) for kind, value in values.items()}
    empty["nocontext"] = lambda *a, **k: contextlib.nullcontext()
    found = 0
    for home, name, kind in FREE:
        try:
            module = importlib.import_module(home)
        except ImportError:
            continue
        owner, _, attr = name.rpartition(".")
        target = getattr(module, owner) if owner else module
        real = getattr(target, attr, None)
        if real is None:
            continue
        fake = empty[kind]
        setattr(target, attr, staticmethod(fake) if owner else fake)
        for other in list(sys.modules.values()):  # where it was imported by name
            named = getattr(other, "__name__", "")
            if named.startswith("analysis") and getattr(other, attr, None) is real:
                setattr(other, attr, fake)
        found += 1
    assert found, "no figure function found to patch: update bench_run.FREE"
from analysis.cli import main
sys.argv = ["twopose-analyze", "run", *argv]
t, c = time.perf_counter(), time.process_time()
with contextlib.redirect_stdout(io.StringIO()):
    try:
        main()
    except SystemExit as end:
        assert not end.code, end.code
wall, cpu = time.perf_counter() - t, time.process_time() - c
result = kept[-1]
assert not result.failed, result.errors
reused = sum(bool(getattr(s, "analysis_reused", False)) for s in result.sessions)
print("BENCH", wall, cpu, len(result.sessions), reused, result.figures_reused)
"""

#: What "figures that cost nothing" patches (module, function, what it returns instead):
#: the report's browser charts and the matplotlib figures, in every version of the code
#: this benchmark has measured.
FREE: tuple[tuple[str, str, str], ...] = (
    ("analysis.batch.runner", "FigureDrawer.started", "nocontext"),  # the drawing process
    ("analysis.report.figures.drawer", "FigureDrawer.started", "nocontext"),
    ("analysis.report.figures.drawer", "session_pngs", "pngs"),
    ("analysis.report.writer", "run_figures", "dict"),
    ("analysis.report.figures.draw", "run_figures", "dict"),
    ("analysis.report.figures.draw", "png_bytes", "png"),
    ("analysis.tools.sensitivity", "plot_sensitivity", "none"),
    ("analysis.report.charts", "session_chart", "none"),  # the report's charts (issue 47)
    ("analysis.report.run_charts", "overview_charts", "none"),
    ("analysis.report.run_charts", "sensitivity_chart", "none"),
    ("analysis.report.html", "chart_html", "str"),
    ("analysis.report.html", "chart_scripts", "list"),
)

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "run.txt"


@dataclasses.dataclass(frozen=True)
class Size:
    """One batch size: its name, how its folder is made, and its extra ``run`` options."""

    name: str
    make: Callable[[Path], Path]  # work folder -> the sessions' folder (or file)
    options: tuple[str, ...] = ()
    figures: bool = True  # also measure run --figures png (once: the opt-in's cost)


@dataclasses.dataclass
class Timing:
    """The best of a mode's runs: CPU of the run and its children, wall, the process's CPU."""

    cpu: float = float("inf")
    wall: float = float("inf")
    process_cpu: float = float("inf")
    sessions: int = 0
    reused: int = 0  # sessions whose analysis a previous run gave

    def keep(self, cpu: float, printed: list[float]) -> None:
        wall, process_cpu, sessions, reused, _ = printed
        self.cpu, self.wall = min(self.cpu, cpu), min(self.wall, wall)
        self.process_cpu = min(self.process_cpu, process_cpu)
        self.sessions, self.reused = int(sessions), int(reused)


#: Where the measured code is imported from (:func:`_snapshot`; the working tree until then).
CODE = [REPO]
# Every run as an analyst's installed copy runs: its bytecode cached (a shell that sets
# PYTHONDONTWRITEBYTECODE would make each run compile every module, some 1.5 CPU-seconds).
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def _snapshot(work: Path) -> Path:
    """The committed code (HEAD's ``analysis/`` and ``twopose/``), copied once per commit
    into ``work``: every run of the benchmark measures one version whatever others change in
    the working tree meanwhile (a re-run's cache keys on the code's digest, so an edit
    between a first run and its re-run would void the re-run). The working tree when it is
    not a git clone."""
    try:
        head = subprocess.run(
            ["git", "-C", str(REPO), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        code = work / f"code_{head[:12]}"
        done = code / ".extracted"  # written last: a copy cut short is extracted again
        if not done.is_file():
            archive = subprocess.run(
                ["git", "-C", str(REPO), "archive", "HEAD", "analysis", "twopose"],
                capture_output=True,
                check=True,
            ).stdout
            shutil.rmtree(code, ignore_errors=True)
            with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
                tar.extractall(code, filter="data")
            done.write_text(head)
        return code
    except (OSError, subprocess.CalledProcessError):
        return REPO


def _python(code: str, *args: str) -> tuple[list[float], float]:
    """What ``code`` printed on its ``BENCH`` line, and the CPU seconds (user + system) it
    and every child it waited for took; it imports the measured code (:data:`CODE`)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run(
        [sys.executable, "-c", code, *args], capture_output=True, text=True, cwd=CODE[0], env=ENV
    )
    if out.returncode:
        raise SystemExit(f"benchmark run failed ({' '.join(args)}):\n{out.stderr[-3000:]}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    line = [ln for ln in out.stdout.splitlines() if ln.startswith("BENCH ")][-1]
    return [float(x) for x in line.split()[1:]], cpu


def _run(mode: str, out: Path, size: Size, path: Path) -> tuple[list[float], float]:
    extra = ("--figures", "png") if mode == "figures" else ()
    args = (str(path), "--out", str(out), "--jobs", "1", *size.options, *extra)
    return _python(f"FREE = {FREE!r}\n{RUN}", "free" if mode == "free" else "run", *args)


def _has_figures_option() -> bool:
    """Whether ``run`` offers ``--figures`` (static images on request, issue 47)."""
    shown = subprocess.run(
        [sys.executable, "-m", "analysis", "run", "--help"],
        capture_output=True,
        text=True,
        cwd=CODE[0],
    )
    return "--figures" in shown.stdout


def _small_batch(n_sessions: int) -> Callable[[Path], Path]:
    """``n_sessions`` simulated sessions of 18 frames (3 trials, 2 poses, 3 frames), the
    measuring methods in turn, each a different file."""

    def make(work: Path) -> Path:
        folder = work / f"small_{n_sessions}"
        if len(list(folder.glob("*.mcap"))) == n_sessions:
            return folder
        shutil.rmtree(folder, ignore_errors=True)
        for k, method in enumerate(MEASURING_METHODS):
            source = work / f"small_{method}.mcap"
            if not source.exists():
                simulate_session(source, method=method, trials=3, frames=3, seed=47 + k)
            count = len(range(k, n_sessions, len(MEASURING_METHODS)))
            distinct_copies(source, folder, count, stem=f"{method}_")
        return folder

    return make


def _bundled_batch(n_sessions: int) -> Callable[[Path], Path]:
    """``n_sessions`` distinct session files, the bundled ones in turn (the name keeps its
    set's prefix, thesis_ or stress_): copies made different files, as a lab's sessions are,
    so that the batch counts every one (it counts a copy once)."""

    def make(work: Path) -> Path:
        folder = work / f"batch_{n_sessions}"
        if len(list(folder.glob("*.mcap"))) == n_sessions:
            return folder
        shutil.rmtree(folder, ignore_errors=True)
        bundled = sorted((REPO / "sessions").glob("*.mcap"))
        for k, src in enumerate(bundled):
            count = len(range(k, n_sessions, len(bundled)))
            distinct_copies(src, folder, count, stem=f"{src.stem}_")
        return folder

    return make


def _long_session(copies: int) -> Callable[[Path], Path]:
    """One session of ``copies`` x 20 trials x 2 poses x 10 real frames (400 frames a copy)."""

    def make(work: Path) -> Path:
        base = work / "base.mcap"
        if not base.exists():
            simulate_session(base, method=Method.GROUND, trials=20, frames=10, seed=13)
        folder = work / f"long_{copies}"  # a folder of one, so that its outputs stay apart
        path = folder / f"t{copies * 20}.mcap"
        if not path.exists():
            folder.mkdir(exist_ok=True)
            replicate(base, path, copies)
        return path

    return make


def _frames_of(path: Path) -> int:
    return sum(count_frames(p) for p in ([path] if path.is_file() else path.glob("*.mcap")))


@dataclasses.dataclass(frozen=True)
class Measured:
    """A benchmark's timings: per size and mode (run, rerun, free, figures); the marginal
    frame's runs and decodes (run_s, run_l, dec_s, dec_l); the frames of every size."""

    timings: dict[str, dict[str, Timing]]
    frame: dict[str, Timing]
    frames: dict[str, int]


def measure_sizes(
    work: Path, sizes: list[Size], marginal: tuple[Size, Size], repeat: int, *, share: bool
) -> Measured:
    """Every size's modes (run; with ``share`` also re-run, free and once --figures) and the
    marginal frame's runs and decodes, interleaved round by round."""
    paths = {s.name: s.make(work) for s in (*sizes, *marginal)}
    frames = {name: _frames_of(path) for name, path in paths.items()}
    # The re-run and --figures once (the first round), so that the full run takes ~10 min.
    once = (["rerun", "figures"] if _has_figures_option() else ["rerun"]) if share else []
    timings = {s.name: {m: Timing() for m in ("run", "rerun", "free", "figures")} for s in sizes}
    frame = {k: Timing() for k in ("run_s", "run_l", "dec_s", "dec_l")}
    small, large = marginal
    for round_ in range(repeat):  # interleaved: a slow spell of the machine hits every mode
        for size in sizes:
            modes = ["run", *(once[:1] if round_ == 0 else []), *(["free"] if share else [])]
            for mode in [*modes, *(once[1:] if round_ == 0 and size.figures else [])]:
                out = work / f"out_{len(sizes)}_{sizes.index(size)}_{mode}"
                if mode == "rerun":
                    out = work / f"out_{len(sizes)}_{sizes.index(size)}_run"
                else:
                    shutil.rmtree(out, ignore_errors=True)
                printed, cpu = _run(mode, out, size, paths[size.name])
                timings[size.name][mode].keep(cpu, printed)
                if size.name == large.name and mode == "run":
                    frame["run_l"].keep(cpu, printed)
        out = work / "out_marginal_small"
        shutil.rmtree(out, ignore_errors=True)
        frame["run_s"].keep(*_swap(_run("run", out, small, paths[small.name])))
        for key, size in (("dec_s", small), ("dec_l", large)):
            printed, cpu = _python(DECODE_LOOP, str(paths[size.name]))
            frame[key].keep(cpu, [*printed, 0, 0, 0])
    if large.name not in timings:  # the large session is not one of the sizes
        raise SystemExit("the marginal frame's large session must be one of the sizes")
    return Measured(timings, frame, frames)


def _swap(measured: tuple[list[float], float]) -> tuple[float, list[float]]:
    printed, cpu = measured
    return cpu, printed


def share_lines(sizes: list[Size], measured: Measured) -> bool:
    """Print each size's figures' share and re-run; whether every target is met."""
    ok = True
    for size in sizes:
        t, frames = measured.timings[size.name], measured.frames[size.name]
        run, free, rerun, figures = t["run"], t["free"], t["rerun"], t["figures"]
        share = (run.cpu - free.cpu) / run.cpu
        again = rerun.cpu / run.cpu
        opt_in = (
            f"; with --figures (static images, on request: no target) {figures.cpu:.1f} s, "
            f"figures {(figures.cpu - free.cpu) / figures.cpu:.0%}"
            if figures.cpu < float("inf")
            else ""
        )
        command = " ".join(("run --jobs 1", *size.options))
        print(
            f"{size.name} ({frames:,} frames), {command}: "
            f"CPU {run.cpu:.1f} s as run, {free.cpu:.1f} s with figures that cost nothing: "
            f"figures {share:.0%} of the CPU (target <= {SHARE_TARGET:.0%}){opt_in}; "
            f"re-run into the same folder: CPU {rerun.cpu:.1f} s, {again:.0%} of the first "
            f"run's (target <= {RERUN_TARGET:.0%}), {rerun.reused} of {rerun.sessions} "
            f"sessions' analysis reused; wall {run.wall:.1f} s, {free.wall:.1f} s, re-run "
            f"{rerun.wall:.1f} s"
        )
        ok &= share <= SHARE_TARGET and again <= RERUN_TARGET
    return ok


def frame_line(measured: Measured, marginal: tuple[Size, Size]) -> bool:
    """Print a frame's marginal cost in ``run`` against a bare decode; whether the wall
    ratio meets its target."""
    frame = measured.frame
    n_small, n_large = (measured.frames[s.name] for s in marginal)
    ratios = []
    parts = []
    for clock in ("wall", "process_cpu"):

        def per_frame(key: str, clock: str = clock) -> float:
            small, large = frame[f"{key}_s"], frame[f"{key}_l"]
            return (getattr(large, clock) - getattr(small, clock)) / (n_large - n_small) * 1e3

        dec, run = per_frame("dec"), per_frame("run")
        ratios.append(run / dec)
        parts.append(f"decode {dec:.2f}, run {run:.2f}")
    print(
        f"{n_small:,} -> {n_large:,} frames, marginal ms/frame: ratio {ratios[0]:.2f} wall "
        f"(target <= {FRAME_TARGET:g}), {ratios[1]:.2f} CPU (every thread); "
        f"wall {parts[0]}; CPU {parts[1]}"
    )
    return ratios[0] <= FRAME_TARGET


FULL = (
    [
        Size("60 sessions of 18 frames", _small_batch(60), ("--no-scene",)),
        Size("100 sessions", _bundled_batch(100)),
        Size("1 session", _long_session(25), figures=False),  # its figures: a batch's few
    ],
    (Size("2,000-frame session", _long_session(5)), Size("1 session", _long_session(25))),
)
QUICK = (
    [
        Size("6 sessions of 18 frames", _small_batch(6), ("--no-scene",)),
        Size("7 sessions", _bundled_batch(7)),
        Size("1 session", _long_session(3)),
    ],
    (Size("400-frame session", _long_session(1)), Size("1 session", _long_session(3))),
)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workdir", type=Path, default=None, help="keeps the made sessions")
    parser.add_argument("--repeat", type=int, default=None, help="rounds (best kept; 2, quick 1)")
    parser.add_argument("--quick", action="store_true", help="small sizes, for development")
    parser.add_argument("--only", choices=("share", "frames"), help="one part")
    args = parser.parse_args()
    work = args.workdir or Path(tempfile.mkdtemp(prefix="twopose-run-"))
    work.mkdir(parents=True, exist_ok=True)
    CODE[0] = _snapshot(work)
    sizes, marginal = QUICK if args.quick else FULL
    if args.only == "frames":
        sizes = [s for s in sizes if s.name == marginal[1].name]
    repeat = args.repeat or (1 if args.quick else 2)
    measured = measure_sizes(work, sizes, marginal, repeat, share=args.only != "frames")
    ok = True
    if args.only != "frames":
        ok &= share_lines(sizes, measured)
    if args.only != "share":
        ok &= frame_line(measured, marginal)
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
