"""``hil devices``: the emulated devices on ptys, in real time, for a hand-started client.

Sim time starts at once and runs with the wall clock (400 Hz ticks from the precise
pacer); the plant flies on whatever the Maestro receives, the RC plays the scenario's
sticks, and every device answers its protocol. Ctrl-C (or ``duration_s``) stops it.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import shutil
import signal
from collections.abc import Callable, Mapping
from pathlib import Path

from rich.console import Console

from hil.host import cpulatency
from hil.config.attach import follow_device_rates, open_attached, resolve_attachments
from hil.flight.tickloop import Mode, TickLoop
from hil.flight.devices import DeviceSet
from hil.config.rig import Rig
from hil.host.rtsched import for_rig
from hil.flight.rundir import make_run_dir
from hil.config.scenario import Scenario, apply_to_rig
from hil.flight.scenario_runner import ScenarioRunner
from hil.transport.base import Port
from hil.transport.pty import PtyPort

DEVICE_PORTS = ("imu", "adc", "adc-spidriver", "rc", "esc", "telemetry", "ground")

DESCRIPTIONS = {
    "imu": "XSENS MTi (Xbus)",
    "adc": "MCP3204 behind a Bus Pirate v3 (binary SPI)",
    "adc-spidriver": "MCP3204 behind a SPIDriver",
    "rc": "PPM receiver through the timer-capture front-end",
    "esc": "Pololu Maestro -> 4 ESCs",
    "telemetry": "XBee-PRO, vehicle side (API mode)",
    "ground": "XBee-PRO, ground-station side",
}


async def serve_devices(
    rig: Rig,
    scenario: Scenario,
    *,
    seed: int,
    duration_s: float | None,
    console: Console,
    on_ready: Callable[[dict[str, str]], None] | None = None,
    run_dir: Path | None = None,
    attach: Mapping[str, str] | None = None,
) -> dict[str, dict[str, int]]:
    """Serve until Ctrl-C or ``duration_s``; returns the device counters.

    ``attach``: port -> device or URL over the rig's ``[ports]`` (hil/config/attach.py). Those ports
    are opened first, all or none (a :class:`~hil.config.ConfigError` naming port and path,
    and nothing started); the others are ptys."""
    runner = ScenarioRunner(scenario, rig)
    attachments = resolve_attachments(rig.ports, attach or {}, DEVICE_PORTS, command="devices")
    # the tick loop keeps its 400 Hz on a loaded host where SCHED_FIFO is allowed (the
    # clients are the user's own processes: theirs to raise)
    rt = for_rig(rig)
    wake = cpulatency.for_rig(rig)  # the clients' answers come sooner from a polling idle CPU
    attached = open_attached(attachments, rig.port_baud)
    own_dir = run_dir is None
    run_dir = run_dir or make_run_dir(f"hil-devices-{rig.name}-")
    os.chmod(run_dir, 0o700)
    dev_dir = run_dir / "dev"
    dev_dir.mkdir(mode=0o700, exist_ok=True)
    devices = DeviceSet(rig, seed=seed, stick_script=runner.stick_script(), with_spidriver=True)
    runner.bind(devices)
    runner.attach_flight(None)
    ports: dict[str, Port] = {name: attached.get(name) or PtyPort(name, dev_dir) for name in DEVICE_PORTS}
    for port in ports.values():
        await port.start()
    devices.attach(dict(ports))
    follow_device_rates(devices, attached)

    # Plain lines, never wrapped, so a path can be copied into a client's command line.
    console.print(f"{rig.name}: emulated devices in real time (Ctrl-C to stop)", highlight=False)
    for name, port in ports.items():
        line = attachments[name] if name in attachments else None
        how = (f"attached, {rig.port_baud(name)} baud {line.bytesize}{line.parity}{line.stopbits}"
               if line is not None else f"{rig.port_baud(name)} baud")
        console.print(f"  {name:<14} {port.path}  ({DESCRIPTIONS[name]}, {how})",
                      soft_wrap=True, highlight=False, markup=False)
    for port in attached.values():
        for text in port.notes:
            console.print(f"  note: {text}", soft_wrap=True, highlight=False, markup=False)

    duration_ns = int((duration_s if duration_s is not None else 10 * 365 * 86400.0) * 1e9)
    loop = TickLoop(
        devices,
        mode=Mode.REALTIME,
        tick_ns=rig.tick_ns,
        duration_ns=duration_ns,
        barrier_timeout_s=rig.flight.barrier_timeout_s,
        boot_timeout_s=0.0,
        before_tick=runner.before_tick,
    )
    task = asyncio.current_task()
    aloop = asyncio.get_running_loop()
    if task is not None:
        with contextlib.suppress(NotImplementedError, RuntimeError):
            aloop.add_signal_handler(signal.SIGINT, task.cancel)
    if on_ready is not None:
        on_ready({name: port.path for name, port in ports.items()})
    try:
        with wake as held, rt as got:
            console.print(f"  scheduling: {got.describe()}; {held.describe()}", soft_wrap=True, highlight=False,
                          markup=False)
            await loop.run()
    except asyncio.CancelledError:
        console.print("stopped")
    finally:
        runner.finish(max(loop.t_ns, 0))
        with contextlib.suppress(NotImplementedError, RuntimeError):
            aloop.remove_signal_handler(signal.SIGINT)
        for port in ports.values():
            port.close()
        if own_dir:
            shutil.rmtree(run_dir, ignore_errors=True)
    return {name: dict(dev.counters) for name, dev in devices.by_port.items()}
