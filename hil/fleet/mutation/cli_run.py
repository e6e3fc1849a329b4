"""What ``hil mutate`` does once its options are parsed (hil/fleet/mutation/command.py)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from rich.console import Console

from hil import clock
from hil.config import ConfigError
from hil.fleet.campaign import campaign_dir
from hil.fleet.campaign_case import finite
from hil.fleet.mutation import operators
from hil.fleet.mutation import report as rep
from hil.fleet.mutation.catalogue import load_catalogue, load_equivalents
from hil.fleet.mutation.edits import context
from hil.fleet.mutation.runner import (
    BaselineFailed,
    Plan,
    catalogue_mutants,
    diffs,
    load_suite,
    operator_mutants,
    rig_files,
    run_baseline,
    run_mutants,
    tree_files,
    where,
)

_MODES = ("lockstep", "realtime")
_EXECUTORS = ("auto", "dask", "process")


def _plan(o: dict[str, Any]) -> tuple[Plan, dict[str, str], str]:
    if o["mode"] not in _MODES:
        raise ConfigError(f"--mode: {o['mode']!r} is not one of {', '.join(_MODES)}")
    if o["executor"] not in _EXECUTORS:
        raise ConfigError(f"--executor: {o['executor']!r} is not one of {', '.join(_EXECUTORS)}")
    if o["seeds"] < 1:
        raise ConfigError("--seeds: must be >= 1")
    for key in ("min_score", "min_operator_score"):
        if not 0.0 <= o[key] <= 1.0:
            raise ConfigError(f"--{key.replace('_', '-')}: must be in 0..1")
    cat_path: Path = o["catalogue"]
    cat = load_catalogue(cat_path)
    tree = o["tree"] or Path(cat.target.tree)
    suite = load_suite(o["rig"], o["scenarios"] or [Path("rigs/scenarios")], o["exclude"] or [])
    mutants = [] if o["no_catalogue"] else catalogue_mutants(cat, o["only"])
    mutants += operator_mutants(tree, cat.target.operator_modules, o["operators"], o["operator_seed"])
    if not mutants:
        raise ConfigError("no mutants to fly")
    eq_path = o["equivalents"] or cat_path.with_name(f"{cat_path.stem}-equivalents.toml")
    eq = load_equivalents(eq_path, {m.id for m in mutants} | {m.id for m in cat.mutant},
                          lambda: {site.id for site in operators.sites(tree, cat.target.operator_modules)})
    plan = Plan(suite, tree, mutants, list(range(1, o["seeds"] + 1)), mode=o["mode"], matrix=o["matrix"],
                keep_kills=o["keep_kills"], workers=o["workers"], scheduler=o["scheduler"], executor=o["executor"],
                context=context(Path("."), cat.target.context, what=str(cat_path)))
    return plan, eq, cat.target.name


def _progress(out: Console, total: int, label: str, jsonl: Path):  # noqa: ANN202 - a closure
    done = [0]

    def show(r: dict[str, Any]) -> None:
        done[0] += 1
        with jsonl.open("a") as f:  # streamed: an interrupted campaign keeps what it flew
            f.write(json.dumps(finite({**r, "runs": [{k: v for k, v in x.items() if k != "mcap"} for x in r["runs"]]}),
                               allow_nan=False) + "\n")
        failed = [x for x in r["runs"] if not x["passed"]]
        if failed:
            f = failed[0]
            what = f"KILLED by {f['scenario']}: {', '.join(f['failed']) or f['end_reason']}" if label == "mutant" \
                else f"FAIL {f['scenario']} seed {f['seed']}: {', '.join(f['failed']) or f['end_reason']}"
        else:
            what = "survived" if label == "mutant" else "pass"
        out.print(f"[{label} {done[0]}/{total}] {r['mutant'] if label == 'mutant' else r['case_id']} {what} "
                  f"({len(r['runs'])} flights, {r['wall_s']:.0f} s)", highlight=False, markup=False)
    return show


def run(o: dict[str, Any], console: Console | None = None) -> int:
    out = console or Console()
    try:
        plan, eq, name = _plan(o)
        files, rig = tree_files(plan), rig_files(plan.suite.rig)
        all_diffs = diffs(plan, files)
    except ConfigError as exc:
        out.print(f"error: {exc}", highlight=False, markup=False)
        return 2
    cdir = campaign_dir(o["out"], f"mutate-{name}")
    stop_file = cdir / "STOP"
    out.print(f"hil mutate {name}: {len(plan.mutants)} mutants x {len(plan.suite.scenarios)} scenarios "
              f"(excluded: {', '.join(plan.suite.excluded) or 'none'}) on {where(plan)} -> {cdir}", highlight=False)
    t0 = clock.monotonic_ns()
    try:
        n_base = len(plan.suite.scenarios) * len(plan.seeds)
        base = run_baseline(plan, files, rig, stop_file, _progress(out, n_base, "baseline", cdir / "baseline.jsonl"))
        base_wall = (clock.monotonic_ns() - t0) / 1e9
        results, interrupted = run_mutants(plan, files, rig, stop_file, _progress(out, len(plan.mutants), "mutant", cdir / "mutants.jsonl"))
    except BaselineFailed as exc:
        out.print(f"[red]baseline failed, no mutant flown:[/] {exc}", highlight=False)
        (cdir / "baseline-failures.json").write_text(json.dumps(finite(
            [{k: v for k, v in r.items() if k != "mcap"} for r in exc.failures]), indent=1))
        return 2
    except KeyboardInterrupt:
        out.print("interrupted")
        return 130
    finally:
        stop_file.unlink(missing_ok=True)
    kills = cdir / "kills"
    for r in results:
        for run_ in r["runs"]:
            if run_.get("mcap"):
                kills.mkdir(exist_ok=True)
                (kills / f"{r['mutant']}-{run_['scenario']}-s{run_['seed']}.mcap").write_bytes(run_["mcap"])
            run_.pop("mcap", None)
    meta = {"rig": str(plan.suite.rig), "tree": str(plan.tree), "catalogue": str(o["catalogue"]),
            "scenarios_excluded": plan.suite.excluded, "baseline_seeds": plan.seeds,
            "baseline_flights": sum(len(b["runs"]) for b in base), "baseline_wall_s": base_wall,
            "mutant_seed": plan.seeds[0], "matrix": plan.matrix, "executor": where(plan), "mode": plan.mode,
            "wall_s": (clock.monotonic_ns() - t0) / 1e9, "interrupted": interrupted,
            "operators": o["operators"], "operator_seed": o["operator_seed"]}
    report = rep.build(plan.mutants, {r["mutant"]: r for r in results}, all_diffs, eq,
                       [s.stem for s in plan.suite.scenarios], meta)
    report["targets"] = rep.targets(report, o["min_score"], o["min_operator_score"])
    rep.write_json(report, cdir / "report.json")
    rep.plot_heatmap(report, cdir / "heatmap.png")
    rep.print_report(out, report)
    out.print(f"report: {cdir / 'report.json'}, {cdir / 'heatmap.png'}; wall {meta['wall_s']:.0f} s", highlight=False)
    if interrupted:
        return 130
    return rep.exit_code(report, o["min_score"], o["min_operator_score"])
