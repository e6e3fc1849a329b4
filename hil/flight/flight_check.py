"""Ask the flight code whether the ``[flight]`` overrides make a valid config, before a run.

A rig's ``[flight.overrides]`` and a scenario's ``[flight]`` are laid over the flight code's
config template (hil/flight/run_files.py); the bench cannot validate the result itself
(``hil`` never imports ``flightcode``). So it writes the merged config, as the run would, and
runs the rig's flight command with ``--check-config`` (flightcode/check.py): one JSON line
says valid, or names the key and the reason. The answer is turned into a ConfigError naming
the file the key came from: the scenario, the rig, or the template.

Only a command that runs the stock flight code (``-m flightcode``) is asked; another
program's config is its own business, and its boot says what it thinks of it.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import signal
import tempfile
from collections.abc import Mapping
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from hil.config import ConfigError
from hil.config.rig import Rig
from hil.config.scenario import Scenario
from hil.flight.process import expand_command
from hil.flight.run_files import write_flight_config
from hil.flight.spawn import uncancelled_start

CHECK_FLAG = "--check-config"
#: wall seconds the check may take (an interpreter start and the config's imports: about 0.5 s)
CHECK_TIMEOUT_S = 60.0
#: wall seconds to wait for the check's process once its group was killed
REAP_TIMEOUT_S = 5.0
_PORTS = ("imu", "adc", "rc", "esc", "telemetry")


def check_command(rig: Rig) -> tuple[str, ...] | None:
    """The rig's flight command with ``--check-config``; None unless it runs ``-m flightcode``."""
    cmd = tuple(rig.flight.command)
    runs_flightcode = any(cmd[i:i + 2] == ("-m", "flightcode") for i in range(len(cmd) - 1))
    return (*cmd, CHECK_FLAG) if runs_flightcode else None


def _has_key(table: Mapping[str, Any], dotted: str) -> bool:
    node: Any = table
    for part in dotted.split("."):
        if not isinstance(node, Mapping) or part not in node:
            return False
        node = node[part]
    return True


def _where(rig: Rig, scenario: Scenario, source: Path | None, key: str) -> str:
    """The file (and table) a bad key of the merged config came from."""
    if key and _has_key(scenario.flight, key):
        return f"{source or scenario.name}: [flight] {key}"
    if key and _has_key(rig.flight.overrides, key):
        return f"{rig.path}: [flight.overrides] {key}"
    return f"{rig.flight_config_path}: {key}" if key else str(rig.flight_config_path)


async def check_flight_config(rig: Rig, scenario: Scenario, source: Path | None = None) -> None:
    """Raise :class:`ConfigError` naming file, key and reason if the flight code refuses the
    config this run would give it (module docstring). Nothing else is started. A cancel (Ctrl-C)
    ends the check at once."""
    template = check_command(rig)
    if template is None:
        return
    with tempfile.TemporaryDirectory(prefix="hilcheck-") as tmp:
        ports = {name: SimpleNamespace(client_path=f"{tmp}/{name}") for name in _PORTS}
        config = write_flight_config(rig, scenario, ports, Path(tmp))  # type: ignore[arg-type]
        verdict = await _ask(expand_command(template, config=config))
    if verdict is not None and not verdict.get("ok"):
        key = str(verdict.get("key", ""))
        raise ConfigError(f"{_where(rig, scenario, source, key)}: {verdict.get('reason', 'invalid')} "
                          "(the flight code's own check, python -m flightcode --check-config)")


async def _ask(argv: list[str]) -> dict[str, Any] | None:
    """Run the check; its verdict, or None if it gave none. A launcher in the command (``sh
    -c``, ``make``) may go on after the flight code answered, or never end: its process group
    is killed as soon as the verdict is read, at ``CHECK_TIMEOUT_S``, or on a cancel."""
    loop = asyncio.get_running_loop()
    spawn = asyncio.ensure_future(loop.subprocess_exec(
        lambda: asyncio.subprocess.SubprocessStreamProtocol(limit=2**16, loop=loop), *argv,
        stdin=asyncio.subprocess.DEVNULL, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.DEVNULL,
        start_new_session=True))
    try:
        transport, protocol = await uncancelled_start(spawn, _kill_group)
    except OSError:
        return None  # the run's own start says what is wrong with the command
    proc = asyncio.subprocess.Process(transport, protocol, loop)
    assert proc.stdout is not None
    try:
        async with asyncio.timeout(CHECK_TIMEOUT_S):
            async for line in proc.stdout:
                verdict = _verdict(line)
                if verdict is not None:
                    return verdict
    except (TimeoutError, ValueError):  # ValueError: a line longer than the stream's limit
        pass
    finally:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(proc.pid, signal.SIGKILL)
        with contextlib.suppress(TimeoutError):  # bounded: a descendant that left the group holds stdout
            await asyncio.wait_for(asyncio.shield(proc.wait()), REAP_TIMEOUT_S)
    return None


def _kill_group(transport: asyncio.SubprocessTransport) -> None:
    """A check cancelled while it started: its whole group (a launcher's children too)."""
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(transport.get_pid(), signal.SIGKILL)
    transport.close()


def _verdict(line: bytes) -> dict[str, Any] | None:
    try:
        verdict = json.loads(line)
    except ValueError:
        return None
    return verdict if isinstance(verdict, dict) and "flightcode_check" in verdict else None
