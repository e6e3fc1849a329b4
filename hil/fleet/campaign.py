"""Campaigns: one rig flown over scenarios x sweep points x seeds, many runs in parallel.

A campaign file (``rigs/campaigns/*.toml``; format in docs/replay-and-campaigns.md)::

    [campaign]
    name = "hover-seeds"
    rig = "paper-quad"               # name under rigs/, or a path (relative to this file)
    scenarios = ["hover"]            # names (the rig's scenarios/, rigs/scenarios/) or paths
    seeds = { from = 1, count = 20 } # or a list: [1, 2, 3]
    mode = "lockstep"
    duration_s = 10.0                # optional: overrides every scenario's duration
    workers = 1                      # optional: default one per two cores
    out = "logs/campaigns"           # a directory <name>-<UTC time> is made in it
    keep_logs = "failed"             # all | failed | none
    case_timeout_s = 600.0           # wall seconds per case, then it is stopped

    [sweep.flight]                   # the flight code's config (keys of the rig's template)
    "attitude.tau_ff_s" = [0.025, 0.035]
    [sweep.rig]                      # the rig file's tables (plant, imu, ...), validated like it
    "plant.body.mass_kg" = [1.1, 1.4]

Every case is one ``run_case(params)`` (hil/fleet/campaign_case.py) in its own process. Executors:
Dask distributed (a ``LocalCluster`` of processes, one thread each, no dashboard, 127.0.0.1,
TLS with temporary credentials; or a scheduler address) when installed, else a stdlib ``ProcessPoolExecutor``. Results stream
into ``results.jsonl`` and a rich summary; ``summary.json`` is written at the end, also after
Ctrl-C (which stops the running cases, their logs finalized, and cancels the queued ones).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import datetime
import enum
import importlib.util
import itertools
import json
import math
import multiprocessing
import os
import shutil
import signal
import statistics
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import tomli_w
from pydantic import BaseModel, ConfigDict, Field
from rich.console import Console
from rich.table import Table
from rich.text import Text

from hil import clock
from hil.fleet.campaign_case import finite, nested, run_case
from hil.config import ConfigError, load_toml, resolve_rig, validate

CaseFn = Callable[[dict[str, Any]], dict[str, Any]]
TIMING_KEYS = ("rtf", "latency_p99_us", "barrier_misses", "cores_used")
_STOP_WAIT_S = 60.0  # after Ctrl-C, wait this long for the running cases to finalize


class KeepLogs(enum.StrEnum):
    ALL = "all"
    FAILED = "failed"
    NONE = "none"


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class SeedRange(_Strict):
    first: int = Field(alias="from", ge=0)
    count: int = Field(gt=0, le=1_000_000)


class CampaignHeader(_Strict):
    name: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_.-]+$")
    description: str = ""
    rig: str = "paper-quad"
    scenarios: list[str] = Field(min_length=1)
    seeds: list[Annotated[int, Field(ge=0)]] | SeedRange = [1]
    mode: Literal["lockstep", "realtime"] = "lockstep"
    duration_s: float | None = Field(default=None, gt=0)
    workers: int | None = Field(default=None, ge=1)
    out: str = "logs/campaigns"
    keep_logs: KeepLogs = KeepLogs.FAILED
    case_timeout_s: float = Field(default=600.0, gt=0)


class SweepTables(_Strict):
    flight: dict[str, Any] = {}
    rig: dict[str, Any] = {}


class CampaignFile(_Strict):
    campaign: CampaignHeader
    sweep: SweepTables = SweepTables()


Sweep = tuple[tuple[str, tuple[Any, ...]], ...]


@dataclass(frozen=True)
class Campaign:
    """A validated campaign file; paths absolute. ``flight_sweep``/``rig_sweep``: (dotted key,
    values) in file order; the cases are scenarios x product(sweeps) x seeds."""

    path: Path
    name: str
    description: str
    rig_path: Path
    scenarios: tuple[tuple[str, Path], ...]
    seeds: tuple[int, ...]
    mode: str
    duration_s: float | None
    workers: int | None
    out_dir: Path
    keep_logs: KeepLogs
    case_timeout_s: float
    flight_sweep: Sweep = ()
    rig_sweep: Sweep = ()

    def points(self) -> list[tuple[dict[str, Any], dict[str, Any]]]:
        """Every sweep point: (flight overrides, rig overrides), dotted keys."""
        keys = [("flight", k) for k, _ in self.flight_sweep] + [("rig", k) for k, _ in self.rig_sweep]
        values = [v for _, v in self.flight_sweep] + [v for _, v in self.rig_sweep]
        out = []
        for combo in itertools.product(*values):
            flight = {k: v for (kind, k), v in zip(keys, combo, strict=True) if kind == "flight"}
            rig = {k: v for (kind, k), v in zip(keys, combo, strict=True) if kind == "rig"}
            out.append((flight, rig))
        return out

    def cases(self, campaign_dir: Path, *, keep_logs: KeepLogs | None = None) -> list[dict[str, Any]]:
        """The params of every case (JSON-able; see hil/fleet/campaign_case.py)."""
        out: list[dict[str, Any]] = []
        for (scenario_name, scenario_path), (flight, rig), seed in itertools.product(
                self.scenarios, self.points(), self.seeds):
            case_id = f"{len(out):04d}"
            out.append({
                "case_id": case_id, "campaign": self.name, "rig": str(self.rig_path),
                "scenario": str(scenario_path), "scenario_name": scenario_name, "seed": seed, "mode": self.mode,
                "duration_s": self.duration_s, "flight_overrides": flight, "rig_overrides": rig,
                "case_dir": str(campaign_dir / "cases" / case_id),
                "log_path": str(campaign_dir / "logs" / f"{case_id}_{scenario_name}_s{seed}.mcap"),
                "keep_logs": (keep_logs or self.keep_logs).value, "timeout_s": self.case_timeout_s,
                "stop_file": str(campaign_dir / "STOP"), "cwd": str(Path.cwd()),
            })
        return out


# ---- loading ------------------------------------------------------------------------------------
def _near(value: str, campaign_path: Path) -> Path | None:
    candidate = campaign_path.parent / value
    return candidate.resolve() if candidate.is_file() else None


def _flatten(table: dict[str, Any], file: Path, section: str, prefix: str = "") -> list[tuple[str, tuple[Any, ...]]]:
    out: list[tuple[str, tuple[Any, ...]]] = []
    for k, v in table.items():
        key = f"{prefix}.{k}" if prefix else k
        if isinstance(v, dict):
            out += _flatten(v, file, section, key)
        elif isinstance(v, list) and v:
            out.append((key, tuple(v)))
        else:
            raise ConfigError(f"{file}: [{section}] {key}: a sweep is a non-empty list of values (got {v!r})")
    return out


_MISSING = object()


def _lookup(table: Any, dotted: str) -> Any:
    for part in dotted.split("."):
        if not isinstance(table, dict) or part not in table:
            return _MISSING
        table = table[part]
    return table


def _same_kind(ref: Any, value: Any) -> bool:
    if isinstance(ref, bool) or isinstance(value, bool):
        return isinstance(ref, bool) and isinstance(value, bool)
    if isinstance(ref, (int, float)):
        return isinstance(value, (int, float))
    return type(ref) is type(value)


def _check_flight(sweep: Sweep, template: Path, scenario_tables: list[dict[str, Any]], file: Path) -> None:
    """Flight overrides must name keys the flight code knows: those of its config template (which
    lists every key) or of a scenario's [flight]; values must be of the same kind."""
    tables = [load_toml(template), *scenario_tables]
    for key, values in sweep:
        refs = [r for r in (_lookup(t, key) for t in tables) if r is not _MISSING]
        if not refs:
            raise ConfigError(f"{file}: [sweep.flight] {key}: not a key of the flight config template {template} "
                              "(the flight code rejects unknown keys)")
        for v in values:
            if not _same_kind(refs[0], v) or isinstance(refs[0], dict):
                raise ConfigError(f"{file}: [sweep.flight] {key}: {v!r} is not of the kind of the template's "
                                  f"value {refs[0]!r}")


