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
        (("flight code's CPU per sample (us, x cpu_scale)" if rep.compute_source is ComputeSource.CPU
          else "flight code's own compute (us, telemetry)"), rep.compute_us),
        *([("tick lateness (us): start - wall deadline", rep.lateness_us)] if rep.lateness_us is not None else []),
    ):
        table.add_row(name, str(st.n), *(f"{v:.1f}" for v in (st.p50, st.p99, st.p999, st.max, st.mean)))
    console.print(table)
    console.print(
        f"samples {rep.samples}; over the {rep.budget_us:g} us budget: {rep.misses}; "
        f"no ESC command at all: {rep.no_command}"
    )
    if rep.realtime is not None:
        console.print(rep.realtime.text, style=None if rep.realtime.held else "bold red", highlight=False)
