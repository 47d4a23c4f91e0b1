"""Start-up cost of the command lines and of the core's solvers.

    .venv/bin/python benchmarks/bench_startup.py

Times fresh processes (best of N): `twopose-analyze --help`, `twopose-record --help`, and
`import twopose.solve.nview, twopose.camera.model`; and lists which heavy modules each one loads.
Target: each `--help` under 0.5 s here, the solver import loading neither mcap, pandas nor
matplotlib.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time

from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "startup.txt"

HEAVY = ("mcap", "pandas", "matplotlib", "jsonschema", "cv2", "numpy", "rich")

CASES = {
    "twopose-analyze --help": "import sys; sys.argv = ['twopose-analyze', '--help']\n"
    "from analysis.cli import main\ntry:\n    main()\nexcept SystemExit:\n    pass",
    "twopose-record --help": "import sys; sys.argv = ['twopose-record', '--help']\n"
    "from recorder.cli.app import main\ntry:\n    main()\nexcept SystemExit:\n    pass",
    "import twopose.solve.nview, twopose.camera.model": "import twopose.solve.nview, "
    "twopose.camera.model",
}


def _time(code: str, repeats: int) -> tuple[float, list[str]]:
    probe = code + f"\nimport sys\nprint('LOADED', *[m for m in {HEAVY!r} if m in sys.modules])"
    best, loaded = float("inf"), []
    for _ in range(repeats):
        start = time.perf_counter()
        out = subprocess.run(
            [sys.executable, "-c", probe], capture_output=True, text=True, check=True
        ).stdout
        best = min(best, time.perf_counter() - start)
        loaded = next(line for line in out.splitlines() if line.startswith("LOADED")).split()[1:]
    return best, loaded


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    bare, _ = _time("pass", args.repeats)
    print(f"python -c pass: {bare:.3f} s (the interpreter alone)")
    for name, code in CASES.items():
        seconds, loaded = _time(code, args.repeats)
        print(f"{name}: {seconds:.3f} s; loads {', '.join(loaded) or 'none of ' + '/'.join(HEAVY)}")


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
