"""Closed-loop runs for the system tests: the real flight code as a subprocess, lockstep."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import psutil
import pytest

from hil.flight.tickloop import Mode
from hil.config.rig import Rig, load_rig
from hil.flight.run import run_flight_async
from hil.flight.run_result import RunResult
from hil.config.scenario import load_scenario


def explain(result: RunResult) -> str:
    """A failure message with everything needed to see why a run failed."""
    lines = [f"end: {result.end_reason.value} {result.message}", f"log: {result.log_path}"]
    for c in result.criteria:
        lines.append(f"  {'ok ' if c.passed else 'BAD'} {c.name}: {c.metric}({c.signal}) = {c.value:.4g} {c.bound} {c.detail}")
    lines.append(f"timing: { {k: round(v, 1) for k, v in result.timing.items()} }")
    lines += ["flight stderr (last lines):", *("  " + s for s in result.flight_stderr_tail)]
    return "\n".join(lines)


def at_tick(k: int, look: Callable[[Any], None]) -> Callable[..., None]:
    """An ``on_ready`` for a run that calls ``look(runner)`` once, right after tick ``k``
    (after the run's own end-of-tick work): to see the processes while the run flies."""

    def on_ready(loop: Any, devices: object, runner: Any) -> None:
        logged = loop.after_tick

        def after_tick(k_now: int, t_ns: int) -> None:
            if logged is not None:
                logged(k_now, t_ns)
            if k_now == k:
                look(runner)

        loop.after_tick = after_tick

    return on_ready


@pytest.fixture
def fly(tmp_path: Path):
    """``await fly(scenario, **kwargs)`` -> RunResult, recorded into tmp_path."""

    async def _fly(scenario: str, *, rig: str | Rig | None = None, **kwargs) -> RunResult:
        rig_obj = rig if isinstance(rig, Rig) else load_rig(rig)
        source = rig_obj.scenario_path(scenario)
        kwargs.setdefault("mode", Mode.LOCKSTEP)
        kwargs.setdefault("out_dir", tmp_path)
        kwargs.setdefault("keep_trace", True)  # tests look at the run's signals afterwards
        return await run_flight_async(rig_obj, load_scenario(source), scenario_source=source, **kwargs)

    return _fly


def rig_with_command(tmp_path: Path, command: list[str], name: str) -> Path:
    """A copy of the default rig, written as ``tmp_path/<name>.toml``, whose flight command is
    ``command`` (its ``{python}``/``{config}`` placeholders as in a rig) with the default config."""
    root = Path(__file__).resolve().parents[2]
    quoted = ", ".join(f'"{part}"' for part in command)
    lines = []
    for line in (root / "rigs" / "paper-quad.toml").read_text().splitlines():
        if line.startswith("command = "):
            line = f"command = [{quoted}]"
        elif line.startswith("config = "):
            line = f'config = "{root / "rigs" / "flightcode-paper-quad.toml"}"'
        lines.append(line)
    rig = tmp_path / f"{name}.toml"
    rig.write_text("\n".join(lines) + "\n")
    (tmp_path / "scenarios").mkdir(exist_ok=True)
    return rig


def _fds() -> set[str]:
    return {f"{fd} -> {os.readlink(f'/proc/self/fd/{fd}')}" for fd in os.listdir("/proc/self/fd")
            if os.path.exists(f"/proc/self/fd/{fd}")}


def _children() -> list[int]:
    return [p.pid for p in psutil.Process().children(recursive=True)]


@pytest.fixture
def clean_slate(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """Run directories go to a private temp root; returns a check that nothing was left since
    the check was made (called first in the test's coroutine: the event loop's own descriptors
    exist by then)."""
    root = tmp_path / "tmp"
    root.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(root))
    before_fds: set[str] = set()
    before_children: list[int] = []

    def nothing_left(out: Path | None = None) -> None:
        if out is None:
            before_fds.update(_fds())
            before_children.extend(_children())
            return
        assert _children() == before_children
        assert _fds() == before_fds
        assert list(root.iterdir()) == []
        assert not list(out.glob("*.part")) and not list(out.glob(".*"))

    return nothing_left
