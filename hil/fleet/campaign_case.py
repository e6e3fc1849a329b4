"""One campaign case, isolated in its own process.

``run_case(params) -> dict`` is the unit of work of ``hil campaign`` (hil/fleet/campaign.py): a
plain, picklable function that any executor can run (Dask worker, process pool, a loop). It
starts ``python -m hil.fleet.campaign_case <case dir>/params.json`` and waits for it, so a crash of
the bench or of anything it loads (a segfault, ``os._exit``, a SIGKILL) ends that case as a
failure and never takes the worker down. The child builds the case's rig and scenario (the
sweep's overrides merged in), flies it with :func:`hil.flight.run.run_flight_async` and writes
``result.json``; the parent reads it, or reports the crash.

``params`` (all JSON): ``case_id``, ``rig`` and ``scenario`` (absolute paths), ``seed``,
``mode``, ``duration_s`` (None = the scenario's), ``flight_overrides`` and ``rig_overrides``
(dotted key -> value), ``case_dir``, ``log_path``, ``keep_logs`` (all | failed | none),
``timeout_s`` (wall seconds for the whole case), ``stop_file`` (the campaign's stop flag:
once it exists the case is interrupted, its log finalized), ``cwd`` (for the flight command),
``tmpdir`` (optional: the case process's TMPDIR, so that what a killed case leaves there goes
with its caller's directory).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import os
import shutil
import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import tomli_w

from hil import clock

#: how often the parent checks the stop flag and the timeout while the case runs
_POLL_S = 0.2
#: after SIGINT/SIGTERM a case has this long to finalize its log before SIGKILL
_GRACE_S = 20.0
RESULT_FILE = "result.json"
#: the fields of a result that no run filled
_EMPTY: dict[str, Any] = {"passed": False, "criteria": [], "timing": {}, "sim_s": 0.0, "flight_returncode": None,
                          "log": None}
OUTPUT_FILE = "output.txt"


def nested(dotted: dict[str, Any]) -> dict[str, Any]:
    """``{"a.b": 1}`` -> ``{"a": {"b": 1}}``."""
    out: dict[str, Any] = {}
    for key, value in dotted.items():
        node = out
        *parents, leaf = key.split(".")
        for p in parents:
            node = node.setdefault(p, {})
        node[leaf] = value
    return out


def finite(value: Any) -> Any:
    """JSON-safe: non-finite floats -> None, recursively."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    return value


# ---- worker side ------------------------------------------------------------------------------
def run_case(params: dict[str, Any]) -> dict[str, Any]:
    """Run one case in a subprocess; always returns its result dict (see hil/fleet/campaign.py)."""
    t0 = clock.monotonic_ns()
    stop_file = params.get("stop_file")
    if stop_file and os.path.exists(stop_file):  # queued when the campaign was stopped
        return {**_identity(params), **_EMPTY, "end_reason": "cancelled", "message": "the campaign was stopped",
                "returncode": None, "wall_s": 0.0}
    case_dir = Path(params["case_dir"])
    case_dir.mkdir(parents=True, exist_ok=True)
    params_path = case_dir / "params.json"
    params_path.write_text(json.dumps(params, indent=1))
    result_path = case_dir / RESULT_FILE
    result_path.unlink(missing_ok=True)
    cwd = params.get("cwd")
    env = dict(os.environ, TMPDIR=params["tmpdir"]) if params.get("tmpdir") else None
    with (case_dir / OUTPUT_FILE).open("wb") as out:
        proc = subprocess.Popen(
            [sys.executable, "-m", "hil.fleet.campaign_case", str(params_path)],
            stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT, env=env,
            cwd=cwd if cwd and Path(cwd).is_dir() else None,
            start_new_session=True,  # a terminal Ctrl-C reaches the campaign, which stops cases itself
        )
        returncode, why = _wait(proc, float(params.get("timeout_s") or 0), stop_file)
    result = _read_result(result_path)
    if result is None:
        result = _crashed(params, returncode, why, case_dir / OUTPUT_FILE)
    elif why:
        result["message"] = f"{why}; {result.get('message', '')}".rstrip("; ")
    result["returncode"] = returncode
    result["wall_s"] = (clock.monotonic_ns() - t0) / 1e9
    _keep(params, result, case_dir)
    return result