def _rig_variant(rig_path: Path, overrides: dict[str, Any], dest: Path) -> Path:
    """A copy of the rig with ``overrides`` merged and its flight-config template made absolute."""
    from hil.flight.run import deep_merge

    data = deep_merge(load_toml(rig_path), nested(overrides))
    flight = dict(data.get("flight", {}))
    template = Path(str(flight.get("config", "flightcode-paper-quad.toml")))
    flight["config"] = str(template if template.is_absolute() else (rig_path.parent / template).resolve())
    data["flight"] = flight
    dest.write_text(tomli_w.dumps(data))
    return dest


def _check_rig(sweep: Sweep, rig_path: Path, file: Path) -> None:
    """Each rig override value, merged alone into the rig, must load (component validation)."""
    from hil.config.rig import load_rig

    with tempfile.TemporaryDirectory(prefix="hil-campaign-") as tmp:
        for key, values in sweep:
            for v in values:
                variant = _rig_variant(rig_path, {key: v}, Path(tmp) / rig_path.name)
                try:
                    load_rig(variant)
                except ConfigError as exc:
                    reason = str(exc).replace(f"{variant}: ", "").replace(str(variant), str(rig_path))
                    raise ConfigError(f"{file}: [sweep.rig] {key} = {v!r}: {reason}") from None


