"""``hil timing`` on the console: a log's timing report (hil.analysis.timing.TimingReport)
as a rich table of the 400 Hz loop's figures, the budget's verdict and, for a realtime
run, whether it held 400 Hz. Figures are microseconds, as their row names say.
"""

from __future__ import annotations

from rich.console import Console
from rich.table import Table

from hil.analysis.timing import ComputeSource, TimingReport


def print_timing(console: Console, rep: TimingReport, log_name: str) -> None:
    """Print ``rep`` (the timing report of the log named ``log_name``) on ``console``."""
    table = Table(title=f"loop timing: {log_name}")
    for col in ("figure", "n", "p50", "p99", "p99.9", "max", "mean"):
        table.add_column(col, justify="right" if col != "figure" else "left")
    for name, st in (
        ("response latency (us): IMU emitted -> ESC command", rep.latency_us),
        ("ESC command period (us)", rep.period_us),
        ("period jitter |T - 2500| (us)", rep.jitter_us),
        (("loop busy time per sample (us on the emulated LPC2148)" if rep.board_cclk_hz is not None
          else "flight code's CPU per sample (us, x cpu_scale)" if rep.compute_source is ComputeSource.CPU
          else "flight code's own compute (us, telemetry)"), rep.compute_us),
        *([("tick lateness (us): start - wall deadline", rep.lateness_us)] if rep.lateness_us is not None else []),
    ):
        table.add_row(name, str(st.n), *(f"{v:.1f}" for v in (st.p50, st.p99, st.p999, st.max, st.mean)))
    console.print(table)
    console.print(
        f"samples {rep.samples}; over the {rep.budget_us:g} us budget: {rep.misses}; "
        f"no ESC command at all: {rep.no_command}"
    )
    if rep.board_cclk_hz is not None:
        print_cycle_histogram(console, rep)
    if rep.realtime is not None:
        console.print(rep.realtime.text, style=None if rep.realtime.held else "bold red", highlight=False)


#: the text histogram's bins and bar width
HIST_BINS, HIST_WIDTH = 12, 40


def print_cycle_histogram(console: Console, rep: TimingReport) -> None:
    """A board run: the busy cycles of each answering loop iteration against the budget, as
    a text histogram (bins of equal width from 0 to the larger of the budget and the worst)."""
    cycles, budget = rep.board_busy_cycles, rep.budget_cycles
    assert rep.board_cclk_hz is not None and budget is not None
    if not cycles:
        console.print("loop busy cycles: no sample was answered")
        return
    top = max(max(cycles), budget)
    width = top / HIST_BINS
    counts = [0] * HIST_BINS
    for c in cycles:
        counts[min(int(c / width), HIST_BINS - 1)] += 1
    most = max(counts)
    console.print(f"loop busy cycles per sample (LPC2148 at {rep.board_cclk_hz / 1e6:g} MHz; budget "
                  f"{rep.budget_us:g} us = {budget:,.0f} cycles):", highlight=False)
    for i, n in enumerate(counts):
        lo, hi = i * width, (i + 1) * width
        mark = "over" if lo >= budget else ("budget" if lo < budget <= hi else "")
        bar = "#" * (round(HIST_WIDTH * n / most) if n else 0)
        console.print(f"  {lo:>9,.0f} - {hi:>9,.0f}  {n:>6}  {bar:<{HIST_WIDTH}} {mark}", highlight=False)
    over = sum(1 for c in cycles if c > budget)
    console.print(f"  {over} of {len(cycles)} over the budget; worst {max(cycles):,.0f} cycles "
                  f"({max(cycles) / budget:.0%} of it)", highlight=False)
