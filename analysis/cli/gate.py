"""``twopose-analyze check`` and ``compare``: the CI gate and two runs side by side."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from twopose.errors import (
    EXIT_SOME_INPUTS_FAILED,
    handle_errors,
)

if TYPE_CHECKING:
    pass

from analysis.choices import Estimator
from analysis.cli.app import JunitOption, app


@app.command("check")
def check_command(
    results: Annotated[Path, typer.Argument(help="The --out folder of the run to check.")],
    baseline: Annotated[
        Path, typer.Option("--baseline", help="The --out folder of the run to compare with.")
    ],
    tolerance: Annotated[
        Path | None,
        typer.Option(
            "--tolerance",
            help="TOML file of allowances (default: RMSE and median 10%, |bias| 10% or "
            "0.05 in, n_ok, n_used and n_warned 0 trials, coverage 0.05); see docs/ci.md.",
        ),
    ] = None,
    junit: JunitOption = None,
) -> None:
    """The CI gate: compare summary.csv with a baseline's, per session and method (RMSE,
    median, |bias|, n_ok, n_used, n_warned, coverage); print what got worse; exit 1 on a
    regression beyond the tolerance."""
    from analysis.batch.outputs import Inputs, write_file
    from analysis.gate.baseline import check, check_cases, check_lines, junit_xml

    with handle_errors():
        read = Inputs(files=(tolerance,) if tolerance else (), folders=(results, baseline))
        read.check_file("--junit", junit)
        outcome = check(results, baseline, tolerance)
        if junit is not None:
            write_file(
                junit, junit_xml("twopose-analyze check", check_cases(outcome), outcome.notes)
            )
    typer.echo("\n".join(check_lines(outcome, baseline)))
    if outcome.regressed:
        raise typer.Exit(EXIT_SOME_INPUTS_FAILED)


@app.command("compare")
def compare_command(
    run_a: Annotated[Path, typer.Argument(help="The --out folder of run A.")],
    run_b: Annotated[Path, typer.Argument(help="The --out folder of run B.")],
    out: Annotated[
        Path, typer.Option("--out", help="Folder for the tables, compare.png, compare.html.")
    ] = Path("comparison"),
    estimator_a: Annotated[Estimator, typer.Option(help="Estimator read from run A.")] = "thesis",
    estimator_b: Annotated[Estimator, typer.Option(help="Estimator read from run B.")] = "thesis",
    include_warned: Annotated[
        bool, typer.Option("--include-warned", help="Also use trials with a warning.")
    ] = False,
) -> None:
    """Compare two runs: statistics side by side, and paired differences (B - A) on the
    trials both measured, with a 95% interval and a sign-flip test, per method; and the
    trials only one run holds."""
    from analysis.gate.comparison import compare, describe_one_sided, describe_test

    with handle_errors():
        comparison = compare(
            run_a,
            run_b,
            out,
            estimator_a=estimator_a,
            estimator_b=estimator_b,
            include_warned=include_warned,
        )
    typer.echo(f"A: {comparison.a.label}\nB: {comparison.b.label}")
    for _, row in comparison.tests.iterrows():
        typer.echo(describe_test(row))
    if comparison.tests.empty:
        typer.echo("no trial measured in both runs")
    for line in describe_one_sided(comparison.one_sided):
        typer.echo(line)
    typer.echo(f"wrote {out / 'compare.html'} and its tables")