def _wait(proc: subprocess.Popen[bytes], timeout_s: float, stop_file: str | None) -> tuple[int, str]:
    """Wait for the case; on the stop flag SIGINT it, on timeout SIGTERM it; SIGKILL after a grace."""
    start = clock.monotonic_ns()
    signalled_ns = 0
    why = ""
    while True:
        try:
            return proc.wait(timeout=_POLL_S), why
        except subprocess.TimeoutExpired:
            pass
        now = clock.monotonic_ns()
        if signalled_ns:
            if now - signalled_ns > _GRACE_S * 1e9:
                proc.kill()
                why += "; killed after the grace period"
                return proc.wait(), why
        elif stop_file and os.path.exists(stop_file):
            why = "interrupted by the campaign"
            proc.send_signal(signal.SIGINT)
            signalled_ns = now
        elif timeout_s > 0 and now - start > timeout_s * 1e9:
            why = f"case timeout ({timeout_s:g} s wall)"
            proc.send_signal(signal.SIGTERM)
            signalled_ns = now


def _read_result(path: Path) -> dict[str, Any] | None:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _tail(path: Path, n: int = 12) -> list[str]:
    try:
        return path.read_text(errors="replace").splitlines()[-n:]
    except OSError:
        return []


def _crashed(params: dict[str, Any], returncode: int, why: str, output: Path) -> dict[str, Any]:
    status = f"signal {-returncode}" if returncode < 0 else f"status {returncode}"
    log = Path(params["log_path"])
    part = log.with_name(log.name + ".part")
    return {
        **_identity(params), **_EMPTY, "end_reason": "interrupted" if why.startswith("interrupted") else "case crashed",
        "message": f"the case process ended with {status} without a result" + (f" ({why})" if why else ""),
        "log": str(log) if log.exists() else str(part) if part.exists() else None,
        "output_tail": _tail(output),
    }


def _keep(params: dict[str, Any], result: dict[str, Any], case_dir: Path) -> None:
    """Apply keep_logs to the MCAP; keep the case directory (params, output) of failures only."""
    keep = params.get("keep_logs", "failed")
    passed = bool(result.get("passed"))
    log = result.get("log")
    if log and (keep == "none" or (keep == "failed" and passed)):
        Path(log).unlink(missing_ok=True)
        result["log"] = None
    if passed:
        shutil.rmtree(case_dir, ignore_errors=True)
    else:
        result["case_dir"] = str(case_dir)


def _identity(params: dict[str, Any]) -> dict[str, Any]:
    return {"case_id": params["case_id"], "scenario": params.get("scenario_name", Path(params["scenario"]).stem),
            "seed": params["seed"], "overrides": {**{f"flight.{k}": v for k, v in params["flight_overrides"].items()},
                                                 **{f"rig.{k}": v for k, v in params["rig_overrides"].items()}}}


# ---- child side ---------------------------------------------------------------------------------
def _case_files(params: dict[str, Any], case_dir: Path) -> tuple[Path, Path]:
    """The rig and scenario files of this case: the originals, or copies with the overrides."""
    from hil.config import load_toml
    from hil.flight.run import deep_merge

    rig, scenario = Path(params["rig"]), Path(params["scenario"])
    if params["rig_overrides"]:
        data = deep_merge(load_toml(rig), nested(params["rig_overrides"]))
        flight = dict(data.get("flight", {}))
        template = Path(str(flight.get("config", "flightcode-paper-quad.toml")))
        flight["config"] = str(template if template.is_absolute() else (rig.parent / template).resolve())
        data["flight"] = flight
        rig = case_dir / rig.name  # same name: the log's attachment is found by it (hil.fleet.verify.verify)
        rig.write_text(tomli_w.dumps(data))
    if params["flight_overrides"]:
        data = load_toml(scenario)
        data["flight"] = deep_merge(data.get("flight", {}), nested(params["flight_overrides"]))
        scenario = case_dir / scenario.name
        scenario.write_text(tomli_w.dumps(data))
    return rig, scenario


