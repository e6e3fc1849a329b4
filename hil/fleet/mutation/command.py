"""``hil mutate``: mutation testing of a flight code against a scenario suite (docs/mutation.md).

Registered by hil/cli.py; the campaign machinery is imported when the command runs, so
``hil --help`` stays fast.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

#: the Python flight code's catalogue (`hil falsify --mutant` names it too)
DEFAULT_CATALOGUE = Path("rigs/mutation/flightcode.toml")


def mutate(
    rig: Annotated[Path, typer.Option(help="The rig whose [flight] command flies each mutant.")] = Path("rigs/paper-quad.toml"),
    scenarios: Annotated[list[Path] | None, typer.Option("--scenario", "-s", help="Scenario files or directories (default rigs/scenarios).")] = None,
    exclude: Annotated[list[str] | None, typer.Option(help="Scenario names left out (expected to fail, e.g. paper-literal-weights).")] = None,
    catalogue: Annotated[Path, typer.Option(help="The edit catalogue (TOML).")] = DEFAULT_CATALOGUE,
    equivalents: Annotated[Path | None, typer.Option(help="Mutants judged equivalent, with reasons (default: <catalogue>-equivalents.toml).")] = None,
    tree: Annotated[Path | None, typer.Option(help="The source tree (default: the catalogue's [target] tree, from here).")] = None,
    only: Annotated[list[str] | None, typer.Option(help="Fly only these catalogue mutants (ids).")] = None,
    no_catalogue: Annotated[bool, typer.Option(help="Fly no catalogue mutants (operator mutants only).")] = False,
    operators: Annotated[int, typer.Option(help="Operator mutants to draw (cosmic-ray operators).")] = 0,
    operator_seed: Annotated[int, typer.Option(help="Seed of the operator-mutant draw.")] = 1,
    seeds: Annotated[int, typer.Option(help="Baseline: every scenario on seeds 1..N.")] = 3,
    matrix: Annotated[bool, typer.Option(help="Fly every scenario against every mutant (default: stop at the first kill).")] = False,
    keep_kills: Annotated[bool, typer.Option(help="Bring back the MCAP of each kill.")] = False,
    min_score: Annotated[float, typer.Option(help="Target for catalogue mutants: score (killed / (killed + survived)), 0..1.")] = 0.95,
    min_operator_score: Annotated[float, typer.Option(help="Target for operator mutants, 0..1.")] = 0.8,
    workers: Annotated[int | None, typer.Option(help="Parallel mutants (default: one per two cores).")] = None,
    scheduler: Annotated[str | None, typer.Option(help="A Dask scheduler address (tls://host:8786).")] = None,
    executor: Annotated[str, typer.Option(help="auto (Dask if installed), dask or process.")] = "auto",
    mode: Annotated[str, typer.Option(help="lockstep or realtime.")] = "lockstep",
    out: Annotated[Path, typer.Option(help="Output directory (a timestamped campaign directory is made in it).")] = Path("logs/mutation"),
) -> None:
    """Fly mutants of the flight code (catalogue edits, cosmic-ray operator mutants) against the suite.

    The unmodified flight code flies first, every scenario on --seeds seeds; if any fails the
    campaign stops. Exit status: 0 every target met (--min-score, --min-operator-score); 1 one is not; 2 bad input or a baseline
    failure (named); 130 interrupted.
    """
    from hil.fleet.campaign_executors import sigterm_as_ctrl_c
    from hil.fleet.mutation.cli_run import run

    options = dict(locals())
    # SIGTERM (a CI runner's cancel) between the baseline and the mutants too, not only while
    # cases fly (the executors take it there)
    with sigterm_as_ctrl_c():
        code = run(options)
    raise typer.Exit(code)


__all__: list[Any] = ["mutate"]