def load_campaign(path: Path | str) -> Campaign:
    """Read and validate a campaign file. Errors (ConfigError) name the file, key and reason."""
    from hil.config.rig import load_rig
    from hil.config.scenario import load_scenario

    path = Path(path).resolve()
    model = validate(CampaignFile, load_toml(path), file=path, section="")
    h = model.campaign
    try:
        rig_path = _near(h.rig, path) or resolve_rig(h.rig).resolve()
    except ConfigError as exc:
        raise ConfigError(f"{path}: [campaign] rig: {exc}") from None
    rig = load_rig(rig_path)
    scenarios: list[tuple[str, Path]] = []
    flights: list[dict[str, Any]] = []
    for entry in h.scenarios:
        try:
            source = _near(entry, path) or rig.scenario_path(entry).resolve()
        except ConfigError as exc:
            raise ConfigError(f"{path}: [campaign] scenarios: {exc}") from None
        scenario = load_scenario(source)
        scenarios.append((scenario.name, source))
        flights.append(scenario.flight)
    seeds = tuple(h.seeds) if isinstance(h.seeds, list) else tuple(range(h.seeds.first, h.seeds.first + h.seeds.count))
    if len(set(seeds)) != len(seeds):
        raise ConfigError(f"{path}: [campaign] seeds: a seed appears twice")
    flight_sweep = tuple(_flatten(model.sweep.flight, path, "sweep.flight"))
    rig_sweep = tuple(_flatten(model.sweep.rig, path, "sweep.rig"))
    _check_flight(flight_sweep, rig.flight_config_path, flights, path)
    _check_rig(rig_sweep, rig_path, path)
    return Campaign(path, h.name, h.description, rig_path, tuple(scenarios), seeds, h.mode, h.duration_s,
                    h.workers, Path(h.out), h.keep_logs, h.case_timeout_s, flight_sweep, rig_sweep)


