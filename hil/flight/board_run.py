"""A run whose flight computer is the emulated LPC2148 (rig ``[flight] board``): what it acquires
instead of a flight process, ptys and a clock session (hil/flight/run.py calls
:func:`acquire_board` in place of its own steps for a board rig).

No process is started: the firmware's image is loaded into the board (firmware/'s ARM build,
made first when out of date, or the rig's ELF), the run's flight config is written into it
(hil/flight/board_image.py), and the tick loop (hil/flight/board_loop.py) runs the core. The
XSENS and the XBee talk to the UARTs through ports with the usual wire taps; the ground XBee
keeps its pty, so a ground station can attach as on any run. The ELF flown is attached to
the log (``replay --verify`` flies it again).
"""

from __future__ import annotations

import collections
import contextlib
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from hil.analysis.criteria import CriterionResult
from hil.board.elf import load_elf
from hil.board.errors import FirmwareError
from hil.config import ConfigError
from hil.flight import run_setup
from hil.flight.board_devices import BoardDevices
from hil.flight.board_gdb import GdbServer
from hil.flight.board_image import firmware_elf, flight_config_text, install_config, sha256
from hil.flight.board_loop import BoardTickLoop
from hil.flight.board_record import BoardRecorder
from hil.flight.board_timing import board_criteria, board_figures
from hil.flight.board_wiring import BoardWiring
from hil.flight.devices import DeviceSet
from hil.flight.tickloop import Mode
from hil.transport.base import Port

#: the attachment holding the firmware flown (hil/fleet/verify.py reads it back)
FIRMWARE_ATTACHMENT = "firmware.elf"


class BoardFlight:
    """The flight code of a board run, as the run's end and its figures see a process: there
    is none to start or stop; the firmware "exits" when it stops or faults."""

    pid: int | None = None
    starting = False

    def __init__(self) -> None:
        self.survivors: list[Any] = []
        self.last_stderr: collections.deque[str] = collections.deque(maxlen=20)
        self.ended = False

    @property
    def running(self) -> bool:
        return not self.ended

    @property
    def returncode(self) -> int | None:
        return None

    def tree_pids(self) -> list[int]:
        return []

    async def start(self) -> None:
        return None

    async def stop(self) -> int | None:
        self.ended = True
        return None


class BoardRun:
    """What a board run adds to the run's state: its loop, its figures and criteria."""

    def __init__(self, loop: BoardTickLoop, elf: Path) -> None:
        self.loop = loop
        self.elf = elf

    def figures(self) -> dict[str, float]:
        return board_figures(self.loop)

    def criteria(self, timing: dict[str, float]) -> list[CriterionResult]:
        return board_criteria(timing)

    def exit_message(self, t_ns: int) -> str:
        return f"{self.loop.exit_text()} at t = {t_ns / 1e9:.3f} s"


def check_board_run(rig: Any, mode: Mode, attach: Any) -> None:
    """What a board run refuses before anything is created (ConfigError, exit 2)."""
    if mode is not Mode.LOCKSTEP:
        raise ConfigError(f"{rig.path}: [flight] board = {rig.flight.board!r}: a board runs in lockstep only "
                          f"(its time is the emulated core's cycles), not in {mode.value} mode")
    if attach:
        raise ConfigError(f"{rig.path}: [flight] board: ports cannot be attached to real lines on a board run "
                          "(the devices are wired to the emulated board's pins)")


async def _gdb_server(stack: contextlib.AsyncExitStack, wiring: BoardWiring, run: Any, elf: Path) -> GdbServer:
    """The debugger's port, announced on stderr (the run waits there before the first instruction)."""
    server = GdbServer(wiring.core, port=run.gdb_port)
    try:
        port = await server.start()
    except OSError as exc:
        raise ConfigError(f"--gdb {run.gdb_port}: cannot listen on 127.0.0.1:{run.gdb_port}: {exc.strerror}") from None
    stack.push_async_callback(server.close)
    print(f"hil: the board waits for GDB on 127.0.0.1:{port}: gdb-multiarch {elf} -ex 'target remote :{port}'",
          file=sys.stderr, flush=True)
    run.note(f"GDB port 127.0.0.1:{port} (the tick held while the debugger held the core)")
    return server


def _on_line(logger_ref: list[Any], flight: BoardFlight) -> Callable[[str], None]:
    def on_line(line: str) -> None:
        flight.last_stderr.append(line)
        if logger_ref:
            logger_ref[0].flight_line("stdout", line)
    return on_line


async def acquire_board(stack: contextlib.AsyncExitStack, run: Any, record_step: Callable[..., Any]) -> None:
    """A board run's resources, on ``stack`` as each exists: the run directory, the devices,
    the board with the firmware, the ports, the recorder and logger (``record_step(ports,
    files, meta)`` is the run's own), the loop."""
    rig, scenario, runner = run.rig, run.scenario, run.runner
    with run_setup.started("creating the run directory"):
        run.run_dir = run_setup.make_private_dir(stack, rig, keep=False)
    with run_setup.started("building the firmware"):
        elf = firmware_elf(rig)
    try:
        image = load_elf(elf)
    except FirmwareError as exc:
        raise ConfigError(f"{rig.path}: [flight] firmware: {exc}") from None
    devices = run.devices = DeviceSet(rig, seed=run.seed, stick_script=runner.stick_script())
    runner.bind(devices)
    flight = BoardFlight()
    logger_ref: list[Any] = []
    try:
        wiring = BoardWiring(image, devices.mcp, _on_line(logger_ref, flight), devices.wire_filters)
    except FirmwareError as exc:
        raise ConfigError(f"{rig.path}: [flight] firmware: {exc}") from None
    config = flight_config_text(rig, scenario)
    install_config(wiring.core, image, config, where=f"{rig.path}: [flight] config")
    ports: dict[str, Port] = {
        "imu": wiring.port("imu", 0, lambda: int(devices.imu.baud_bps)),
        "telemetry": wiring.port("telemetry", 1, lambda: int(devices.xbee_vehicle.baud)),
    }
    with run_setup.started("opening the ports"):
        ports |= await run_setup.open_ports(stack, ("ground",), run.run_dir / "dev", {})
    run.ports = ports
    devices.attach(dict(ports))
    files = [(FIRMWARE_ATTACHMENT, "application/x-elf", elf.read_bytes()),
             ("flight-config.toml", "application/toml", config)]
    meta = {"board": rig.flight.board, "firmware": str(elf), "firmware_sha256": sha256(elf)}
    logger = record_step(ports, files, meta)
    logger_ref.append(logger)
    board_devices = BoardDevices(devices, wiring)
    loop = BoardTickLoop(board_devices, tick_ns=rig.tick_ns, duration_ns=run.duration_ns,
                         boot_timeout_s=rig.flight.boot_timeout_s, before_tick=runner.before_tick)
    board_rec = BoardRecorder(loop, logger.out)
    if run.gdb_port is not None:
        loop.gdb = await _gdb_server(stack, wiring, run, elf)

    def after_tick(k: int, t_ns: int) -> None:
        board_rec.after_tick(k, t_ns)
        logger.after_tick(k, t_ns)

    loop.after_tick = after_tick
    run.loop = loop
    run.flight = flight
    run.board = BoardRun(loop, elf)
    runner.attach_flight(None)
