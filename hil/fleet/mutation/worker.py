"""One mutant flown on a campaign worker, from its own temporary copy of the source tree.

``run_mutant(task) -> dict`` is a picklable unit of work for any executor (Dask worker,
process pool). Everything it needs travels in ``task`` (the edited tree, the rig's files, the
scenarios), so workers share no filesystem with the client; the verdicts, and on request the
MCAP of a failed run, come back in the result. The temporary directory is removed whatever
happens. Each scenario is one :func:`hil.fleet.campaign_case.run_case` (its own process) with
the working directory at the copy, so the rig's ``[flight] command`` runs the mutant.

``task`` keys: ``case_id``, ``mutant``, ``tree_name``, ``files`` (relative path -> bytes, the
edits applied), ``context_files`` (project-relative path -> bytes, beside the tree), ``rig_name``, ``rig_files`` (name -> bytes: the rig and the files beside it it
names), ``scenarios`` (list of {name, text}), ``seeds``, ``stop_at_first_kill``,
``keep_kills``, ``mode``, ``timeout_s`` (per flight), ``stop_file``.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import Any

from hil import clock
from hil.fleet.campaign_case import run_case
from hil.fleet.mutation.edits import materialize

#: the prefix of every temporary directory a mutant flies from (tests check none is left)
TMP_PREFIX = "hil-mutant-"


def _case_params(task: dict[str, Any], root: Path, scenario: str, seed: int) -> dict[str, Any]:
    cid = f"{scenario}-s{seed}"
    return {
        "case_id": cid, "rig": str(root / "rig" / task["rig_name"]),
        "scenario": str(root / "scenarios" / f"{scenario}.toml"), "scenario_name": scenario, "seed": seed,
        "mode": task["mode"], "duration_s": None, "flight_overrides": {}, "rig_overrides": {},
        "case_dir": str(root / "cases" / cid), "log_path": str(root / "logs" / f"{cid}.mcap"),
        "keep_logs": "failed" if task["keep_kills"] else "none", "timeout_s": task["timeout_s"],
        "stop_file": task.get("stop_file"), "cwd": str(root / "src"),
    }


def _run(result: dict[str, Any], keep: bool) -> dict[str, Any]:
    """The part of a case's result the report needs (and the MCAP bytes of a kept kill)."""
    failed = [c["name"] for c in result.get("criteria", []) if not c.get("passed")]
    run = {"scenario": result["scenario"], "seed": result["seed"], "passed": bool(result.get("passed")),
           "end_reason": result.get("end_reason"), "message": result.get("message", ""), "failed": failed,
           "criteria": result.get("criteria", []), "wall_s": result.get("wall_s"),
           "output_tail": result.get("output_tail", [])[-6:], "mcap": None}
    log = result.get("log")
    if keep and not run["passed"] and log and Path(log).is_file():
        run["mcap"] = Path(log).read_bytes()
    return run


def run_mutant(task: dict[str, Any]) -> dict[str, Any]:
    """Fly ``task``'s scenarios x seeds against its tree; stop at the first kill if asked."""
    t0 = clock.monotonic_ns()
    root = Path(tempfile.mkdtemp(prefix=TMP_PREFIX))
    runs: list[dict[str, Any]] = []
    try:
        materialize(task["files"], root / "src" / task["tree_name"])
        materialize(task.get("context_files", {}), root / "src")
        materialize(task["rig_files"], root / "rig")
        materialize({f"{s['name']}.toml": s["text"] for s in task["scenarios"]}, root / "scenarios")
        for s in task["scenarios"]:
            for seed in task["seeds"]:
                run = _run(run_case(_case_params(task, root, s["name"], seed)), bool(task["keep_kills"]))
                runs.append(run)
                if not run["passed"] and task["stop_at_first_kill"]:
                    break
            if runs and not runs[-1]["passed"] and task["stop_at_first_kill"]:
                break
    finally:
        shutil.rmtree(root, ignore_errors=True)
    return {"case_id": task["case_id"], "mutant": task["mutant"], "runs": runs,
            "wall_s": (clock.monotonic_ns() - t0) / 1e9}
