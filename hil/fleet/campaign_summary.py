"""A campaign's summary: counts per scenario, each criterion's worst value, timing medians
(``summary.json``), and the table printed at the end.
"""

from __future__ import annotations

import math
import os
import statistics
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table
from rich.text import Text

from hil.fleet.campaign_file import Campaign

#: the run timing figures whose medians the summary gives per scenario (hil/analysis/timing.py)
TIMING_KEYS = ("rtf", "latency_p99_us", "barrier_misses", "cores_used")


def _median(values: list[Any]) -> float | None:
    xs = [float(v) for v in values if isinstance(v, (int, float)) and math.isfinite(v)]
    return statistics.median(xs) if xs else None


def _cpu_s(timing: dict[str, Any]) -> float | None:
    """CPU-seconds of a flight's tick loop: the cores it kept busy times its wall time."""
    cores, wall_s = timing.get("cores_used"), timing.get("wall_s")
    return cores * wall_s if isinstance(cores, (int, float)) and isinstance(wall_s, (int, float)) else None


def _badness(c: dict[str, Any]) -> tuple[int, float]:
    """Sort key, larger = worse: failed first, then the smaller margin (a result without one,
    from a flight code's own criteria, by its value pushed towards its bound)."""
    v = c.get("value")
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return (1, math.inf)
    failed = 0 if c.get("passed") else 1
    margin = c.get("margin")
    if isinstance(margin, (int, float)):
        return (failed, -float(margin))
    lower_only = ">=" in str(c.get("bound", "")) and "<=" not in str(c.get("bound", ""))
    return (failed, -float(v) if lower_only else float(v))


_STOPPED = frozenset({"interrupted", "cancelled"})


def outcome(result: dict[str, Any]) -> str:
    """``passed``, ``failed``, or ``stopped`` (interrupted or cancelled by a Ctrl-C: no verdict)."""
    if result.get("passed"):
        return "passed"
    return "stopped" if result.get("end_reason") in _STOPPED else "failed"


def summarize(results: list[dict[str, Any]], *, campaign: Campaign, cases: int, interrupted: bool, cancelled: int,
              executor: str, wall_s: float, directory: Path) -> dict[str, Any]:
    """Counts per scenario, each criterion's worst value (and its case), timing medians."""
    by_scenario: dict[str, Any] = {}
    for name in dict.fromkeys(n for n, _ in campaign.scenarios):
        rs = [r for r in results if r.get("scenario") == name]
        worst: dict[str, Any] = {}
        for r in rs:
            for c in r.get("criteria", []):
                w = worst.get(c["name"])
                if w is None or _badness(c) > _badness(w):
                    worst[c["name"]] = {"value": c.get("value"), "bound": c.get("bound"), "passed": c.get("passed"),
                                        "margin": c.get("margin"), "case_id": r["case_id"]}
        by_scenario[name] = {
            "cases": len(rs), **{k: sum(1 for r in rs if outcome(r) == k) for k in ("passed", "failed", "stopped")},
            "end_reasons": dict(sorted({e: sum(1 for r in rs if r.get("end_reason") == e)
                                        for e in {r.get("end_reason") for r in rs}}.items())),
            "worst": worst,
            "timing_median": {k: _median([r.get("timing", {}).get(k) for r in rs]) for k in TIMING_KEYS}
            | {"wall_s": _median([r.get("wall_s") for r in rs])},
        }
    return {
        "campaign": campaign.name, "file": str(campaign.path), "dir": str(directory), "executor": executor,
        "cases": cases, "done": len(results),
        **{k: sum(1 for r in results if outcome(r) == k) for k in ("passed", "failed", "stopped")},
        "cancelled": cancelled, "interrupted": interrupted, "wall_s": wall_s,
        "flights_per_hour": len(results) / wall_s * 3600 if wall_s > 0 else None,
        # the CPU one flight's ticks need (bench, flight code, recorder; hil/host/cpuuse.py): sharing
        # the cores never makes it less, so C CPUs fly at most C * 3600 / this flights an hour
        "cpu_s_per_flight": _median([_cpu_s(r.get("timing", {})) for r in results]),
        "by_scenario": by_scenario,
        "failed_cases": [r["case_id"] for r in results if outcome(r) == "failed"],
    }


def _fmt(v: Any) -> str:
    return "n/a" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.4g}"


def print_summary(console: Console, summary: dict[str, Any]) -> None:
    """The campaign table: per scenario counts, worst criteria values, timing medians."""
    table = Table(title=f"campaign {summary['campaign']}")
    for col in ("scenario", "cases", "pass", "fail", "worst criteria (case)", "RTF", "p99 latency us", "wall s"):
        table.add_column(col)
    for name, s in summary["by_scenario"].items():
        worst = Text()
        for i, (c, w) in enumerate(s["worst"].items()):
            margin = f", margin {w['margin']:+.3g}" if isinstance(w.get("margin"), (int, float)) else ""
            line = f"{chr(10) if i else ''}{c}: {_fmt(w['value'])} {w['bound']}{margin} ({w['case_id']})"
            worst.append(line, style="" if w["passed"] else "red")
        tm = s["timing_median"]
        table.add_row(name, str(s["cases"]), f"[green]{s['passed']}[/]", f"[red]{s['failed']}[/]" if s["failed"] else "0",
                      worst if worst.plain else "-", _fmt(tm["rtf"]), _fmt(tm["latency_p99_us"]), _fmt(tm["wall_s"]))
    console.print(table)
    tail = " (interrupted)" if summary["interrupted"] else ""
    console.print(f"{summary['passed']} passed, {summary['failed']} failed, {summary['stopped']} stopped, "
                  f"{summary['cancelled']} not run of "
                  f"{summary['cases']} in {summary['wall_s']:.1f} s{tail}"
                  + (f" ({summary['flights_per_hour']:.0f} flights/h)" if summary.get("flights_per_hour") else ""),
                  highlight=False)
    cpu_s = summary.get("cpu_s_per_flight")
    if cpu_s:
        n_cpus = len(os.sched_getaffinity(0))
        console.print(f"a flight's ticks took {cpu_s:.3g} CPU-seconds (median): this host's {n_cpus} CPUs fly at most "
                      f"{n_cpus * 3600 / cpu_s:.0f} such flights an hour", highlight=False)
    console.print(f"results: {Path(summary['dir']) / 'results.jsonl'}", highlight=False, soft_wrap=True)


__all__ = ["TIMING_KEYS", "outcome", "print_summary", "summarize"]
