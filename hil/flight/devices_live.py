"""``hil devices``: the emulated devices on ptys, in real time, for a hand-started client.

Sim time starts at once and runs with the wall clock (400 Hz ticks from the precise
pacer); the plant flies on whatever the Maestro receives, the RC plays the scenario's
sticks, and every device answers its protocol. Ctrl-C (or ``duration_s``) stops it.

Every resource is acquired by a step of hil/flight/run_setup.py (the steps of ``hil run``)
and handed to one ``AsyncExitStack`` the moment it exists: a failure at any step, or later,
releases everything acquired before (serial lines, the private run directory, the ptys, the
recorder child, the live server and its pipe).

``live`` (``hil devices --live``, docs/live.md): the devices' messages are recorded the way a
realtime run records them (hil/flight/runlog.py) by a recorder child whose live server
(hil/live/server.py) mirrors them to Foxglove. The recording goes to the private run
directory and is removed with it: the server's channels, schemas and bytes are a run's. The
app's /hil/inject starts catalogue faults (hil/live/steer.py); pause, step and speed are
refused, as for any realtime run.
"""

from __future__ import annotations

import asyncio
import contextlib
import signal
from collections.abc import Callable, Mapping

from rich.console import Console

from hil import clock
from hil.analysis.trace_stream import TraceStream
from hil.config.attach import follow_device_rates, resolve_attachments
from hil.config.rig import Rig
from hil.config.scenario import Scenario
from hil.flight import run_setup
from hil.flight.devices import DeviceSet
from hil.flight.run_files import run_metadata
from hil.flight.runlog import RunLogger
from hil.flight.scenario_runner import ScenarioRunner
from hil.flight.tickloop import Mode, TickLoop
from hil.host import cpulatency
from hil.host.rtsched import for_rig
from hil.live.steer import attach_live
from hil.live.topics import LiveConfig
from hil.record.process import ProcessRecorder
from hil.transport.base import Port

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
#: ``duration_s=None``: until Ctrl-C (ten years of sim time)
FOREVER_NS = 10 * 365 * 86400 * 1_000_000_000
#: the recording behind ``--live``, in the private run directory (removed with it)
LIVE_LOG = "devices.mcap"


async def serve_devices(
    rig: Rig,
    scenario: Scenario,
    *,
    seed: int,
    duration_s: float | None,
    console: Console,
    on_ready: Callable[[dict[str, str]], None] | None = None,
    attach: Mapping[str, str] | None = None,
    live: LiveConfig | None = None,
) -> dict[str, dict[str, int]]:
    """Serve until Ctrl-C or ``duration_s``; returns the device counters.

    ``attach``: port -> device or URL over the rig's ``[ports]`` (hil/config/attach.py). Those ports
    are opened first, all or none (a :class:`~hil.config.ConfigError` naming port and path,
    and nothing started); the others are ptys. ``live``: serve the devices to Foxglove (module
    docstring); its ``announce`` gets the URL once the server listens. A resource that cannot be
    had raises :class:`~hil.flight.run_setup.RunStartError` naming the step, after everything
    acquired was released."""
    runner = ScenarioRunner(scenario, rig)
    attachments = resolve_attachments(rig.ports, attach or {}, DEVICE_PORTS, command="devices")
    # the tick loop keeps its 400 Hz on a loaded host where SCHED_FIFO is allowed (the
    # clients are the user's own processes: theirs to raise)
    rt = for_rig(rig)
    wake = cpulatency.for_rig(rig)  # the clients' answers come sooner from a polling idle CPU
    duration_ns = FOREVER_NS if duration_s is None else int(duration_s * 1e9)
    async with contextlib.AsyncExitStack() as stack:
        with run_setup.started("opening the serial lines"):  # all or none: a missing/busy one leaves nothing
            attached = run_setup.open_serial_lines(stack, attachments, rig)
        with run_setup.started("creating the run directory"):
            run_dir = run_setup.make_private_dir(stack, rig, keep=False, prefix="hil-devices-")
        devices = DeviceSet(rig, seed=seed, stick_script=runner.stick_script(), with_spidriver=True)
        runner.bind(devices)
        runner.attach_flight(None)
        with run_setup.started("opening the ports"):
            ports = await run_setup.open_ports(stack, DEVICE_PORTS, run_dir / "dev", attached)
        devices.attach(dict(ports))
        follow_device_rates(devices, attached)  # type: ignore[arg-type]
        logger: RunLogger | None = None
        recorder: ProcessRecorder | None = None
        run_start_unix_ns = clock.wall_ns()
        if live is not None:
            meta = {**run_metadata(rig, scenario, seed, Mode.REALTIME, duration_ns), "command": "hil devices"}
            with run_setup.started("starting the recorder"):
                recorder = run_setup.start_recorder(
                    stack, lambda path: ProcessRecorder(path, run_start_unix_ns=run_start_unix_ns, metadata=meta,
                                                        live=live, duration_ns=duration_ns),
                    run_dir / LIVE_LOG, unique=False)
            # what a realtime run records, with no criteria reading it (a chunk no one takes is dropped)
            logger = RunLogger(recorder, TraceStream(deferred=True), devices, ports, rig, run_start_unix_ns)
            runner.log_event = logger.event
        _print_ports(console, rig, ports, attachments, attached)
        loop = TickLoop(
            devices,
            mode=Mode.REALTIME,
            tick_ns=rig.tick_ns,
            duration_ns=duration_ns,
            barrier_timeout_s=rig.flight.barrier_timeout_s,
            boot_timeout_s=0.0,
            before_tick=runner.before_tick,
            after_tick=logger.after_tick if logger is not None else None,
        )
        if logger is not None:
            steering = attach_live(recorder, loop, runner, logger, lockstep=False)  # announces the URL
            if steering is not None:
                stack.callback(steering.close)
        _stop_on_sigint(stack)
        if on_ready is not None:
            on_ready({name: port.path for name, port in ports.items()})
        end = "error"
        try:
            with wake as held, rt as got:
                console.print(f"  scheduling: {got.describe()}; {held.describe()}", soft_wrap=True, highlight=False,
                              markup=False)
                await loop.run()
            end = "stopped (--duration)"
        except asyncio.CancelledError:
            end = "stopped (Ctrl-C)"
            console.print("stopped")
        finally:
            runner.finish(max(loop.t_ns, 0))  # reverts active faults (their end is an event)
            if recorder is not None and logger is not None:
                logger.out.flush()  # type: ignore[union-attr]
                with contextlib.suppress(OSError):  # the log is removed with the run directory
                    recorder.close({"status": "aborted" if end == "error" else "stopped", "end_reason": end})
    return {name: dict(dev.counters) for name, dev in devices.by_port.items()}


