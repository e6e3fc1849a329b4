"""Rig files: one vehicle and its wiring, validated into the components' parameter classes.

Layout of a rig TOML (units in key names; every table optional, defaults = the paper's
vehicle; unknown tables and keys are errors naming the file and key):

    [rig]        name, description, tick_ns, default_scenario
    [plant]      -> hil.plant.params.PlantParams
    [imu]        -> emulators.xsens.params.XsensParams
    [adc]        bridge = "buspirate" (the only one); [adc.mcp3204], [adc.buspirate], [adc.spidriver] (hil devices)
    [analog]     -> emulators.analog.params.AnalogParams
    [rc]         frontend = "capture" | "sbus"; [rc.ppm], [rc.capture], [rc.sbus]
    [esc]        [esc.maestro], [esc.esc]
    [telemetry]  [telemetry.vehicle], [telemetry.ground], [telemetry.link]
    [flight]     command, config (the flight code's config template), timeouts; or board and
                 firmware (the firmware's ARM image on an emulated LPC2148)
    [record]     recording rates
    [ports.<port>]  attach a port to a real serial device or URL (hil/config/attach.py)
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field

from hil.config.attach import load_ports_table
from hil.config import (
    ConfigError,
    check_keys,
    load_toml,
    resolve_rig,
    resolve_scenario,
    validate,
)

#: table -> "module:Class" of the component parameters it validates into
COMPONENTS: dict[str, str] = {
    "plant": "hil.plant.params:PlantParams",
    "imu": "emulators.xsens.params:XsensParams",
    "adc.mcp3204": "emulators.mcp3204.params:Mcp3204Params",
    "adc.buspirate": "emulators.buspirate.params:BusPirateParams",
    "adc.spidriver": "emulators.spidriver.params:SpiDriverParams",
    "analog": "emulators.analog.params:AnalogParams",
    "rc.ppm": "emulators.rc.params:PpmParams",
    "rc.capture": "emulators.rc.params:CaptureParams",
    "rc.sbus": "emulators.rc.params:SbusParams",
    "esc.maestro": "emulators.maestro.params:MaestroParams",
    "esc.esc": "emulators.esc.params:EscParams",
    "telemetry.vehicle": "emulators.xbee.params:XBeeParams",
    "telemetry.ground": "emulators.xbee.params:XBeeParams",
    "telemetry.link": "emulators.xbee.params:LinkParams",
}


def _component_class(spec: str) -> type:
    module, _, name = spec.partition(":")
    return getattr(importlib.import_module(module), name)  # type: ignore[no-any-return]


@dataclass(frozen=True)
class RigHeader:
    __pydantic_config__ = {"extra": "forbid"}
    name: str = "paper-quad"
    description: str = ""
    tick_ns: int = 2_500_000
    default_scenario: str = "mission"


#: ``[flight] firmware`` naming firmware/'s ARM build (``hil firmware build --target arm``)
FIRMWARE_TARGET = "arm"


@dataclass(frozen=True)
class FlightSection:
    """How the bench starts the flight code. ``{python}`` and ``{config}`` are substituted."""

    __pydantic_config__ = {"extra": "forbid"}
    command: tuple[str, ...] = ("{python}", "-m", "flightcode", "--config", "{config}")
    #: the flight code's own config file (its format), relative to the rig file; the bench
    #: fills its [ports] table with the run's symlinks
    config: str = "flightcode-paper-quad.toml"
    #: sim seconds (wall seconds where virtual time falls back to the host clock)
    boot_timeout_s: float = 20.0
    #: lockstep on the host clock only (the fallback): wall seconds to wait for a sample's command
    barrier_timeout_s: float = 0.5
    #: wall seconds the flight command's processes have to exit after SIGTERM at the run's end
    #: (or Ctrl-C, a bench error) before SIGKILL ends whatever is left of its tree
    stop_grace_s: Annotated[float, Field(gt=0.0, le=600.0)] = 3.0
    required_devices: tuple[str, ...] = ("imu", "adc")
    #: the target processor's CPU time per host CPU second: compute figures in lockstep are the
    #: flight code's CPU time on this host times this (docs/time.md: how to calibrate it)
    cpu_scale: Annotated[float, Field(gt=0.0)] = 1.0
    #: where ``cpu_scale`` came from (target, method, date). Empty: not calibrated, and compute
    #: budgets are reported but not judged (this host's CPU time says nothing of the target's)
    cpu_scale_source: str = ""
    #: lockstep: run the flight code on sim time through the clock shim (docs/time.md)
    virtual_time: bool = True
    #: lockstep: refuse to fly on the host clock when virtual time cannot be had (the clock
    #: shim missing, a static program, LD_PRELOAD dropped): exit 2 with the reason, not a note
    require_virtual_time: bool = False
    #: tables merged over the flight code's config template for this rig (e.g. gains retuned
    #: for this rig's plant), before a scenario's own ``[flight]`` overrides
    overrides: dict[str, Any] = field(default_factory=dict)
    #: the flight computer: "" a process (``command``); "lpc2148" the firmware's ARM image on
    #: the emulated LPC2148 (docs/board.md), lockstep in target cycles; ``command`` is not used
    board: Literal["", "lpc2148"] = ""
    #: a board's firmware: "arm" (firmware/'s ARM build, made first if needed) or the path of
    #: an ARM ELF, relative to the rig file
    firmware: str = ""

    @property
    def firmware_target(self) -> bool:
        """``firmware`` names the ARM build rather than a file."""
        return self.firmware == FIRMWARE_TARGET


@dataclass(frozen=True)
class RecordSection:
    __pydantic_config__ = {"extra": "forbid"}
    #: /sim/truth and /hil/esc/output every N ticks (100 Hz: the file budget, docs/recording.md)
    truth_divider: Annotated[int, Field(ge=1)] = 4
    pose_divider: Annotated[int, Field(ge=1)] = 8  #: /tf and /sim/pose every N ticks (50 Hz)
    counters_divider: Annotated[int, Field(ge=1)] = 400  #: device counters every N ticks (1 Hz)


@dataclass(frozen=True)
class RealtimeSection:
    """How a realtime run is scheduled on the host (hil/host/rtsched.py, docs/time.md)."""

    __pydantic_config__ = {"extra": "forbid"}
    #: "auto": the tick loop and the flight code on SCHED_FIFO where the host allows it, else
    #: as before with a note; "fifo": refuse to run without it; "normal": never
    policy: Literal["auto", "fifo", "normal"] = "auto"
    #: the SCHED_FIFO priority (1-98; 99 is left to the kernel's own threads)
    priority: Annotated[int, Field(ge=1, le=98)] = 50


@dataclass(frozen=True)
class HostSection:
    """What a run asks of the host's CPUs, in lockstep and realtime (hil/host/cpulatency.py)."""

    __pydantic_config__ = {"extra": "forbid"}
    #: "auto": hold the kernel's CPU latency request (/dev/cpu_dma_latency) at cpu_latency_us
    #: for the run where the host allows it, else run without with a note; "require": refuse
    #: to run without it; "off": never ask (idle CPUs then sleep, and every wake-up is slower)
    cpu_latency: Literal["auto", "require", "off"] = "auto"
    #: the wake-up latency asked for, in us (0: the idle CPUs poll)
    cpu_latency_us: Annotated[int, Field(ge=0, le=2_000_000_000)] = 0