# ---- executors ----------------------------------------------------------------------------------
def default_workers() -> int:
    """One case per two cores: concurrent runs distort each other's timing (ecosystem.md §7)."""
    return max(1, (os.cpu_count() or 2) // 2)


def dask_available() -> bool:
    return importlib.util.find_spec("distributed") is not None


def failure(case: dict[str, Any], end_reason: str, message: str) -> dict[str, Any]:
    """The result of a case that produced none (its worker died, the executor failed it)."""
    overrides = {**{f"flight.{k}": v for k, v in case["flight_overrides"].items()},
                 **{f"rig.{k}": v for k, v in case["rig_overrides"].items()}}
    return {"case_id": case["case_id"], "scenario": case["scenario_name"], "seed": case["seed"],
            "overrides": overrides, "passed": False, "end_reason": end_reason, "message": message,
            "criteria": [], "timing": {}, "sim_s": 0.0, "flight_returncode": None, "log": None,
            "returncode": None, "wall_s": None}


def _ignore_sigint() -> None:  # pool workers: Ctrl-C is the campaign's to handle
    signal.signal(signal.SIGINT, signal.SIG_IGN)


Handle = Callable[[dict[str, Any]], None]


def _take(fut: cf.Future[dict[str, Any]], case: dict[str, Any], handle: Handle, broken: list[dict[str, Any]]) -> None:
    """Hand one pool future's result on; a case lost to a broken pool goes to ``broken``."""
    try:
        result = fut.result()
    except cf.process.BrokenProcessPool:
        broken.append(case)
        return
    except Exception as exc:  # noqa: BLE001 - whatever the case function raised is that case's failure
        result = failure(case, "case error", f"{type(exc).__name__}: {exc}")
    handle(result)


def _pool_round(cases: list[dict[str, Any]], workers: int, case_fn: CaseFn, handle: Handle,
                stop_file: Path) -> tuple[bool, int, list[dict[str, Any]]]:
    """One process pool over ``cases``: (interrupted, cancelled, cases lost to a dead worker)."""
    pool = cf.ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                                  initializer=_ignore_sigint)
    futures = {pool.submit(case_fn, c): c for c in cases}
    broken: list[dict[str, Any]] = []
    handled: set[cf.Future[dict[str, Any]]] = set()
    try:
        for fut in cf.as_completed(futures):
            handled.add(fut)
            _take(fut, futures[fut], handle, broken)
    except KeyboardInterrupt:
        stop_file.touch()
        cancelled = sum(1 for f in futures if f.cancel())
        rest = [f for f in futures if f not in handled and not f.cancelled()]
        try:
            for fut in cf.as_completed(rest, timeout=_STOP_WAIT_S):
                handled.add(fut)
                _take(fut, futures[fut], handle, broken)
        except (KeyboardInterrupt, cf.TimeoutError):
            pass  # a second Ctrl-C: stop waiting
        pool.shutdown(wait=False, cancel_futures=True)
        return True, cancelled + len(broken) + sum(1 for f in rest if f not in handled), []
    pool.shutdown(wait=True)
    return False, 0, broken


def _run_pool(cases: list[dict[str, Any]], workers: int, case_fn: CaseFn, handle: Handle,
              stop_file: Path) -> tuple[bool, int]:
    """Stdlib process pool. A worker that dies breaks the pool and every unfinished case with
    it; those cases are then re-run one per fresh pool, so only the culprit fails ("worker
    died") and the others get their result. Returns (interrupted, cancelled)."""
    interrupted, cancelled, broken = _pool_round(cases, workers, case_fn, handle, stop_file)
    for i, case in enumerate(broken):
        if interrupted:
            return True, cancelled + len(broken) - i
        interrupted, cancelled, again = _pool_round([case], 1, case_fn, handle, stop_file)
        if again:
            handle(failure(case, "worker died", "its worker process died (run alone in a fresh pool)"))
    return interrupted, cancelled


def local_cluster_security() -> Any:
    """TLS credentials for a local Dask cluster: a throw-away CA and certificate made for this
    cluster (``Security.temporary()``, needs ``cryptography``), encryption required.

    Dask's scheduler and workers listen on TCP ports; on loopback any local user could
    otherwise connect and run code as us (a Dask client can submit any function). With TLS
    and mutual authentication only holders of these in-memory credentials can."""
    from distributed.security import Security

    return Security.temporary()


def start_local_cluster(workers: int, **kwargs: Any) -> Any:
    """A LocalCluster of ``workers`` processes (one thread each, no dashboard) on 127.0.0.1,
    speaking TLS with temporary credentials (:func:`local_cluster_security`)."""
    from distributed import LocalCluster

    security = local_cluster_security()
    return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                        host="127.0.0.1", protocol="tls://", security=security, **kwargs)


