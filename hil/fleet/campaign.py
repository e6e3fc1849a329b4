"""Campaigns: one rig flown over scenarios x sweep points x seeds, many runs in parallel.

:func:`run_campaign` makes the campaign's directory, runs every case and streams the results;
the parts live by job in hil/fleet/: ``campaign_file.py`` (the campaign file: format,
validation, the cases), ``campaign_executors.py`` (process pool, Dask), ``campaign_summary.py``
(``summary.json`` and its table), ``campaign_case.py`` (one case in its own process). The names
documented in docs/replay-and-campaigns.md are importable from here.

Every case is one ``run_bundled_case(case)`` (hil/fleet/campaign_worker.py): the case carries
its files as bytes, runs in a temporary directory of the worker as ``run_case(params)``
(hil/fleet/campaign_case.py, its own process), and its kept log comes back as bytes, written
here into the campaign's ``logs/``; workers share no filesystem with the client. Executors:
Dask distributed (a ``LocalCluster`` of processes, one thread each, no dashboard, 127.0.0.1,
TLS with temporary credentials; or a scheduler address) when installed, else a stdlib ``ProcessPoolExecutor``. Results stream
into ``results.jsonl`` and a rich summary; ``summary.json`` is written at the end, also after
Ctrl-C (which stops the running cases, their logs finalized, and cancels the queued ones).
"""

from __future__ import annotations

import datetime
import itertools
import json
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from rich.console import Console

from hil import clock
from hil.config import ConfigError
from hil.fleet.campaign_bundle import land_result
from hil.fleet.campaign_case import finite, run_case
from hil.fleet.campaign_executors import (
    CaseFn,
    Handle,
    dask_available,
    default_workers,
    failure,
    local_cluster_security,
    run_dask,
    run_pool,
    start_local_cluster,
)
from hil.fleet.campaign_file import Campaign, KeepLogs, load_campaign
from hil.fleet.campaign_summary import TIMING_KEYS, outcome, print_summary, summarize
from hil.fleet.campaign_worker import run_bundled_case


@dataclass
class CampaignRun:
    """What ``run_campaign`` did: its directory, every finished case's result, the summary."""

    dir: Path
    results: list[dict[str, Any]]
    summary: dict[str, Any]

    @property
    def passed(self) -> bool:
        s = self.summary
        return not s["interrupted"] and s["failed"] == 0 and s["passed"] == s["cases"]


def campaign_dir(out: Path, name: str) -> Path:
    """A new directory ``out/<name>-<UTC stamp>[-n]`` (created; never one that exists)."""
    stamp = datetime.datetime.fromtimestamp(clock.wall_ns() / 1e9, tz=datetime.UTC).strftime("%Y%m%dT%H%M%S")
    for n in itertools.count():
        d = out / (f"{name}-{stamp}" + (f"-{n}" if n else ""))
        try:
            d.mkdir(parents=True)
            return d
        except FileExistsError:
            continue
    raise AssertionError("unreachable")


def run_campaign(
    campaign: Campaign,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    executor: Literal["auto", "dask", "process"] = "auto",
    out_dir: Path | None = None,
    keep_logs: KeepLogs | None = None,
    console: Console | None = None,
    on_result: Handle | None = None,
    case_fn: CaseFn = run_bundled_case,
) -> CampaignRun:
    """Run every case; stream results; write results.jsonl and summary.json; print the summary.

    ``workers``/``out_dir``/``keep_logs`` override the file. ``scheduler``: a Dask scheduler
    address (``tcp://host:8786``; implies Dask). ``executor``: ``auto`` = Dask when installed,
    else the process pool. ``case_fn``: the unit of work (a picklable module-level function).
    """
    out = console if console is not None else Console()
    n_workers = workers or campaign.workers or default_workers()
    use_dask = executor == "dask" or bool(scheduler) or (executor == "auto" and dask_available())
    if use_dask and not dask_available():
        raise ConfigError("Dask is not installed: pip install 'mav-hil-bench[campaign]' (or use the process pool)")
    cdir = campaign_dir(out_dir or campaign.out_dir, campaign.name)
    shutil.copyfile(campaign.path, cdir / "campaign.toml")
    cases = campaign.cases(cdir, keep_logs=keep_logs)
    stop_event = f"hil-stop-{cdir.name}" if use_dask else None  # the stop flag for workers elsewhere
    for case in cases:
        case["stop_event"] = stop_event
    where = f"dask {scheduler}" if scheduler else f"dask LocalCluster x{n_workers} (TLS)" if use_dask else f"process pool x{n_workers}"
    out.print(f"campaign {campaign.name}: {len(cases)} cases on {where} -> {cdir}", highlight=False, soft_wrap=True)
    results: list[dict[str, Any]] = []
    t0 = clock.monotonic_ns()
    with (cdir / "results.jsonl").open("a") as jsonl:

        def handle(result: dict[str, Any]) -> None:
            result = land_result(result, cdir)
            jsonl.write(json.dumps(finite(result), allow_nan=False) + "\n")
            jsonl.flush()
            results.append(result)
            verdict = {"passed": "PASS", "failed": "FAIL", "stopped": "STOP"}[outcome(result)]
            extra = " ".join(f"{k}={v}" for k, v in result.get("overrides", {}).items())
            wall = result.get("wall_s")
            out.print(f"[{len(results)}/{len(cases)}] {verdict} {result['case_id']} {result['scenario']} "
                      f"seed {result['seed']} {extra} ({result['end_reason']}"
                      + (f", {wall:.1f} s)" if wall is not None else ")"), highlight=False, markup=False)
            if on_result is not None:
                on_result(result)

        stop_file = cdir / "STOP"
        if use_dask:
            interrupted, cancelled = run_dask(cases, n_workers, scheduler, case_fn, handle, stop_file, cdir.name,
                                              stop_event=stop_event)
        else:
            interrupted, cancelled = run_pool(cases, n_workers, case_fn, handle, stop_file)
    summary = summarize(results, campaign=campaign, cases=len(cases), interrupted=interrupted, cancelled=cancelled,
                        executor=where, wall_s=(clock.monotonic_ns() - t0) / 1e9, directory=cdir)
    (cdir / "summary.json").write_text(json.dumps(finite(summary), indent=1, allow_nan=False))
    (cdir / "STOP").unlink(missing_ok=True)
    print_summary(out, summary)
    return CampaignRun(cdir, results, summary)


__all__ = ["TIMING_KEYS", "Campaign", "CampaignRun", "KeepLogs", "dask_available", "default_workers", "failure",
           "load_campaign", "local_cluster_security", "outcome", "print_summary", "run_bundled_case", "run_campaign",
           "run_case",
           "start_local_cluster", "summarize"]
