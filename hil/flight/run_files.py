"""What a run writes besides its signals: the flight code's config (the rig's template with
the rig's and the scenario's overrides, pointing at the run's ports), the log's default name,
and the log's metadata - ``run`` when recording starts, ``verdict`` when it ends.

Every metadata value is a string (MCAP metadata); figures and lists inside are JSON.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import tomli_w

from hil import __version__, clock, native
from hil.analysis.criteria import CriterionResult
from hil.config import load_toml
from hil.config.rig import Rig
from hil.config.scenario import Scenario
from hil.flight.tickloop import Clock, EndReason, Mode
from hil.host.cpulatency import CpuLatency
from hil.host.rtsched import RtScheduling
from hil.transport.base import Port
from hil.vtime.session import ShimUsage


def deep_merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """``base`` with ``over`` laid on it, tables merged key by key (neither is changed)."""
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = deep_merge(out[key], value)
        else:
            out[key] = value
    return out


def write_flight_config(rig: Rig, scenario: Scenario, ports: Mapping[str, Port], run_dir: Path) -> Path:
    """The flight code's own config, from the rig's template, pointing at the symlinks."""
    template_path = rig.flight_config_path
    config = load_toml(template_path)
    config = deep_merge(config, rig.flight.overrides)
    config = deep_merge(config, scenario.flight)
    port_table = dict(config.get("ports", {}))
    for name in ("imu", "adc", "rc", "esc", "telemetry"):
        entry = dict(port_table.get(name, {}))
        client_path = ports[name].client_path  # None: a real line whose far end the template names
        if client_path is not None:
            entry["path"] = client_path
        # A template that names a baud keeps it (a wrong one is a test of the flight code);
        # otherwise the device's own line rate from the rig.
        entry.setdefault("baud", rig.device_baud(name))
        port_table[name] = entry
    config["ports"] = port_table
    path = run_dir / "flight.toml"
    path.write_text(tomli_w.dumps(config))
    return path


def default_log_path(out_dir: Path, rig: Rig, scenario: Scenario, seed: int) -> Path:
    """``<out_dir>/<UTC start, to the second>_<rig>_<scenario>_s<seed>.mcap``."""
    stamp = clock.wall_ns()
    import datetime

    utc = datetime.datetime.fromtimestamp(stamp / 1e9, tz=datetime.UTC).strftime("%Y%m%dT%H%M%S")
    return out_dir / f"{utc}_{rig.name}_{scenario.name}_s{seed}.mcap"


def run_metadata(rig: Rig, scenario: Scenario, seed: int, mode: Mode, duration_ns: int) -> dict[str, str]:
    """The log's ``run`` metadata: what was flown, on what bench and host (``git_sha`` of the
    bench's own checkout, ``unknown`` outside one)."""
    import platform
    import subprocess

    try:
        sha = subprocess.run(
            ["git", "rev-parse", "HEAD"], capture_output=True, text=True, cwd=Path(__file__).parent, timeout=5
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain"], capture_output=True, text=True, cwd=Path(__file__).parent, timeout=5
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        sha, dirty = "", ""
    return {
        "rig": rig.name,
        "rig_file": str(rig.path),
        "scenario": scenario.name,
        "seed": str(seed),
        "mode": mode.value,
        "duration_s": f"{duration_ns / 1e9:g}",
        "tick_ns": str(rig.tick_ns),
        "bench_version": __version__,
        "git_sha": sha or "unknown",
        "git_dirty": str(bool(dirty)).lower(),
        "python": platform.python_version(),
        "host": platform.node(),
        "device_models": native.describe(),
    }


def verdict_metadata(end: EndReason, criteria: list[CriterionResult], message: str, returncode: int | None,
                     timing: dict[str, float], *, clock_used: Clock, clock_note: str,
                     rt_scheduling: RtScheduling | None, cpu_latency: CpuLatency | None, cpu_scale: float,
                     shim: ShimUsage | None, notes: list[str]) -> dict[str, str]:
    """The log's ``verdict`` metadata, written when the log is closed: how the run ended, its
    criteria's verdict, its timing figures (non-finite ones as null), the clock the flight code
    ran on and the host's scheduling and CPU latency (``rt_scheduling``: realtime runs only)."""
    return {
        "end_reason": end.value,
        "passed": str(end is EndReason.COMPLETED and all(c.passed for c in criteria)).lower(),
        "message": message,
        "flight_returncode": str(returncode),
        "timing": json.dumps({k: (v if math.isfinite(v) else None) for k, v in timing.items()}),
        "clock": clock_used.value,
        "clock_note": clock_note,
        "rt_scheduling": rt_scheduling.describe() if rt_scheduling is not None else "",
        "cpu_latency": cpu_latency.describe() if cpu_latency is not None else "",
        "cpu_scale": f"{cpu_scale:g}",
        "shim_calls": json.dumps(shim.calls if shim else {}),
        "idle_waits": json.dumps({"inline": shim.idle_waits_inline, "event_loop": shim.idle_waits_loop}
                                 if shim else {}),
        "notes": json.dumps(notes),
    }


__all__ = ["deep_merge", "default_log_path", "run_metadata", "verdict_metadata", "write_flight_config"]