def _run_dask(cases: list[dict[str, Any]], workers: int, scheduler: str | None, case_fn: CaseFn, handle: Handle,
              stop_file: Path, tag: str) -> tuple[bool, int]:
    """Dask distributed: a LocalCluster of ``workers`` processes, or the cluster at ``scheduler``."""
    import logging

    from distributed import Client, as_completed, wait

    cluster = None
    if scheduler:
        # Security from Dask's configuration (distributed.comm.tls.*; docs/replay-and-campaigns.md)
        client = Client(scheduler)
    else:
        cluster = start_local_cluster(workers, silence_logs=logging.ERROR)
        client = Client(cluster, security=cluster.security)
        # A terminal Ctrl-C reaches the local workers too; the campaign stops the cases itself.
        with contextlib.suppress(Exception):
            client.run(_ignore_sigint)
    keys = [f"hil-case-{tag}-{c['case_id']}" for c in cases]
    by_key = dict(zip(keys, cases, strict=True))
    handled: set[str] = set()

    def take(fut: Any) -> None:
        handled.add(fut.key)
        try:
            handle(fut.result())
        except Exception as exc:  # noqa: BLE001 - KilledWorker (the worker died) or what the case raised
            end = "worker died" if type(exc).__name__ == "KilledWorker" else "case error"
            handle(failure(by_key[fut.key], end, f"{type(exc).__name__}: {exc}"))

    try:
        futures = client.map(case_fn, cases, key=keys, pure=False)
        try:
            for fut in as_completed(futures):
                take(fut)
        except KeyboardInterrupt:
            stop_file.touch()
            running = set(itertools.chain.from_iterable(client.processing().values()))
            rest = [f for f in futures if f.key not in handled]
            queued = [f for f in rest if not f.done() and f.key not in running]
            client.cancel(queued)
            finishing = [f for f in rest if f not in queued]
            try:
                wait(finishing, timeout=_STOP_WAIT_S)
            except (KeyboardInterrupt, TimeoutError):
                pass
            for f in finishing:
                if f.done():
                    take(f)
            return True, len(rest) - sum(1 for f in rest if f.key in handled)
        return False, 0
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


# ---- running and summarising --------------------------------------------------------------------
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


def _campaign_dir(out: Path, name: str) -> Path:
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
    case_fn: CaseFn = run_case,
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
    cdir = _campaign_dir(out_dir or campaign.out_dir, campaign.name)
    shutil.copyfile(campaign.path, cdir / "campaign.toml")
    cases = campaign.cases(cdir, keep_logs=keep_logs)
    where = f"dask {scheduler}" if scheduler else f"dask LocalCluster x{n_workers} (TLS)" if use_dask else f"process pool x{n_workers}"
    out.print(f"campaign {campaign.name}: {len(cases)} cases on {where} -> {cdir}", highlight=False, soft_wrap=True)
    results: list[dict[str, Any]] = []
    t0 = clock.monotonic_ns()
    with (cdir / "results.jsonl").open("a") as jsonl:

        def handle(result: dict[str, Any]) -> None:
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
            interrupted, cancelled = _run_dask(cases, n_workers, scheduler, case_fn, handle, stop_file, cdir.name)
        else:
            interrupted, cancelled = _run_pool(cases, n_workers, case_fn, handle, stop_file)
    summary = summarize(results, campaign=campaign, cases=len(cases), interrupted=interrupted, cancelled=cancelled,
                        executor=where, wall_s=(clock.monotonic_ns() - t0) / 1e9, directory=cdir)
    (cdir / "summary.json").write_text(json.dumps(finite(summary), indent=1, allow_nan=False))
    (cdir / "STOP").unlink(missing_ok=True)
    print_summary(out, summary)
    return CampaignRun(cdir, results, summary)


def _median(values: list[Any]) -> float | None:
    xs = [float(v) for v in values if isinstance(v, (int, float)) and math.isfinite(v)]
    return statistics.median(xs) if xs else None


def _cpu_s(timing: dict[str, Any]) -> float | None:
    """CPU-seconds of a flight's tick loop: the cores it kept busy times its wall time."""
    cores, wall_s = timing.get("cores_used"), timing.get("wall_s")
    return cores * wall_s if isinstance(cores, (int, float)) and isinstance(wall_s, (int, float)) else None


def _badness(c: dict[str, Any]) -> tuple[int, float]:
    """Sort key, larger = worse: failed first, then the value pushed towards its bound."""
    v = c.get("value")
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return (1, math.inf)
    lower_only = ">=" in str(c.get("bound", "")) and "<=" not in str(c.get("bound", ""))
    return (0 if c.get("passed") else 1, -float(v) if lower_only else float(v))


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
                                        "case_id": r["case_id"]}
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
            line = f"{chr(10) if i else ''}{c}: {_fmt(w['value'])} {w['bound']} ({w['case_id']})"
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


__all__ = ["Campaign", "CampaignRun", "KeepLogs", "default_workers", "load_campaign", "outcome", "run_campaign",
           "run_case", "summarize"]
