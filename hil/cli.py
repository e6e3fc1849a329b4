"""The ``hil`` command.

    hil run [RIG] [--scenario S] [--mode lockstep|realtime] [--seed N] [--duration T] [--out DIR]
    hil devices [RIG]            bring the emulated devices up on ptys for a hand-started flight code
    hil report LOG               PNG plots of a run (attitude, altitude, motors, timing)
    hil timing LOG               timing of the 400 Hz loop from a log (with a histogram PNG)
    hil replay LOG               play a recorded session's device bytes back on ptys
    hil recover LOG              salvage a killed run's .part file into a valid MCAP
    hil campaign FILE            many runs (Dask)
    hil perf                     benchmarks of this machine and the bench
    hil build [--groups G]       compile the device models, the plant and the tick path (optional)
    hil firmware build [--target host|arm]   build the C flight code (firmware/)
    hil faults                   the fault catalogue with parameters and units
    hil mutate / hil falsify S   does the suite catch flight-code bugs / search S's ranges for a failing flight
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from hil.live.options import DevicesLiveOpt, LiveAddrOpt, LiveOpt, LiveTopicsOpt, live_config
from hil.fleet.falsify import command as falsify_command
from hil.fleet.mutation import command as mutation_command
from hil.flight import firmware_build as firmware_command
from hil.native.sources import Grouping

app = typer.Typer(
    help="Hardware-in-the-loop bench for the Wang/Ma/Sun quad-rotor MAV. "
    "Exit status of every command: 0 success, 1 a verdict failed (criteria, timing, verify), "
    "2 bad input (an 'error:' line says which file, key or path and why); each command's --help says more.",
    no_args_is_help=True, add_completion=False, pretty_exceptions_enable=False,
)
console = Console()
err_console = Console(stderr=True)
_MODES = ("lockstep", "realtime")  #: hil.flight.tickloop.Mode values (not imported here: start-up time)


def _fail(message: str, code: int = 2) -> None:
    # escaped: messages quote file syntax such as "[[faults]]", which is not markup
    err_console.print(f"[bold red]error:[/] {escape(message)}", soft_wrap=True)
    raise typer.Exit(code)


def _log_file(log: Path) -> None:
    """Exit 2 with one sentence unless ``log`` is a complete run log (hil/record/log_check.py)."""
    from hil.record.log_check import LogError, check_log

    try:
        check_log(log)
    except LogError as exc:
        _fail(str(exc))


@app.command()
def run(
    rig: Annotated[str | None, typer.Argument(help="Rig file or name under rigs/ (default: paper-quad).")] = None,
    scenario: Annotated[str | None, typer.Option("--scenario", "-s", help="Scenario file or name under rigs/scenarios/ (default: the rig's).")] = None,
    mode: Annotated[str, typer.Option(help="lockstep (deterministic, as fast as possible) or realtime (400 Hz wall clock).")] = "lockstep",
    seed: Annotated[int | None, typer.Option(help="Run seed (default: the scenario's).")] = None,
    duration: Annotated[float | None, typer.Option(help="Sim seconds to run (default: the scenario's).")] = None,
    out: Annotated[Path, typer.Option(help="Directory for the MCAP log.")] = Path("logs"),
    no_record: Annotated[bool, typer.Option("--no-record", help="Do not write an MCAP file.")] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
    stress_cpu: Annotated[int, typer.Option(help="Timing stress: CPU-bound processes beside the flight code.")] = 0,
    stress_adc_delay_us: Annotated[float, typer.Option(help="Timing stress: hold every ADC bridge reply back (wall us).")] = 0.0,
    wall_clock: Annotated[bool, typer.Option("--wall-clock", help="Lockstep with the flight code on the host clock (no clock shim; docs/time.md). For comparisons only: load then changes the flight.")] = False,
    require_vt: Annotated[bool, typer.Option("--require-virtual-time", help="Lockstep: exit 2 rather than fall back to the host clock (shim missing, static binary, LD_PRELOAD dropped); also the rig's [flight] require_virtual_time.")] = False,
    attach: Annotated[list[str] | None, typer.Option("--attach", help="PORT=DEVICE: this port on a real serial device or URL (/dev/ttyUSB0, socket://host:port, rfc2217://host:port); repeatable; realtime only.")] = None,
    live: LiveOpt = False, live_addr: LiveAddrOpt = None, live_topics: LiveTopicsOpt = None,
    gdb: Annotated[int | None, typer.Option("--gdb", metavar="PORT", min=0, max=65535, help="A board rig ([flight] board): a GDB remote port on the emulated core (0: a free one, printed); the run waits for the debugger before the firmware's first instruction and holds while it holds the core.")] = None,
) -> None:
    """Fly the flight code against the emulated vehicle and write one MCAP log.

    Exit status: 0 the run completed and every criterion passed; 1 a criterion failed or the
    run did not complete (flight code exited, boot failed, interrupted, a resource could not be
    had); 2 bad input (rig, scenario, option, a fault the rig refuses, a [flight] override the
    flight code refuses, virtual time required but not available).
    """
    from hil import clock

    started_ns = clock.bench_start_monotonic_ns()
    # Argument errors first, before the bench's imports (numpy, the plant, the emulators,
    # the recorder): an error must answer in well under half a second.
    if mode not in _MODES:
        _fail(f"--mode: must be 'lockstep' or 'realtime' (got {mode!r})")
    live_cfg = live_config(live, live_addr, live_topics, record=not no_record)
    from hil.config import ConfigError, resolve_rig, resolve_scenario

    try:  # the files exist: found before the rig's validation imports the device models
        rig_file = resolve_rig(rig)
        if scenario is not None:
            resolve_scenario(scenario, rig_file)
    except ConfigError as exc:
        _fail(str(exc))
    from hil.config.rig import load_rig
    from hil.config.scenario import load_scenario
    from hil.flight.scenario_runner import ScenarioRunner

    try:
        rig_obj = load_rig(rig)
        source = rig_obj.scenario_path(scenario)
        scenario_obj = load_scenario(source)
        ScenarioRunner(scenario_obj, rig_obj, source)  # faults and budgets against the rig, before anything starts
    except ConfigError as exc:
        _fail(str(exc))
    import asyncio

    from hil.config.attach import parse_attach_flags, refuse_lockstep, resolve_attachments
    from hil.flight.tickloop import Mode
    from hil.flight.run import PORTS, RunStartError, run_flight_async
    from hil.analysis.summary import print_summary

    run_mode = Mode(mode)
    try:
        attach_map = parse_attach_flags(attach or [])
        refuse_lockstep(resolve_attachments(rig_obj.ports, attach_map, PORTS, command="run"), run_mode.value)
    except ConfigError as exc:
        _fail(str(exc))

    from hil.flight.progress import ConsoleProgress
    from hil.flight.signals import cancelled_by_signals

    # a bar on a terminal, plain lines on a pipe or CI log
    progress = ConsoleProgress(console, f"{rig_obj.name}/{scenario_obj.name}", quiet=quiet)

    async def main() -> object:
        progress.begin()
        return await cancelled_by_signals(run_flight_async(
            rig_obj, scenario_obj, mode=run_mode, seed=seed, duration_s=duration, out_dir=out,
            record=not no_record, progress=progress, scenario_source=source,
            virtual_time=False if wall_clock else None, require_virtual_time=require_vt or None, stress_cpu=stress_cpu,
            stress_adc_delay_us=stress_adc_delay_us, attach=attach_map, started_ns=started_ns, live=live_cfg, gdb_port=gdb))

    try:
        with progress.bar:
            result = asyncio.run(main())
    except ConfigError as exc:  # refused before anything was created, or virtual time required and missing
        _fail(str(exc))
    except RunStartError as exc:  # a resource could not be had; what was acquired is released
        _fail(str(exc), 1)
    print_summary(console, result, rig_obj, scenario_obj)  # type: ignore[arg-type]
    raise typer.Exit(0 if result.passed else 1)  # type: ignore[attr-defined]


@app.command()
def devices(
    rig: Annotated[str | None, typer.Argument(help="Rig file or name under rigs/ (default: paper-quad).")] = None,
    scenario: Annotated[str | None, typer.Option("--scenario", "-s", help="Scenario whose sticks drive the RC (default: the rig's).")] = None,
    seed: Annotated[int, typer.Option(help="Seed of the device models.")] = 1,
    duration: Annotated[float | None, typer.Option(help="Stop after this many seconds (default: until Ctrl-C).")] = None,
    attach: Annotated[list[str] | None, typer.Option("--attach", help="PORT=DEVICE: serve this port on a real serial device or URL instead of a pty (/dev/ttyUSB0, socket://host:port, rfc2217://host:port); repeatable.")] = None,
    live: DevicesLiveOpt = False, live_addr: LiveAddrOpt = None, live_topics: LiveTopicsOpt = None,
) -> None:
    """Bring the emulated devices up on ptys and print their paths, streaming in real time.

    Point any client (the flight code started by hand, miniterm, an Xbus tool) at the
    printed paths. The plant flies on the ESC commands the Maestro receives. Ctrl-C stops.
    With --attach (or the rig's [ports] tables) a port is served on a real serial device
    instead, for a flight-controller board wired through a USB-serial adapter. With --live
    they are served to Foxglove with a run's topics (docs/live.md): prints the URL; takes
    /hil/inject faults; refuses pause, step and speed (real time).

    Exit status: 0 stopped (Ctrl-C or --duration); 1 a resource could not be had (released);
    2 bad input (rig, scenario, an option, a serial device missing, busy or not permitted).
    """
    live_cfg = live_config(live, live_addr, live_topics)
    from hil.config import ConfigError
    from hil.flight import devices_live, run_setup

    try:
        devices_live.serve_devices_blocking(rig, scenario, seed=seed, duration_s=duration, console=console,
                                            attach_flags=attach or [], live=live_cfg)
    except ConfigError as exc:  # bad files or flags, or a serial device missing/busy/denied: nothing started
        _fail(str(exc))
    except run_setup.RunStartError as exc:  # a resource could not be had; what was acquired is released
        _fail(str(exc), 1)


@app.command()
def recover(
    log: Annotated[Path, typer.Argument(help="A killed run's .mcap.part (or .mcap) file.")],
    out: Annotated[Path | None, typer.Option(help="Output file (default: LOG without .part, or LOG.recovered.mcap).")] = None,
) -> None:
    """Salvage a killed run's MCAP: every complete chunk, metadata and attachments.

    Exit status: 0 the file was written (it says how many messages were kept); 2 no such
    file, not an MCAP file, or an output that is the input (nothing written).
    """
    from hil.record import recover as do_recover
    from hil.record import recovered_path
    from hil.record.log_check import LogError

    out = out or recovered_path(log)
    try:
        n = do_recover(log, out)
    except (LogError, OSError) as exc:
        _fail(str(exc))
    console.print(f"recovered {n} messages -> {out}")


@app.command()
def report(
    log: Annotated[Path, typer.Argument(help="A run's MCAP file.")],
    out: Annotated[Path | None, typer.Option(help="Directory for the PNG plots (default: next to the log).")] = None,
) -> None:
    """Plot a run: attitude, altitude, motors and timing, as PNG files.

    Exit status: 0 the plots were written (their paths are printed); 2 not a readable run log.
    """
    from hil.analysis.report import make_report

    _log_file(log)
    for path in make_report(log, out or log.parent):
        console.print(str(path))


@app.command()
def timing(
    log: Annotated[Path, typer.Argument(help="A run's MCAP file.")],
    budget_us: Annotated[float, typer.Option(help="Response-time budget per sample (us).")] = 2500.0,
    png: Annotated[Path | None, typer.Option(help="Histogram PNG (default: LOG_timing.png next to the log).")] = None,
) -> None:
    """Timing of the 400 Hz loop from a log: period, response latency, jitter, misses, compute.

    Exit status: 0 every sample answered within the budget (and, for a realtime run, realtime
    held); 1 a sample over the budget or without an ESC command, or realtime not held; 2 not
    a readable run log (missing, torn, damaged, not an MCAP file, or another tool's MCAP).
    """
    from hil.analysis.timing import analyze_log, plot_latency
    from hil.analysis.timing_table import print_timing

    _log_file(log)
    rep = analyze_log(log, budget_us)
    print_timing(console, rep, log.name)
    out = plot_latency(log, png or log.with_name(log.name.removesuffix(".mcap") + "_timing.png"), budget_us)
    if out is not None:
        console.print(f"histogram: {out}")
    held = rep.realtime is None or rep.realtime.held
    raise typer.Exit(0 if rep.misses == 0 and rep.no_command == 0 and held else 1)


@app.command()
def perf(
    runs: Annotated[int, typer.Option(help="Lockstep runs to take the median of.")] = 3,
    seconds: Annotated[float, typer.Option(help="Sim seconds per run.")] = 10.0,
) -> None:
    """Benchmarks on this machine: plant tick, recording, lockstep RTF, realtime timing.

    Exit status: 0 the table was printed (the figures are information, not a verdict).
    """
    from hil.perf.measure import measure

    rep = measure(lockstep_runs=runs, lockstep_s=seconds, realtime_s=seconds)
    table = Table(title="hil perf (medians; shared machines are noisy: compare ratios)")
    for col in ("figure", "value", "note"):
        table.add_column(col)
    for row in rep.rows:
        table.add_row(*(escape(cell) for cell in row))  # plain text: "[host]" is not markup
    console.print(table)


@app.command()
def build(
    clean: Annotated[bool, typer.Option("--clean", help="Remove the compiled build instead (everything runs interpreted).")] = False,
    jobs: Annotated[Optional[int], typer.Option(help="Parallel compiler processes (default: the CPUs this process may use).")] = None,
    groups: Annotated[Grouping, typer.Option(help="modules: one extension per module, -O2, in parallel (~2 min); "
                      "one: one mypyc group at -O3, the fastest ticks, 5-9 min on one core.")] = Grouping.MODULES,
) -> None:
    """Compile the device models, the plant and the tick path with mypyc (minutes, once), for less
    CPU per tick (docs/performance.md, Builds). The build lives in this environment and is used
    only while it is the build of the sources on disk: after an edit, runs are interpreted, say
    so, and `hil build` compiles again.
    Exit status: 0 built (or removed), 2 the build could not start or failed (what to install).
    """
    from hil import native
    from hil.native.build import BuildError, build as build_native, clean as clean_native
    from hil.native.progress import BuildProgress

    if clean:
        console.print(f"removed {native.build_dir()}" if clean_native() else "no compiled build to remove")
        return
    try:
        with BuildProgress(console) as progress:
            m = build_native(groups=groups.value, jobs=jobs, progress=progress.update, note=progress.note)
    except BuildError as exc:
        _fail(str(exc))
    console.print(f"compiled {len(m.modules)} extension modules (--groups {m.groups}) into {native.build_dir()}; hil uses them")


@app.command()
def replay(
    log: Annotated[Path, typer.Argument(help="A run's MCAP file.")],
    port: Annotated[list[str] | None, typer.Option("--port", "-p", help="Replay only this port (repeatable).")] = None,
    speed: Annotated[float, typer.Option(help="Sim seconds per wall second; 0 = as fast as the clients read.")] = 1.0,
    from_: Annotated[float | None, typer.Option("--from", help="Skip bytes before this sim time (s); 0 skips boot.")] = None,
    no_wait: Annotated[bool, typer.Option("--no-wait", help="Start at once, not when every port has been opened.")] = False,
    verify_: Annotated[bool, typer.Option("--verify", help="Re-run the recorded run from the log's attachments and compare the control wires byte for byte.")] = False,
    out: Annotated[Path, typer.Option(help="With --verify: where the re-run's log goes.")] = Path("logs/verify"),
) -> None:
    """Play a recorded session's device bytes back on ptys, or --verify it by re-running it.

    Exit status: 0 played back (or --verify: the re-run matched); 1 --verify found a
    divergence; 2 not a readable run log, or a log that cannot be replayed.
    """
    import asyncio

    from hil.record import TornRecordingError
    from hil.fleet.replay import replay as do_replay
    from hil.fleet.replay_error import ReplayError
    from hil.fleet.verify import verify

    _log_file(log)
    try:
        if verify_:
            result = verify(log, out)
            console.print(result.report(), markup=False, highlight=False)
            raise typer.Exit(0 if result.ok else 1)
        asyncio.run(
            do_replay(log, ports=port or None, speed=speed, from_s=from_, wait_open=not no_wait, console=console)
        )
    except (ReplayError, TornRecordingError) as exc:
        _fail(str(exc))


@app.command()
def campaign(
    file: Annotated[Path, typer.Argument(help="A campaign TOML (rigs/campaigns/*.toml).")],
    workers: Annotated[int | None, typer.Option(help="Parallel runs (default: one per two cores).")] = None,
    scheduler: Annotated[str | None, typer.Option(help="A Dask scheduler address, e.g. tls://host:8786 (credentials from the Dask config; docs/replay-and-campaigns.md).")] = None,
    executor: Annotated[str, typer.Option(help="auto (Dask if installed), dask or process.")] = "auto",
    out: Annotated[Path | None, typer.Option(help="Campaign output directory (default: the file's).")] = None,
    keep_logs: Annotated[str | None, typer.Option(help="all, failed or none (default: the file's).")] = None,
) -> None:
    """Many runs (scenarios x seeds x sweeps), each in its own process, summarized.

    Exit status: 0 every run passed; 1 a run failed; 2 bad campaign file or option;
    130 interrupted (Ctrl-C; the summary covers the runs that finished).
    """
    from hil.fleet.campaign import run_campaign
    from hil.fleet.campaign_file import KeepLogs, load_campaign
    from hil.config import ConfigError

    try:
        camp = load_campaign(file)
        keep = KeepLogs(keep_logs) if keep_logs is not None else None
    except (ConfigError, ValueError) as exc:
        _fail(str(exc))
    result = run_campaign(
        camp, workers=workers, scheduler=scheduler, executor=executor, out_dir=out, keep_logs=keep, console=console  # type: ignore[arg-type]
    )
    if result.summary.get("interrupted"):
        raise typer.Exit(130)
    raise typer.Exit(0 if result.passed else 1)


@app.command()
def faults(
    layer: Annotated[str | None, typer.Option(help="Only this layer (plant, sensor, wire, device, process...).")] = None,
) -> None:
    """The fault catalogue: every kind with its parameters, units and defaults.

    Exit status: 0.
    """
    from hil.faults import print_catalogue

    print_catalogue(console, layer)


@app.command()
def fidelity(
    seeds: Annotated[int, typer.Option(help="Fly seeds 1..N.")] = 5,
    docs: Annotated[Path, typer.Option(help="Directory for fidelity.md and its plots.")] = Path("docs"),
) -> None:
    """Fly the paper's experiments over several seeds; write the fidelity table and plots.

    Exit status: 0 every row of the table passes; 1 a row fails; 2 bad input.
    """
    from hil.fleet.fidelity import main as fidelity_main

    ok = fidelity_main(list(range(1, seeds + 1)), docs, progress=lambda msg: console.print(msg))
    console.print(f"wrote {docs / 'fidelity.md'}: {'every row passes' if ok else 'some rows FAIL'}")
    raise typer.Exit(0 if ok else 1)

app.command(name="mutate")(mutation_command.mutate)  # hil/fleet/mutation/command.py
app.command(name="falsify")(falsify_command.falsify)  # hil/fleet/falsify/command.py
app.add_typer(firmware_command.firmware_app, name="firmware")  # hil/flight/firmware_build.py

def main() -> None:  # pragma: no cover - console entry
    app()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(app())
