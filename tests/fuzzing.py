"""A reusable fuzz harness: seeded damage to files, and the invariant every entry point
must keep on any input (an exit code of 0, 1, 2, 3 or 130 with a message; never a
traceback; never a hang; never a numerical warning printed at the user, such as NumPy's
``RuntimeWarning: overflow encountered``: the input is refused, or the result flagged).

Used by the CI-sized sweeps in ``tests/`` and the large ones in ``benchmarks/fuzz.py``.
"""

from __future__ import annotations

import signal
import warnings
from collections import Counter
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import typer
from typer.testing import CliRunner

ALLOWED_EXIT_CODES = {0, 1, 2, 3, 130}


def mutants(data: bytes, n: int, seed: int) -> Iterator[tuple[str, bytes]]:
    """``n`` damaged copies of ``data``: alternately cut at a random byte, and with 1-8
    random bits flipped (seeded: the same seed gives the same files)."""
    rng = np.random.default_rng(seed)
    for i in range(n):
        if i % 2 == 0:
            cut = int(rng.integers(0, len(data)))
            yield f"cut at {cut}", data[:cut]
        else:
            damaged = bytearray(data)
            where = rng.integers(0, len(data), size=int(rng.integers(1, 9)))
            for k in where:
                damaged[int(k)] ^= 1 << int(rng.integers(0, 8))
            yield f"bits flipped at {sorted(int(k) for k in where)}", bytes(damaged)


class HangError(Exception):
    """A command ran past its time limit."""


@contextmanager
def time_limit(seconds: int) -> Iterator[None]:
    """Raise :class:`HangError` if the block runs longer than ``seconds`` (main thread only)."""

    def expired(signum: int, frame: Any) -> None:
        raise HangError(f"no answer within {seconds} s")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


@dataclass
class Outcomes:
    """Exit codes seen, and every violation of the invariant with its case."""

    codes: Counter[int] = field(default_factory=Counter)
    violations: list[str] = field(default_factory=list)

    @property
    def cases(self) -> int:
        return sum(self.codes.values()) + len(self.violations)


def check_command(
    app: typer.Typer,
    args: Sequence[str],
    case: str,
    outcomes: Outcomes,
    seconds: int = 60,
    stdin: str | None = None,
) -> int | None:
    """Run one command in-process; record its exit code or the invariant it broke."""
    runner = CliRunner()
    try:
        with time_limit(seconds), warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", RuntimeWarning)
            result = runner.invoke(app, list(args), input=stdin)
    except HangError as err:
        outcomes.violations.append(f"{case}: {' '.join(args)}: {err}")
        return None
    numerical = [w for w in caught if issubclass(w.category, RuntimeWarning)]
    if numerical:
        first = numerical[0]
        outcomes.violations.append(
            f"{case}: {' '.join(args)}: {first.category.__name__} {first.message} "
            f"({first.filename}:{first.lineno})"
        )
        return None
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        kind = type(result.exception).__name__
        outcomes.violations.append(f"{case}: {' '.join(args)}: traceback ({kind})")
        return None
    if result.exit_code not in ALLOWED_EXIT_CODES or "Traceback" in result.output:
        outcomes.violations.append(f"{case}: {' '.join(args)}: exit {result.exit_code}")
        return None
    if result.exit_code != 0 and not result.output.strip():
        outcomes.violations.append(f"{case}: {' '.join(args)}: exit {result.exit_code}, silent")
        return None
    outcomes.codes[result.exit_code] += 1
    return result.exit_code
