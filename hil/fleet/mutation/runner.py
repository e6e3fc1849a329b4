"""A mutation campaign: the unmodified flight code first (every scenario x N seeds), then the
mutants, each from its own copy, on the campaign executors (Dask or a process pool).

A baseline run that fails stops the campaign (:class:`BaselineFailed`): a suite with false
alarms cannot score mutants.
"""

from __future__ import annotations

import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from hil.config import ConfigError
from hil.fleet.campaign_executors import dask_available, default_workers, run_dask, run_pool
from hil.fleet.mutation import operators
from hil.fleet.mutation.catalogue import Catalogue
from hil.fleet.mutation.edits import Edit, diff, edited, snapshot
from hil.fleet.mutation.worker import run_mutant

Executor = Literal["auto", "dask", "process"]


@dataclass(frozen=True)
class MutantSpec:
    """A mutant to fly: its edits and what the report says about it."""

    id: str
    origin: Literal["catalogue", "operator"]
    layer: str
    kind: str
    effect: str
    edits: tuple[Edit, ...]
    compute_only: bool = False


@dataclass
class Suite:
    """The rig and the scenarios (shortest first: a mutant's first kill comes sooner)."""

    rig: Path
    scenarios: list[Path]
    excluded: list[str] = field(default_factory=list)


class BaselineFailed(Exception):
    """The unmodified flight code failed a scenario: ``failures`` are the failed runs."""

    def __init__(self, failures: list[dict[str, Any]]) -> None:
        self.failures = failures
        names = ", ".join(f"{r['scenario']} seed {r['seed']} ({', '.join(r['failed']) or r['end_reason']})"
                          for r in failures)
        super().__init__(f"the unmodified flight code failed: {names}")


def _duration_s(path: Path) -> float:
    try:
        with path.open("rb") as f:
            return float(tomllib.load(f).get("scenario", {}).get("duration_s", 0.0))
    except (OSError, tomllib.TOMLDecodeError, TypeError, ValueError) as exc:
        raise ConfigError(f"{path}: cannot read the scenario: {exc}") from exc


def load_suite(rig: Path, scenarios: list[Path], exclude: list[str]) -> Suite:
    """Scenario files (directories expand to their *.toml), minus ``exclude`` (names)."""
    files: list[Path] = []
    for s in scenarios:
        files.extend(sorted(s.glob("*.toml")) if s.is_dir() else [s])
    missing = [f for f in files if not f.is_file()]
    if missing:
        raise ConfigError(f"{missing[0]}: no such scenario")
    unknown = sorted(set(exclude) - {f.stem for f in files})
    if unknown:
        raise ConfigError(f"--exclude: no such scenario in the suite: {', '.join(unknown)}")
    kept = [f for f in files if f.stem not in exclude]
    if not kept:
        raise ConfigError("the suite is empty")
    if not rig.is_file():
        raise ConfigError(f"{rig}: no such rig")
    return Suite(rig, sorted(kept, key=lambda f: (_duration_s(f), f.stem)), sorted(exclude))


def rig_files(rig: Path) -> dict[str, bytes]:
    """The rig file and the flight-config template it names (both travel to the workers)."""
    with rig.open("rb") as f:
        data = tomllib.load(f)
    out = {rig.name: rig.read_bytes()}
    config = data.get("flight", {}).get("config")
    if config:
        p = Path(config) if Path(config).is_absolute() else rig.parent / config
        if not p.is_file():
            raise ConfigError(f"{rig}: flight.config: no such file {p}")
        if Path(config).is_absolute() or "/" in config:
            raise ConfigError(f"{rig}: flight.config: must be a file beside the rig for `hil mutate`")
        out[p.name] = p.read_bytes()
    return out


def catalogue_mutants(cat: Catalogue, only: list[str] | None = None) -> list[MutantSpec]:
    known = {m.id for m in cat.mutant}
    if only:
        unknown = sorted(set(only) - known)
        if unknown:
            raise ConfigError(f"--only: no such mutant: {', '.join(unknown)}")
    return [MutantSpec(m.id, "catalogue", m.layer, m.kind, m.effect, (Edit(m.file, m.old, m.new),), m.compute_only)
            for m in cat.mutant if not only or m.id in only]


def operator_mutants(tree: Path, modules: tuple[str, ...], n: int, seed: int) -> list[MutantSpec]:
    """``n`` cosmic-ray operator mutants drawn by ``seed`` (sites that mutate nothing skipped)."""
    if n <= 0:
        return []
    out: list[MutantSpec] = []
    all_sites = operators.sites(tree, modules)
    for site in operators.draw(all_sites, len(all_sites), seed):
        edit = operators.edit_for(tree, site)
        if edit is not None:
            layer = site.file.split("/")[0].removesuffix(".py")
            out.append(MutantSpec(site.id, "operator", layer, site.operator, f"cosmic-ray {site.operator}",
                                  (edit,)))
        if len(out) == n:
            break
    return out


