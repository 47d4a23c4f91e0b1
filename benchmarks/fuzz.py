"""The large fuzz sweep (the CI-sized one is tests/test_fuzz_sessions.py): seeded
truncations and bit flips of a recorded session through ``info`` and ``recover``, a share of
them through ``run``; malformed solve requests, plans and scenes come from the hypothesis
tests (tests/test_bad_inputs.py) with ``--hypothesis-seed`` and more examples.

Prints the cases run per command, the exit codes seen, and every violation of the
invariant (allowed exit code with a message; no traceback; no hang).

    python benchmarks/fuzz.py [--mutants 2000] [--run-every 10] [--seed 0]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from twopose.methods.specs import Method

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from analysis.cli import app as analyze  # noqa: E402
from recorder.cli.app import app as record  # noqa: E402
from recorder.setup.plan import load_plan, record_plan  # noqa: E402
from recorder.sources.registry import SyntheticSource  # noqa: E402
from tests.fuzzing import Outcomes, check_command, mutants  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "fuzz.txt"

PLAN = (
    'method = "ground"\nframes = 3\nground_height = 9.625\n[camera]\nfocal = 525.0\n'
    + "[[trials]]\nground_truth = [[1.91, 9.625, 8.375]]\n"
    "poses = [{ t = [0.0, 0.0, 0.0] }, { t = [1.5, 0.0, -1.0] }]\n" * 3
)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mutants", type=int, default=2000)
    parser.add_argument("--run-every", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    started = time.perf_counter()
    per_command = {"info": Outcomes(), "recover": Outcomes(), "run": Outcomes()}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "plan.toml").write_text(PLAN)
        session = folder / "s.mcap"
        record_plan(
            load_plan(folder / "plan.toml"),
            session,
            SyntheticSource(None, Method.GROUND, realtime=False),
        )
        data = session.read_bytes()
        for i, (case, damaged) in enumerate(mutants(data, args.mutants, args.seed)):
            broken = folder / "broken.mcap"
            broken.write_bytes(damaged)
            check_command(analyze, ["info", str(broken)], case, per_command["info"])
            fixed = folder / f"fixed{i}.mcap"
            check_command(
                record, ["recover", str(broken), "-o", str(fixed)], case, per_command["recover"]
            )
            fixed.unlink(missing_ok=True)
            if i % args.run_every == 0:
                out = ["run", str(broken), "--out", str(folder / "out"), "--no-scene"]
                check_command(analyze, out, case, per_command["run"])
    print(" ".join(["python benchmarks/fuzz.py", *sys.argv[1:]]))
    print(
        f"a {len(data) / 1e3:.0f} kB session, {args.mutants} damaged copies (half cut, half "
        f"bit-flipped), seed {args.seed}, {time.perf_counter() - started:.0f} s"
    )
    failures = 0
    for name, o in per_command.items():
        codes = ", ".join(f"exit {c}: {n}" for c, n in sorted(o.codes.items()))
        print(f"  {name:8s} {o.cases:5d} cases: {codes}; violations {len(o.violations)}")
        for v in o.violations[:10]:
            print(f"    {v}")
        failures += len(o.violations)
    return 1 if failures else 0


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
