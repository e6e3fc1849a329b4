"""The end-of-run summary table (rich): verdict, criteria, timing, counters, log path."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from rich.console import Console
from rich.table import Table

from hil import native

if TYPE_CHECKING:
    from hil.config.rig import Rig
    from hil.flight.run_result import RunResult
    from hil.config.scenario import Scenario


def _fmt(value: float) -> str:
    if math.isnan(value):
        return "n/a"
    if math.isinf(value):
        return "inf"
    return f"{value:.4g}"


def _margin(margin: float) -> str:
    """A criterion's margin: signed, so that a near-miss reads as one ("+0.02", "-0.3")."""
    if math.isnan(margin):
        return ""
    if math.isinf(margin):
        return "none" if margin < 0 else ""
    return f"{margin:+.3g}"


def print_summary(console: Console, result: RunResult, rig: Rig, scenario: Scenario) -> None:
    verdict = "[bold green]PASS[/]" if result.passed else "[bold red]FAIL[/]"
    console.print(
        f"{verdict}  {rig.name} / {scenario.name}  seed {result.seed}  "
        f"{result.sim_s:.2f} s simulated  ({result.end_reason.value})"
    )
    if result.message:
        console.print(f"  {result.message}")
    clock_line = {
        "virtual": "clock: virtual (the flight code ran on sim time; load does not change the flight)",
        "wall": "clock: host (lockstep fallback: load can change the flight)",
        "realtime": "clock: host, realtime",
        "board": "clock: the emulated LPC2148's cycles (the firmware's time; load does not change the flight)",
    }[result.clock.value]
    if result.rt_scheduling is not None:
        clock_line += f", {result.rt_scheduling.describe()}"
    console.print(f"  {clock_line}" + (f": {result.clock_note}" if result.clock_note else ""), highlight=False)
    if result.cpu_latency is not None:
        console.print(f"  host: {result.cpu_latency.describe()}", highlight=False)
    console.print(f"  device models, plant, tick path: {native.describe()}", highlight=False)
    for note in result.notes:
        console.print(f"  [yellow]note:[/] {note}", highlight=False)
    if result.criteria:
        table = Table(title="criteria", show_lines=False)
        for col in ("check", "signal", "metric", "value", "bound", "margin", "result"):
            table.add_column(col)
        for c in result.criteria:
            table.add_row(
                c.name, c.signal, c.metric, _fmt(c.value), c.bound, _margin(c.margin),
                {"pass": "[green]pass[/]", "FAIL": "[red]FAIL[/]", "not judged": "[yellow]not judged[/]"}[c.verdict]
                + (f" ({c.detail})" if c.detail else ""),
            )
        console.print(table)
    t = result.timing
    timing = Table(title="timing")
    timing.add_column("figure")
    timing.add_column("value")
    for key in (
        "rtf", "ticks", "barrier_misses", "latency_p50_us", "latency_p99_us", "latency_max_us",
        "fc_compute_p50_us", "fc_compute_p99_us", "fc_compute_max_us", "period_p50_us", "period_jitter_p99_us",
        "host_latency_p50_us", "host_latency_p99_us", "bench_cost_p50_us", "bench_cost_p99_us",
        "bench_cpu_per_tick_us", "fc_cpu_per_tick_us", "recorder_cpu_per_tick_us", "cores_used",
        "lateness_p50_us", "lateness_p99_us", "lateness_max_us", "late_ticks", "rt_no_command", "late_commands", "host_steal_ms", "boot_sim_s",
        "start_to_tick0_s",
    ):
        if key in t:
            timing.add_row(key, _fmt(t[key]))
    console.print(timing)
    if "board_cclk_hz" in t:
        _print_board(console, t)
    if result.flight_returncode not in (None, 0) or result.end_reason.value != "completed":
        console.print(f"flight code exit status: {result.flight_returncode}")
        if result.flight_stderr_tail:
            console.print("last flight-code stderr lines:")
            for line in result.flight_stderr_tail[-8:]:
                console.print(f"  {line}", markup=False, highlight=False)
    if result.dropped:
        console.print(f"[yellow]recorder dropped {result.dropped} messages (queue full)[/]")
    console.print(f"log: {result.log_path}" if result.log_path else "log: (not recorded)")


#: a board run's figures as the summary shows them (hil/flight/board_timing.py has them all)
_BOARD_ROWS = (
    ("loop busy cycles p50 / p99 / max", ("board_loop_busy_p50_cycles", "board_loop_busy_p99_cycles",
                                          "board_loop_busy_max_cycles")),
    ("CPU load % (flight / busiest tick)", ("board_cpu_load_pct", "board_cpu_load_max_pct")),
    ("interrupt latency cycles p50 / p99 / max", ("board_irq_latency_p50_cycles", "board_irq_latency_p99_cycles",
                                                  "board_irq_latency_max_cycles")),
    ("UART RX overruns (UART0 / UART1)", ("board_uart0_rx_overruns", "board_uart1_rx_overruns")),
    ("ESC pulses late / missed", ("board_esc_pulses_late", "board_esc_pulses_missed")),
    ("samples processed / dropped", ("board_samples_processed", "board_samples_dropped")),
)


def _print_board(console: Console, t: dict[str, float]) -> None:
    """The emulated LPC2148's figures, in target cycles."""
    table = Table(title=f"board (emulated LPC2148 at {t['board_cclk_hz'] / 1e6:g} MHz)")
    table.add_column("figure")
    table.add_column("value")
    for label, keys in _BOARD_ROWS:
        if all(k in t for k in keys):
            table.add_row(label, " / ".join(_fmt(t[k]) for k in keys))
    modes = [k.removeprefix("board_stack_").removesuffix("_used_B") for k in t
             if k.startswith("board_stack_") and k.endswith("_used_B")]
    if modes:
        table.add_row("stack used / region B", ", ".join(
            f"{m} {t[f'board_stack_{m}_used_B']:.0f}/{t[f'board_stack_{m}_size_B']:.0f}" for m in modes))
    console.print(table)