async def _watch_stop(stop_file: str | None, stop: Callable[[], None]) -> None:
    if not stop_file:
        return
    while not os.path.exists(stop_file):
        await asyncio.sleep(_POLL_S)
    stop()


async def _fly(params: dict[str, Any]) -> dict[str, Any]:
    from hil.flight.tickloop import Mode
    from hil.config.rig import load_rig
    from hil.flight.run import run_flight_async
    from hil.config.scenario import load_scenario

    case_dir = Path(params["case_dir"])
    rig_path, scenario_path = _case_files(params, case_dir)
    rig, scenario = load_rig(rig_path), load_scenario(scenario_path)
    log_path = Path(params["log_path"])
    task = asyncio.current_task()
    loop = asyncio.get_running_loop()
    assert task is not None
    stopping: list[bool] = []

    def stop() -> None:  # once: a second cancel would interrupt the run's own clean-up
        if not stopping:
            stopping.append(True)
            task.cancel()

    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop)
    # The stop flag is watched here too, not only by run_case: if the worker that started this
    # process died (a Ctrl-C in the terminal reaches a LocalCluster's workers), nobody else would.
    watcher = asyncio.create_task(_watch_stop(params.get("stop_file"), stop))
    # keep_logs = "none" would delete the MCAP whatever the verdict: do not write it. The
    # recorder is about a fifth of a flight's CPU (docs/performance.md, Campaign throughput).
    record = params.get("keep_logs", "failed") != "none"
    try:
        result = await run_flight_async(
            rig, scenario, mode=Mode(params["mode"]), seed=int(params["seed"]), duration_s=params.get("duration_s"),
            out_dir=log_path.parent, log_path=log_path, scenario_source=scenario_path, record=record)
    finally:
        watcher.cancel()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(sig)
    return {
        **_identity(params), "passed": result.passed, "end_reason": result.end_reason.value,
        "message": result.message,
        "criteria": [{"name": c.name, "signal": c.signal, "metric": c.metric, "value": c.value, "bound": c.bound,
                      "passed": c.passed,
                      "margin": c.margin if math.isfinite(c.margin) else None, "detail": c.detail} for c in result.criteria],
        "timing": result.timing, "sim_s": result.sim_s, "flight_returncode": result.flight_returncode,
        "log": str(result.log_path) if result.log_path else None,
        "output_tail": [] if result.passed else list(result.flight_stderr_tail)[-8:],
    }


def main(argv: list[str] | None = None) -> int:
    """``python -m hil.fleet.campaign_case PARAMS.json``: 0 passed, 1 failed, 2 bad case."""
    from hil.config import ConfigError

    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m hil.fleet.campaign_case PARAMS.json", file=sys.stderr)
        return 2
    params = json.loads(Path(args[0]).read_text())
    try:
        result = asyncio.run(_fly(params))
        code = 0 if result["passed"] else 1
    except ConfigError as exc:
        result = {**_identity(params), **_EMPTY, "end_reason": "config error", "message": str(exc)}
        code = 2
    out = Path(params["case_dir"]) / RESULT_FILE
    tmp = out.with_suffix(".tmp")
    tmp.write_text(json.dumps(finite(result), indent=1, allow_nan=False))
    os.replace(tmp, out)  # the parent never sees half a result
    with contextlib.suppress(OSError):
        sys.stdout.flush()
    return code


if __name__ == "__main__":
    sys.exit(main())