@dataclass(frozen=True)
class AdcSection:
    #: the SPI bridge on the adc port; only the Bus Pirate (the flight code has no SPIDriver driver)
    bridge: Literal["buspirate"]
    mcp3204: Any
    buspirate: Any
    spidriver: Any


@dataclass(frozen=True)
class RcSection:
    frontend: Literal["capture", "sbus"]
    ppm: Any
    capture: Any
    sbus: Any


@dataclass(frozen=True)
class EscSection:
    maestro: Any
    esc: Any


@dataclass(frozen=True)
class TelemetrySection:
    vehicle: Any
    ground: Any
    link: Any


@dataclass(frozen=True)
class Rig:
    path: Path
    header: RigHeader
    plant: Any
    imu: Any
    adc: AdcSection
    analog: Any
    rc: RcSection
    esc: EscSection
    telemetry: TelemetrySection
    flight: FlightSection
    record: RecordSection
    raw: dict[str, Any] = field(repr=False, default_factory=dict)
    realtime: RealtimeSection = field(default_factory=RealtimeSection)
    host: HostSection = field(default_factory=HostSection)
    #: ports attached to real serial devices ([ports.<port>]; hil/config/attach.py)
    ports: dict[str, Any] = field(default_factory=dict)

    @property
    def name(self) -> str:
        return self.header.name

    @property
    def tick_ns(self) -> int:
        return self.header.tick_ns

    @property
    def flight_config_path(self) -> Path:
        return (self.path.parent / self.flight.config).resolve()

    @property
    def firmware_path(self) -> Path:
        """A board's firmware file (``[flight] firmware`` relative to the rig file; not for
        the build target)."""
        return (self.path.parent / self.flight.firmware).resolve()

    def device_baud(self, port: str) -> int:
        """The line rate (bit/s) of the emulated device on ``port``."""
        if port == "imu":
            return int(self.imu.baud_bps)
        if port == "adc":
            return int(self.adc.buspirate.baud_bps)
        if port == "rc":
            return int(self.rc.capture.baud if self.rc.frontend == "capture" else self.rc.sbus.baud)
        if port == "esc":
            return int(self.esc.maestro.baud)
        if port in ("telemetry", "ground"):
            from emulators.xbee.module import bd_to_baud

            return int(bd_to_baud((self.telemetry.vehicle if port == "telemetry" else self.telemetry.ground).bd))
        raise KeyError(port)

    def port_baud(self, port: str) -> int:
        """Like :meth:`device_baud`, for every port ``hil devices`` serves (adc-spidriver too)."""
        if port == "adc-spidriver":
            return int(self.adc.spidriver.baud_bps)
        return self.device_baud(port)

    def scenario_path(self, name_or_path: str | Path | None) -> Path:
        return resolve_scenario(name_or_path or self.header.default_scenario, self.path)


