"""``hil falsify SCENARIO``: search the scenario's ``[falsify]`` ranges for a flight that fails
a criterion (docs/falsify.md). Registered by hil/cli.py; the search's imports load when it
runs, so ``hil --help`` stays fast."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from hil.fleet.mutation.command import DEFAULT_CATALOGUE


def falsify(
    scenario: Annotated[Path, typer.Argument(help="A scenario file with a falsify table (what may vary).")],
    rig: Annotated[Path, typer.Option(help="The rig whose flight code is searched.")] = Path("rigs/paper-quad.toml"),
    flights: Annotated[int, typer.Option(min=1, help="Flight budget (whole generations).")] = 200,
    wall_s: Annotated[float | None, typer.Option(min=0.0, help="Wall-time budget, s (checked between generations).")] = None,
    seed: Annotated[int, typer.Option(help="Seed of the optimiser's draws (the flights' own seeds are points).")] = 1,
    workers: Annotated[int | None, typer.Option(min=1, help="Flights at once (default: one per two cores).")] = None,
    scheduler: Annotated[str | None, typer.Option(help="A Dask scheduler address (tls://host:8786).")] = None,
    executor: Annotated[str, typer.Option(help="auto (Dask if installed), dask or process.")] = "auto",
    out: Annotated[Path, typer.Option(help="Output directory (a timestamped directory is made in it).")] = Path("logs/falsify"),
    mutant: Annotated[str | None, typer.Option(help="Search against this catalogue mutant (its id) instead of the flight code.")] = None,
    catalogue: Annotated[Path, typer.Option(help="The edit catalogue --mutant names (TOML).")] = DEFAULT_CATALOGUE,
    criterion: Annotated[list[str] | None, typer.Option(
        help="Aim at the criteria whose names contain this text (repeatable): only their margins and failures count.")] = None,
) -> None:
    """Search for the flight that fails: differential evolution over the ranges of the
    scenario's falsify table minimises the flight's lowest criterion margin; flights run in
    parallel on the campaign engine.

    Writes margins.csv, progress.png, search.json and, when a flight failed,
    counterexample.toml (fly it with hil run RIG -s FILE) and its MCAP. With --mutant, the
    mutant's tree is flown and written to the output directory (mutant/, mutant.diff).

    Exit status: 0 no flight failed within the budget; 1 a counterexample; 2 bad input; 130
    interrupted.
    """
    from rich.console import Console
    from rich.markup import escape

    from hil.config import ConfigError
    from hil.fleet.campaign_executors import dask_available, default_workers, sigterm_as_ctrl_c

    console = Console()
    if executor not in ("auto", "dask", "process"):
        console.print(f"[bold red]error:[/] --executor: {escape(executor)!r} is not auto, dask or process")
        raise typer.Exit(2)
    use_dask = executor == "dask" or bool(scheduler) or (executor == "auto" and dask_available())
    try:
        if use_dask and not dask_available():
            raise ConfigError("--executor dask: Dask is not installed: pip install 'mav-hil-bench[campaign]'")
        if not rig.is_file():
            raise ConfigError(f"{rig}: file not found (--rig)")
        with sigterm_as_ctrl_c():
            code = _run(scenario, rig, flights=flights, wall_s=wall_s, seed=seed,
                        workers=workers or default_workers(), scheduler=scheduler, use_dask=use_dask, out=out,
                        console=console, mutant=mutant, catalogue=catalogue, focus=tuple(criterion or ()))
    except ConfigError as exc:
        console.print(f"[bold red]error:[/] {escape(str(exc))}", soft_wrap=True)
        raise typer.Exit(2) from None
    raise typer.Exit(code)


def _run(scenario: Path, rig: Path, *, flights: int, wall_s: float | None, seed: int, workers: int,
         scheduler: str | None, use_dask: bool, out: Path, console: Any, mutant: str | None = None,
         catalogue: Path = DEFAULT_CATALOGUE, focus: tuple[str, ...] = ()) -> int:
    from rich.markup import escape

    from hil.fleet.campaign import campaign_dir
    from hil.fleet.falsify.report import write_outputs
    from hil.fleet.falsify.mutant import load_mutant
    from hil.fleet.falsify.objective import FAILED
    from hil.fleet.falsify.search import Engine, Flight, fly_reference, run_search
    from hil.fleet.falsify.space import load_space

    space = load_space(scenario)
    aimed = _aimed(space, focus)
    target = None if mutant is None else load_mutant(catalogue, mutant)
    name = space.scenario.name if target is None else f"{space.scenario.name}-{target.id}"
    directory = campaign_dir(out, f"falsify-{name}")
    engine = Engine(rig.resolve(), workers, use_dask, scheduler, directory,
                    extra_files={} if target is None else target.bundle())
    where = f"dask {scheduler}" if scheduler else f"dask LocalCluster x{workers}" if use_dask else f"process pool x{workers}"
    against = "" if target is None else f" against mutant {target.id} ({target.effect})"
    console.print(f"falsify {space.scenario.name} on {rig}{against}: {', '.join(space.keys)}; at most {flights} "
                  f"flights on {where} -> {directory}", highlight=False, soft_wrap=True, markup=False)
    if focus:
        console.print(f"aimed at {len(aimed)} of {len(space.scenario.criteria)} criteria: {'; '.join(aimed)}",
                      highlight=False, soft_wrap=True, markup=False)
    mutant_dir = None if target is None else target.write(directory)

    def progress(f: Flight, budget: int) -> None:
        values = " ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in f.values.items())
        verdict = "FAIL" if f.objective < 0 else "pass"
        margin = f"{f.objective:+.3g}" if f.objective > FAILED else "none"
        console.print(f"[{f.index + 1}/{budget}] gen {f.generation} {verdict} {values}: lowest margin {margin} "
                      f"({f.worst})", highlight=False, markup=False, soft_wrap=True)

    search = run_search(space, engine, flights=flights, wall_s=wall_s, seed=seed, on_flight=progress, focus=focus)
    reference = None
    if target is not None and search.counterexample is not None:
        console.print("the counterexample's flight on the unmodified flight code...", highlight=False)
        reference = fly_reference(space, engine, search.counterexample, focus)
    files = write_outputs(search, space.keys, directory, f"hil falsify {name} ({rig.name})",
                          mutant=None if target is None else target.id, reference=reference, focus=aimed)
    (directory / "STOP").unlink(missing_ok=True)
    best, cx = search.best, search.counterexample
    console.print(f"{len(search.flights)} flights in {search.wall_s:.0f} s; stopped: {search.stopped}", highlight=False)
    if cx is not None:
        console.print(f"[bold red]counterexample[/]: flight {cx.index}, {escape(cx.worst)} "
                      f"(scaled margin {cx.objective:+.3g})" if cx.objective > FAILED else
                      f"[bold red]counterexample[/]: flight {cx.index}: {escape(cx.worst)}", soft_wrap=True)
        reproduce = (f"hil run {rig} -s {files['counterexample']}" if mutant_dir is None else
                     f"(cd {mutant_dir.resolve()} && hil run {rig.resolve()} -s {Path(files['counterexample']).resolve()})")
        console.print(f"  reproduce: {reproduce}", highlight=False, soft_wrap=True, markup=False)
        if cx.log:
            console.print(f"  log: {cx.log}", highlight=False, soft_wrap=True)
        if reference is not None:
            ref = f"{reference.objective:+.3g}" if reference.objective > FAILED else "none"
            console.print(f"  the unmodified flight code on it: {'passes' if reference.objective >= 0 else 'fails'} "
                          f"(lowest scaled margin {ref}, {reference.worst}): "
                          + ("the search separates the mutant" if reference.objective >= 0 else
                             "the point is past what the flight code survives, not a separation"),
                          highlight=False, soft_wrap=True, markup=False)
    elif best is not None:
        console.print(f"no flight failed; closest: flight {best.index}, {best.worst} (scaled margin "
                      f"{best.objective:+.3g}) with {best.values}", highlight=False, soft_wrap=True)
    console.print(f"table: {files['table']}", highlight=False, soft_wrap=True)
    if search.stopped == "interrupted":
        return 130
    return 1 if cx is not None else 0


def _aimed(space: Any, focus: tuple[str, ...]) -> list[str]:
    """The scenario's criteria ``--criterion`` names (all without one); none is an error."""
    from hil.config import ConfigError
    from hil.fleet.falsify.objective import focused

    names = [c.name for c in space.scenario.criteria]
    aimed = [n for n in names if focused(n, focus)]
    if not aimed:
        raise ConfigError(f"{space.path}: --criterion {' / '.join(focus)!r}: no criterion of the scenario has it in "
                          f"its name (criteria: {'; '.join(names)})")
    return aimed


__all__: list[Any] = ["falsify"]