@dataclass
class Plan:
    """What to fly and how."""

    suite: Suite
    tree: Path
    mutants: list[MutantSpec]
    seeds: list[int]
    mode: str = "lockstep"
    matrix: bool = False
    keep_kills: bool = False
    workers: int | None = None
    scheduler: str | None = None
    executor: Executor = "auto"
    timeout_factor: float = 10.0
    #: project files the tree's build needs (``[target] context``): path -> bytes, unmutated
    context: dict[str, bytes] = field(default_factory=dict)


def _task(plan: Plan, files: dict[str, bytes], rig: dict[str, bytes], case_id: str, mutant: str,
          scenarios: list[Path], seeds: list[int], first_kill: bool, stop_file: Path) -> dict[str, Any]:
    longest = max(_duration_s(s) for s in scenarios)
    return {"case_id": case_id, "mutant": mutant, "tree_name": plan.tree.name, "files": files,
            "context_files": plan.context,
            "rig_name": plan.suite.rig.name, "rig_files": rig,
            "scenarios": [{"name": s.stem, "text": s.read_bytes()} for s in scenarios], "seeds": seeds,
            "stop_at_first_kill": first_kill, "keep_kills": plan.keep_kills, "mode": plan.mode,
            "timeout_s": 120.0 + plan.timeout_factor * longest, "stop_file": str(stop_file),
            # what the executors' failure() reads when a task is lost
            "scenario_name": ",".join(s.stem for s in scenarios), "seed": seeds[0],
            "flight_overrides": {}, "rig_overrides": {}}


def _lost(result: dict[str, Any]) -> dict[str, Any]:
    """A task the executor lost (its worker died): one errored run, never a kill."""
    if "runs" in result:
        return result
    return {"case_id": result["case_id"], "mutant": result["case_id"], "wall_s": result.get("wall_s"),
            "runs": [{"scenario": result.get("scenario"), "seed": result.get("seed"), "passed": False,
                      "end_reason": result.get("end_reason", "worker died"), "message": result.get("message", ""),
                      "failed": [], "criteria": [], "wall_s": None, "output_tail": [], "mcap": None}]}


def execute(plan: Plan, tasks: list[dict[str, Any]], on_result: Callable[[dict[str, Any]], None],
            stop_file: Path, tag: str) -> bool:
    """Run the tasks; hand each result on. Returns True if interrupted."""
    n = plan.workers or default_workers()
    use_dask = plan.executor == "dask" or bool(plan.scheduler) or (plan.executor == "auto" and dask_available())
    if use_dask and not dask_available():
        raise ConfigError("Dask is not installed: pip install 'mav-hil-bench[campaign]' (or --executor process)")

    def handle(result: dict[str, Any]) -> None:
        on_result(_lost(result))

    if use_dask:
        interrupted, _ = run_dask(tasks, n, plan.scheduler, run_mutant, handle, stop_file, tag)
    else:
        interrupted, _ = run_pool(tasks, n, run_mutant, handle, stop_file)
    return interrupted


def where(plan: Plan) -> str:
    n = plan.workers or default_workers()
    use_dask = plan.executor == "dask" or bool(plan.scheduler) or (plan.executor == "auto" and dask_available())
    return f"dask {plan.scheduler}" if plan.scheduler else f"dask LocalCluster x{n}" if use_dask else f"process pool x{n}"


def run_baseline(plan: Plan, files: dict[str, bytes], rig: dict[str, bytes], stop_file: Path,
                 on_result: Callable[[dict[str, Any]], None]) -> list[dict[str, Any]]:
    """Every scenario x seed on the unmodified tree; BaselineFailed names the failures."""
    tasks = [_task(plan, files, rig, f"baseline-{s.stem}-s{seed}", "baseline", [s], [seed], False, stop_file)
             for s in plan.suite.scenarios for seed in plan.seeds]
    results: list[dict[str, Any]] = []

    def take(r: dict[str, Any]) -> None:
        results.append(r)
        on_result(r)

    if execute(plan, tasks, take, stop_file, "baseline"):
        raise KeyboardInterrupt
    failures = [run for r in results for run in r["runs"] if not run["passed"]]
    if failures:
        raise BaselineFailed(failures)
    return results


def run_mutants(plan: Plan, files: dict[str, bytes], rig: dict[str, bytes], stop_file: Path,
                on_result: Callable[[dict[str, Any]], None]) -> tuple[list[dict[str, Any]], bool]:
    """Each mutant on the suite (first seed), stopping at its first kill unless ``plan.matrix``."""
    tasks = []
    for m in plan.mutants:
        mutated = edited(files, list(m.edits), what=m.id)
        tasks.append(_task(plan, mutated, rig, m.id, m.id, plan.suite.scenarios, plan.seeds[:1], not plan.matrix,
                           stop_file))
    results: list[dict[str, Any]] = []

    def take(r: dict[str, Any]) -> None:
        results.append(r)
        on_result(r)

    interrupted = execute(plan, tasks, take, stop_file, "mutants")
    return results, interrupted


def diffs(plan: Plan, files: dict[str, bytes]) -> dict[str, str]:
    return {m.id: diff(files, list(m.edits), plan.tree.name) for m in plan.mutants}


def tree_files(plan: Plan) -> dict[str, bytes]:
    return snapshot(plan.tree)