def serve_devices_blocking(rig_name: str | None, scenario_name: str | None, *, attach_flags: list[str],
                           **kwargs: object) -> dict[str, dict[str, int]]:
    """``hil devices``: load the rig and scenario, parse ``--attach`` flags, serve (the rest of
    ``kwargs`` as :func:`serve_devices` takes them). Raises ConfigError on bad input."""
    from hil.config.attach import parse_attach_flags
    from hil.config.rig import load_rig
    from hil.config.scenario import load_scenario

    rig = load_rig(rig_name)
    scenario = load_scenario(rig.scenario_path(scenario_name))
    return asyncio.run(serve_devices(rig, scenario, attach=parse_attach_flags(attach_flags), **kwargs))  # type: ignore[arg-type]


def _print_ports(console: Console, rig: Rig, ports: Mapping[str, Port], attachments: Mapping[str, object],
                 attached: Mapping[str, Port]) -> None:
    """Plain lines, never wrapped, so a path can be copied into a client's command line."""
    console.print(f"{rig.name}: emulated devices in real time (Ctrl-C to stop)", highlight=False)
    for name, port in ports.items():
        line = attachments.get(name)
        how = (f"attached, {rig.port_baud(name)} baud {line.bytesize}{line.parity}{line.stopbits}"  # type: ignore[attr-defined]
               if line is not None else f"{rig.port_baud(name)} baud")
        console.print(f"  {name:<14} {port.path}  ({DESCRIPTIONS[name]}, {how})",
                      soft_wrap=True, highlight=False, markup=False)
    for port in attached.values():
        for text in port.notes:  # type: ignore[attr-defined]
            console.print(f"  note: {text}", soft_wrap=True, highlight=False, markup=False)


def _stop_on_sigint(stack: contextlib.AsyncExitStack) -> None:
    """Ctrl-C cancels the serving task (it ends as "stopped"); the handler goes with the stack."""
    task = asyncio.current_task()
    aloop = asyncio.get_running_loop()
    if task is None:
        return
    with contextlib.suppress(NotImplementedError, RuntimeError):
        aloop.add_signal_handler(signal.SIGINT, task.cancel)
        stack.callback(_remove_sigint, aloop)


def _remove_sigint(aloop: asyncio.AbstractEventLoop) -> None:
    with contextlib.suppress(NotImplementedError, RuntimeError):
        aloop.remove_signal_handler(signal.SIGINT)