def _table(data: dict[str, Any], dotted: str) -> dict[str, Any]:
    node: Any = data
    for part in dotted.split("."):
        node = node.get(part, {}) if isinstance(node, dict) else {}
    if not isinstance(node, dict):
        raise ConfigError(f"[{dotted}] must be a table")
    return node


def load_rig(name_or_path: str | Path | None = None) -> Rig:
    """Load and validate a rig file (by path or by name under rigs/)."""
    path = resolve_rig(name_or_path)
    data = load_toml(path)
    check_keys(
        data,
        {"rig", "plant", "imu", "adc", "analog", "rc", "esc", "telemetry", "flight", "record", "realtime", "host", "ports"},
        file=path,
        section="top level",
    )
    check_keys(_table(data, "adc"), {"bridge", "mcp3204", "buspirate", "spidriver"}, file=path, section="adc")
    check_keys(_table(data, "rc"), {"frontend", "ppm", "capture", "sbus"}, file=path, section="rc")
    check_keys(_table(data, "esc"), {"maestro", "esc"}, file=path, section="esc")
    check_keys(_table(data, "telemetry"), {"vehicle", "ground", "link"}, file=path, section="telemetry")
    parts: dict[str, Any] = {
        key: validate(_component_class(spec), _table(data, key), file=path, section=key)
        for key, spec in COMPONENTS.items()
    }
    bridge = _table(data, "adc").get("bridge", "buspirate")
    frontend = _table(data, "rc").get("frontend", "capture")
    if bridge == "spidriver":  # said, not done: refuse it rather than serve the Bus Pirate silently
        raise ConfigError(f"{path}: [adc] bridge: 'spidriver' is not supported on the adc port (the flight code has "
                          "no SPIDriver driver, so a run serves the Bus Pirate); use bridge = 'buspirate'. "
                          "`hil devices` serves the SPIDriver model on its own port, adc-spidriver, with [adc.spidriver]")
    if bridge != "buspirate":
        raise ConfigError(f"{path}: [adc] bridge: must be 'buspirate' (got {bridge!r})")
    if frontend not in ("capture", "sbus"):
        raise ConfigError(f"{path}: [rc] frontend: must be 'capture' or 'sbus' (got {frontend!r})")
    rig = Rig(
        path=path.resolve(),
        header=validate(RigHeader, _table(data, "rig"), file=path, section="rig"),
        plant=parts["plant"],
        imu=parts["imu"],
        adc=AdcSection(bridge, parts["adc.mcp3204"], parts["adc.buspirate"], parts["adc.spidriver"]),
        analog=parts["analog"],
        rc=RcSection(frontend, parts["rc.ppm"], parts["rc.capture"], parts["rc.sbus"]),
        esc=EscSection(parts["esc.maestro"], parts["esc.esc"]),
        telemetry=TelemetrySection(parts["telemetry.vehicle"], parts["telemetry.ground"], parts["telemetry.link"]),
        flight=validate(FlightSection, _table(data, "flight"), file=path, section="flight"),
        record=validate(RecordSection, _table(data, "record"), file=path, section="record"),
        realtime=validate(RealtimeSection, _table(data, "realtime"), file=path, section="realtime"),
        host=validate(HostSection, _table(data, "host"), file=path, section="host"),
        raw=data,
        ports=load_ports_table(data.get("ports", {}), file=path),
    )
    if not rig.flight_config_path.exists():
        raise ConfigError(f"{path}: [flight] config: {rig.flight_config_path} does not exist")
    _check_board(rig, path)
    return rig


def _check_board(rig: Rig, path: Path) -> None:
    """``[flight] board`` and ``firmware`` go together; a firmware file must exist."""
    flight = rig.flight
    if not flight.board:
        if flight.firmware:
            raise ConfigError(f"{path}: [flight] firmware: set without [flight] board (the firmware runs on an "
                              f"emulated board: board = \"lpc2148\")")
        return
    if not flight.firmware:
        raise ConfigError(f"{path}: [flight] firmware: missing (board = {flight.board!r} needs the ARM image: "
                          f"\"{FIRMWARE_TARGET}\" for firmware/'s build, or the path of an ELF file)")
    if not flight.firmware_target and not rig.firmware_path.is_file():
        raise ConfigError(f"{path}: [flight] firmware: {rig.firmware_path} is not a file (\"{FIRMWARE_TARGET}\" "
                          "builds firmware/'s ARM image)")
