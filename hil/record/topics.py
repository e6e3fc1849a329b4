"""The topic table: every MCAP topic of a run, its JSON schema, units and an example payload.

One place. Adding a topic is one ``TopicSpec`` line in ``_TABLE`` (plus its schema if new).
Logging to a topic that is not in the table is a programming error and raises
``UnknownTopicError`` at ``Recorder.log()`` time.

Each topic has one encoding (``TopicSpec.encoding``, docs/recording.md "Encoding"): the
high-rate topics (wire bytes, truth, device values, tick timing) are ``protobuf`` with a schema
generated from the topic's JSON schema (``hil/record/protobuf.py``); the low-rate and
free-form ones, and the Foxglove well-known ones (``foxglove.FrameTransform``,
``foxglove.PoseInFrame``, ``foxglove.Log``: the official JSON schemas vendored in
``schemas/``, see schemas/README.md), are ``json`` with a ``jsonschema`` schema. The JSON
schema describes every topic either way (validation, docs). Schemas stay inside the subset
Foxglove's JSON-schema parser accepts (root ``object`` with ``properties``; fields
``boolean``/``string`` (``contentEncoding: base64`` for bytes)/``number``/``integer``/
``object``/``array`` of those, or ``oneOf`` numeric constants), so its panels can address
every field.

Protobuf topics leave out what the MCAP record already holds: ``t_ns`` when it equals the
log time's sim time, ``t_host_ns`` when it equals ``publish_time``; ``hil.record`` readers
put them back.

The writer completes payloads according to ``TopicSpec.stamp``:

* ``Stamp.SIM``: ``t_ns`` (sim time, ns) is set from the ``log()`` argument unless the payload
  carries its own (an event's true sim time may differ from the time it is logged at);
* ``Stamp.TIMING``: ``t_ns`` and ``t_host_ns`` (host CLOCK_MONOTONIC, ns) likewise;
* ``Stamp.FOXGLOVE``: ``timestamp = {"sec", "nsec"}`` is set to the message's log time
  (Unix time of the sim instant), after the spec's ``defaults``.
"""

from __future__ import annotations

import enum
import functools
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

SCHEMA_DIR = Path(__file__).with_name("schemas")

#: Ports that have wire taps (docs/architecture.md "Ports"); one line to add one.
WIRE_PORTS: tuple[str, ...] = ("imu", "adc", "adc-spidriver", "rc", "esc", "telemetry", "ground")
#: Wire directions, named from the bench's side (hil.transport.base.Direction values).
WIRE_DIRECTIONS: tuple[str, ...] = ("tx", "rx")


class UnknownTopicError(LookupError):
    """A topic (or wire port/direction) that is not in the topic table."""


class Encoding(enum.Enum):
    """Message encoding of a channel."""

    JSON = "json"
    PROTOBUF = "protobuf"


class Stamp(enum.Enum):
    """What the writer adds to a payload before encoding it."""

    SIM = "sim"  #: t_ns
    TIMING = "timing"  #: t_ns and t_host_ns
    FOXGLOVE = "foxglove"  #: timestamp {sec, nsec} = log time


@dataclass(frozen=True)
class TopicSpec:
    """One topic. ``schema`` is the JSON schema (dict); ``example`` is a payload as passed to
    ``Recorder.log`` (bytes for wire topics); ``units`` summarises units and frames for the docs."""

    topic: str
    schema_name: str
    schema: Mapping[str, Any]
    description: str
    units: str
    example: Any
    stamp: Stamp = Stamp.SIM
    defaults: Mapping[str, Any] = field(default_factory=dict)
    encoding: Encoding = Encoding.JSON
    #: protobuf: numbers as 32-bit floats (values that are float32 or coarser at the source)
    float32: bool = False
    #: nominal message rate at the default rig, for the docs ("" if irregular)
    rate: str = ""

    def schema_bytes(self) -> bytes:
        """The schema as registered in the MCAP file: UTF-8 JSON schema, or for protobuf the
        serialized ``FileDescriptorSet`` of ``schema_name``."""
        if self.encoding is Encoding.PROTOBUF:
            return _descriptor_set(self.schema_name, json.dumps(self.schema), self.float32)
        return json.dumps(self.schema, indent=1).encode()


@functools.lru_cache(maxsize=None)
def _descriptor_set(schema_name: str, schema_json: str, float32: bool) -> bytes:
    from hil.record.protobuf import file_descriptor_set

    return file_descriptor_set(schema_name, json.loads(schema_json), float32=float32)


# ---- schema builders (our own types) ------------------------------------------------------
def _num(desc: str) -> dict[str, Any]:
    return {"type": "number", "description": desc}


def _int(desc: str, minimum: int | None = None) -> dict[str, Any]:
    s: dict[str, Any] = {"type": "integer", "description": desc}
    if minimum is not None:
        s["minimum"] = minimum
    return s


def _bool(desc: str) -> dict[str, Any]:
    return {"type": "boolean", "description": desc}


def _str(desc: str) -> dict[str, Any]:
    return {"type": "string", "description": desc}


def _vec(n: int, desc: str, item: str = "number") -> dict[str, Any]:
    return {"type": "array", "items": {"type": item}, "minItems": n, "maxItems": n, "description": desc}


def _obj(desc: str, **props: dict[str, Any]) -> dict[str, Any]:
    return {"type": "object", "description": desc, "properties": props,
            "required": list(props), "additionalProperties": False}


def _free(desc: str) -> dict[str, Any]:
    # Foxglove needs "properties" even when empty; values still come through
    return {"type": "object", "description": desc, "properties": {}, "additionalProperties": True}


def _message(title: str, desc: str, stamp: Stamp, optional: tuple[str, ...] = (), /, *,
             open_: bool = False, **props: dict[str, Any]) -> dict[str, Any]:
    head: dict[str, Any] = {"t_ns": _int("sim time of the event, ns (0 = first IMU sample; boot is negative)")}
    if stamp is Stamp.TIMING:
        head["t_host_ns"] = _int("host CLOCK_MONOTONIC when the bench emitted/received it, ns")
    props = {**head, **props}
    return {"title": title, "description": desc, "$comment": "mav-hil-bench hil/record/topics.py",
            "type": "object", "properties": props,
            "required": [k for k in props if k not in optional], "additionalProperties": open_}


def _vendored(name: str) -> dict[str, Any]:
    return json.loads((SCHEMA_DIR / f"{name}.json").read_text())


_EULER = _obj("ZYX Euler angles, degrees", roll=_num("deg"), pitch=_num("deg"), yaw=_num("deg"))

WIRE = _message(  # the JSON form of recordings before the compact format (still read)
    "hil.WireChunk", "Raw bytes seen on one port in one direction (one transport read/write).",
    Stamp.TIMING,
    port=_str("port name"), direction={"type": "string", "enum": list(WIRE_DIRECTIONS),
                                       "description": "tx = bench->flight code, rx = flight code->bench"},
    len=_int("number of bytes", 0),
    data={"type": "string", "contentEncoding": "base64", "description": "the bytes, base64"})

#: sim time one wire message spans at most (and bytes it holds at most): one message per
#: transport read/write costs ~35 B of record and index each, more than the bytes themselves
WIRE_BATCH_NS = 100_000_000
WIRE_BATCH_BYTES = 16384
WIRE_CHUNKS = _message(
    "hil.WireChunks", "Raw bytes seen on one port in one direction: the transport reads/writes of "
    "up to 100 ms of sim time, concatenated in order. Chunk i is data[sum(chunk_len[:i]):][:chunk_len[i]], "
    "at sim time t_ns + sum(chunk_dt_ns[:i+1]) and host time t_host_ns + sum(chunk_dt_host_ns[:i+1]).",
    Stamp.TIMING, ("t_host_ns",),
    port=_str("port name"), direction={"type": "string", "enum": list(WIRE_DIRECTIONS),
                                       "description": "tx = bench->flight code, rx = flight code->bench"},
    len=_int("number of bytes (all chunks)", 0),
    data={"type": "string", "contentEncoding": "base64", "description": "the bytes (protobuf bytes)"},
    chunk_len={"type": "array", "items": {"type": "integer", "minimum": 0},
               "description": "bytes of each transport read/write"},
    chunk_dt_ns={"type": "array", "items": {"type": "integer"},
                 "description": "sim time of each chunk minus the previous one's (0 for the first), ns"},
    chunk_dt_host_ns={"type": "array", "items": {"type": "integer"},
                      "description": "host time of each chunk minus the previous one's (0 for the first), ns"})

SIM_TRUTH = _message(
    "hil.SimTruth", "Plant truth at the end of the tick (world NED, body FRD).", Stamp.SIM,
    p_N_m=_vec(3, "position, NED, m"), v_N_mps=_vec(3, "velocity, NED, m/s"),
    q_NB=_vec(4, "attitude quaternion (w, x, y, z), rotates FRD body vectors into NED"),
    euler_deg=_EULER, omega_B_radps=_vec(3, "body rates, FRD, rad/s"),
    rotor_omega_radps=_vec(4, "rotor speeds, rad/s, rotor order of the mixer"),
    thrust_N=_vec(4, "rotor thrusts, N"), h_m=_num("altitude above the field, m (= -p_N[2])"),
    battery_V=_num("battery terminal voltage, V"), battery_A=_num("battery current, A"),
    battery_soc=_num("battery state of charge, 0..1"), on_ground=_bool("resting on the ground"),
    wind_N_mps=_vec(3, "wind velocity, NED, m/s"), mass_kg=_num("vehicle mass incl. payload, kg"))

IMU_SAMPLE = _message(  # emulators.xsens.events.SampleSent; items the message does not carry are omitted
    "hil.ImuSample", "One XSENS data message as sent on the wire (its output frame and units).",
    Stamp.SIM, ("packet_counter", "sample_time_fine", "euler_deg", "rate_radps", "acc_mps2"),
    packet_counter=_int("PacketCounter (MTData2) or the legacy sample counter (MTData)", 0),
    sample_time_fine=_int("SampleTimeFine, 1e-4 s ticks (MTData2 only)", 0),
    euler_deg=_vec(3, "Euler angles (roll, pitch, yaw), deg, output frame"),
    rate_radps=_vec(3, "rate of turn, rad/s, sensor frame"),
    acc_mps2=_vec(3, "acceleration, m/s^2, sensor frame"), nbytes=_int("bytes of the whole frame", 0))

ADC_CONVERSION = _message(  # emulators.mcp3204.device.Mcp3204Conversion; the JSON form before the compact format
    "hil.AdcConversion", "One MCP3204 conversion answered to the flight code.", Stamp.SIM,
    ("single_ended", "vref_V", "port"),
    channel=_int("channel (single-ended input, or IN+ of the pair) 0..3", 0), code=_int("12-bit code 0..4095", 0),
    volts=_num("VIN at the sample instant, V"), single_ended=_bool("single-ended (else pseudo-differential)"),
    vref_V=_num("reference voltage, V"), port=_str("adc or adc-spidriver"))


def _list(desc: str, item: str, minimum: int | None = None) -> dict[str, Any]:
    items: dict[str, Any] = {"type": item}
    if minimum is not None:
        items["minimum"] = minimum
    return {"type": "array", "items": items, "description": desc}


ADC_CONVERSIONS = _message(  # one message per tick: the tick's conversions, in the order answered
    "hil.AdcConversions", "The MCP3204 conversions answered to the flight code during one tick, in order "
    "(item i of every list is conversion i).", Stamp.SIM, ("dt_ns", "single_ended", "vref_V", "port"),
    channel=_list("channel (single-ended input, or IN+ of the pair) 0..3", "integer", 0),
    code=_list("12-bit code 0..4095", "integer", 0), volts=_list("VIN at the sample instant, V", "number"),
    dt_ns=_list("sim time of the conversion minus t_ns, ns", "integer"),
    single_ended=_list("single-ended (else pseudo-differential)", "boolean"),
    vref_V=_list("reference voltage, V", "number"), port=_str("adc or adc-spidriver"))

RC_PULSES = _message(
    "hil.RcPulses", "RC receiver channel pulses of the frame delivered at t_ns.", Stamp.SIM,
    pulse_us=_vec(8, "channel pulse widths, us"), present=_bool("receiver signal present (no failsafe)"))

ESC_COMMAND = _message(
    "hil.EscCommand", "Maestro targets as received from the flight code.", Stamp.SIM,
    targets_us=_vec(4, "servo pulse targets, us (Maestro quarter-us resolution)"))

ESC_OUTPUT = _message(
    "hil.EscOutput", "ESC model state after the command was applied.", Stamp.SIM,
    throttle=_vec(4, "throttle 0..1"), armed=_vec(4, "ESC armed", "boolean"))

FC_TELEMETRY = _message(
    "hil.FcTelemetry", "Decoded telemetry frame from the flight code (free-form fields).", Stamp.SIM,
    open_=True)

TICK_TIMING = _message(
    "hil.TickTiming", "Per-tick loop timing.", Stamp.TIMING, ("host_latency_us", "fc_cpu_us", "lateness_us"),
    k=_int("tick index", 0), imu_emit_host_ns=_int("host time the IMU sample was written, ns"),
    esc_arrival_host_ns=_int("host time the ESC command arrived, ns (-1 if missed)"),
    latency_us=_num("IMU emit -> ESC command, us on the flight code's clock (sim time with virtual "
                    "time, host time otherwise); -1 if missed"),
    host_latency_us=_num("IMU written -> ESC command read, us of host time (-1 if missed)"),
    # double even in this float32 topic: the run summary's compute figures come from the same
    # values, and `hil timing` must reproduce them exactly
    fc_cpu_us={**_num("virtual time: the flight code's CPU time for this sample, us of this host, "
                      "unscaled (-1 if not measured)"), "format": "double"},
    lateness_us=_num("realtime: how late the tick that emitted the sample started against its wall "
                     "deadline, us of host time (-1 in lockstep)"),
    miss=_bool("no command before the deadline"))

EVENT = _message(
    "hil.Event", "Scenario, fault, run and device events.", Stamp.SIM,
    kind=_str("source: scenario, fault, run, device.<port> ..."), name=_str("event name"),
    detail=_free("event fields (free-form)"))

_CRITERION = {"type": "object", "description": "one criterion (hil.analysis.criteria.CriterionResult)",
              "properties": {"name": _str("criterion"), "signal": _str("trace signal"),
                             "metric": _str("metric"), "value": _num("measured value, signal units"),
                             "bound": _str("the bound, as written in the scenario"),
                             "passed": _bool("passed (true too when not judged: it does not fail the run)"),
                             "judged": _bool("false: not judged (a compute budget without a calibrated cpu_scale)"),
                             "margin": _num("to the nearest bound, >= 0 passes"), "detail": _str("free text")},
              "required": ["name", "passed"], "additionalProperties": False}
VERDICT = _message(
    "hil.Verdict", "How the run ended and the scenario's criteria results.", Stamp.SIM,
    ("end_reason", "message", "flight_returncode", "timing"),
    passed=_bool("the run completed and all criteria passed"), criteria={"type": "array", "items": _CRITERION},
    end_reason=_str("completed, flight exited, boot failed, interrupted, error ..."),
    message=_str("why it ended, free text"), flight_returncode=_int("flight code exit status (-1 if unknown)"),
    timing=_free("loop timing figures (name -> value)"))

DEVICE_COUNTERS = _message(
    "hil.DeviceCounters", "Periodic snapshot of every device's counters.", Stamp.SIM,
    counters=_free("device or port.<name> -> {counter name -> count}"))

_DT, _I, _B = "sim time of item i minus t_ns, ns", "integer", "boolean"
BOARD_SPI = _message(  # board runs (hil/flight/board_record.py): the pins' traffic no port carries
    "hil.BoardSpi", "SPI0's words and the ADC's /CS (P0.20) on the emulated LPC2148 (item i of each list: word or "
    "change i).", Stamp.SIM, dt_ns=_list(_DT, _I), mosi=_list("word sent", _I, 0), miso=_list("word back", _I, 0),
    cs_dt_ns=_list("/CS change i, " + _DT, _I), cs_level=_list("/CS after change i (true: high)", _B))
BOARD_ESC = _message("hil.BoardEsc", "ESC inputs from the pins (PWM2, PWM5, MAT1.2, MAT1.3 for ESC 0-3): from t_ns + "
                     "dt_ns[i] on, ESC esc[i] sees width_us[i] (0: no pulses).", Stamp.SIM, dt_ns=_list(_DT, _I),
                     esc=_list("ESC 0..3", _I, 0), width_us=_list("pulse width, us", "number"))
BOARD_CAPTURE = _message("hil.BoardCapture", "The PPM edges put on CAP1.0 (P0.10) and what Timer1's CR0 latched.",
                         Stamp.SIM, dt_ns=_list("edge i, " + _DT, _I), level=_list("level after edge i", _B),
                         cap_dt_ns=_list("capture i, " + _DT, _I), cap_value=_list("CR0 at capture i, us", _I, 0))
BOARD_TICK = _message("hil.BoardTick", "The emulated LPC2148 over one tick, in CCLK cycles (overruns: since reset).",
                      Stamp.SIM, ("cycles", "busy_cycles", "load_pct"), k=_int("tick", 0), cycles=_int("cycles", 0),
                      busy_cycles=_int("not in PCON idle", 0), load_pct=_num("busy / cycles, %"), irqs=_int("IRQs", 0),
                      irq_latency_max_cycles=_int("longest VIC request -> entry", 0),
                      uart0_rx_overruns=_int("UART0 chars lost", 0), uart1_rx_overruns=_int("UART1 chars lost", 0))
# ---- example payloads (docs and tests) ---------------------------------------------------
_EX_TRUTH = {
    "p_N_m": [0.1, -0.2, -1.5], "v_N_mps": [0.0, 0.05, -0.1], "q_NB": [0.9990482, 0.0, 0.0, 0.0436194],
    "euler_deg": {"roll": 0.0, "pitch": 0.0, "yaw": 5.0}, "omega_B_radps": [0.01, -0.02, 0.0],
    "rotor_omega_radps": [520.0, 521.0, 519.5, 520.5], "thrust_N": [2.45, 2.46, 2.44, 2.45], "h_m": 1.5,
    "battery_V": 11.9, "battery_A": 14.2, "battery_soc": 0.93, "on_ground": False,
    "wind_N_mps": [1.0, 0.5, 0.0], "mass_kg": 1.0}

_P = Stamp  # shorter table lines
_PB = Encoding.PROTOBUF
# fmt: off
_TABLE: list[TopicSpec] = [
    *[TopicSpec(f"/hil/wire/{p}/{d}", "hil.WireChunks", WIRE_CHUNKS, f"raw bytes on port {p}, {d}", "bytes; t_host_ns ns",
                b"\xfa\xff\x36\x00\xcb", _P.TIMING, encoding=_PB, rate="<= 10 Hz (100 ms batches)")
      for p in WIRE_PORTS for d in WIRE_DIRECTIONS],
    TopicSpec("/sim/truth", "hil.SimTruth", SIM_TRUTH, "plant truth per tick", "SI; NED world, FRD body", _EX_TRUTH,
              encoding=_PB, float32=True, rate="400 Hz / truth_divider (100 Hz)"),
    TopicSpec("/tf", "foxglove.FrameTransform", _vendored("foxglove.FrameTransform"),
              "world (ENU) -> base_link (FLU) from the truth", "m; quaternion (x, y, z, w)",
              {"parent_frame_id": "world", "child_frame_id": "base_link", "translation": {"x": -0.2, "y": 0.1, "z": 1.5},
               "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}, _P.FOXGLOVE, rate="400 Hz / pose_divider"),
    TopicSpec("/sim/pose", "foxglove.PoseInFrame", _vendored("foxglove.PoseInFrame"),
              "truth pose in frame world (ENU/FLU)", "m; quaternion (x, y, z, w)",
              {"frame_id": "world", "pose": {"position": {"x": -0.2, "y": 0.1, "z": 1.5},
                                             "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}, _P.FOXGLOVE,
              rate="400 Hz / pose_divider"),
    TopicSpec("/hil/imu/sample", "hil.ImuSample", IMU_SAMPLE, "XSENS sample as sent", "deg, rad/s, m/s^2; SampleTimeFine 1e-4 s",
              {"packet_counter": 17, "sample_time_fine": 42500, "euler_deg": [0.5, -1.0, 90.0],
               "rate_radps": [0.01, 0.0, -0.02], "acc_mps2": [0.1, -0.05, 9.81], "nbytes": 61},
              encoding=_PB, float32=True, rate="400 Hz"),
    TopicSpec("/hil/adc/conversion", "hil.AdcConversions", ADC_CONVERSIONS, "MCP3204 conversions of one tick", "code 0..4095; V",
              {"channel": [0, 1, 2, 3], "single_ended": [True] * 4, "code": [2048, 1650, 1651, 2480],
               "volts": [2.5, 1.65, 1.651, 2.48], "vref_V": [5.0] * 4}, encoding=_PB, float32=True, rate="400 Hz (one per tick)"),
    TopicSpec("/hil/rc/pulses", "hil.RcPulses", RC_PULSES, "RC pulses delivered", "us",
              {"pulse_us": [1500, 1500, 1100, 1500, 1900, 1100, 1500, 1500], "present": True},
              encoding=_PB, float32=True, rate="44 Hz (PPM frame)"),
    TopicSpec("/hil/esc/command", "hil.EscCommand", ESC_COMMAND, "Maestro targets received", "us",
              {"targets_us": [1100.0, 1100.25, 1100.5, 1100.0]}, encoding=_PB, float32=True, rate="400 Hz"),
    TopicSpec("/hil/esc/output", "hil.EscOutput", ESC_OUTPUT, "ESC throttles and arming", "0..1",
              {"throttle": [0.45, 0.46, 0.44, 0.45], "armed": [True, True, True, True]},
              encoding=_PB, float32=True, rate="400 Hz / truth_divider (100 Hz)"),
    TopicSpec("/fc/telemetry", "hil.FcTelemetry", FC_TELEMETRY, "decoded telemetry frames", "as decoded",
              {"frame": "status", "h_est_m": 1.49, "mode": "ALT_HOLD", "rssi": [-60, -61]}, rate="50 Hz"),
    TopicSpec("/fc/log", "foxglove.Log", _vendored("foxglove.Log"), "flight-code stdout/stderr lines", "level 1..5",
              {"level": 2, "message": "armed", "name": "flightcode.stdout"}, _P.FOXGLOVE, {"level": 2, "file": "", "line": 0}),
    TopicSpec("/hil/timing/tick", "hil.TickTiming", TICK_TIMING, "per-tick loop timing", "ns host monotonic; us",
              {"k": 400, "imu_emit_host_ns": 1_000_000_000, "esc_arrival_host_ns": 1_000_180_000,
               "latency_us": 180.0, "miss": False}, _P.TIMING, encoding=_PB, float32=True, rate="400 Hz"),
    TopicSpec("/hil/board/spi", "hil.BoardSpi", BOARD_SPI, "board: SPI0 words, ADC /CS", "ns", {"dt_ns": [0, 8000],
              "mosi": [6, 0], "miso": [255, 8], "cs_dt_ns": [-500], "cs_level": [False]}, encoding=_PB, rate="400 Hz"),
    TopicSpec("/hil/board/esc", "hil.BoardEsc", BOARD_ESC, "board: ESC inputs from the pins", "us", {"dt_ns": [0], "esc": [2], "width_us": [1213.0]}, encoding=_PB, float32=True, rate="on a change"),
    TopicSpec("/hil/board/capture", "hil.BoardCapture", BOARD_CAPTURE, "board: PPM edges on CAP1.0", "ns; us",
              {"dt_ns": [0], "level": [True], "cap_dt_ns": [0], "cap_value": [1300]}, encoding=_PB, rate="PPM edges"),
    TopicSpec("/hil/board/tick", "hil.BoardTick", BOARD_TICK, "board: load, interrupts, overruns", "CCLK cycles", {"k": 4,
              "cycles": 150000, "busy_cycles": 58000, "load_pct": 38.7, "irqs": 14, "irq_latency_max_cycles": 41,
              "uart0_rx_overruns": 0, "uart1_rx_overruns": 0}, encoding=_PB, float32=True, rate="400 Hz"),
    TopicSpec("/hil/events", "hil.Event", EVENT, "scenario, fault, run and device events", "as in detail",
              {"kind": "fault", "name": "imu_dropout", "detail": {"duration_s": 0.5}}),
    TopicSpec("/hil/verdict", "hil.Verdict", VERDICT, "end of run and criteria results", "signal units",
              {"passed": True, "end_reason": "completed", "message": "", "flight_returncode": 0,
               "criteria": [{"name": "hover_alt", "signal": "truth.h_m", "metric": "max_abs",
                             "value": 0.12, "bound": "<= 0.2", "passed": True, "detail": ""}],
               "timing": {"latency_p99_us": 210.0}}, rate="once"),
    TopicSpec("/hil/device/counters", "hil.DeviceCounters", DEVICE_COUNTERS, "device counters snapshot", "counts",
              {"counters": {"imu": {"bad_checksum": 0, "messages": 12}, "port.esc": {"bytes_rx": 400}}},
              rate="400 Hz / counters_divider"),
]
# fmt: on

TOPICS: Mapping[str, TopicSpec] = MappingProxyType({s.topic: s for s in _TABLE})
if len(TOPICS) != len(_TABLE):
    raise RuntimeError("hil/record/topics.py: a topic appears twice in _TABLE")


def topic_spec(topic: str) -> TopicSpec:
    """The table entry of ``topic``; ``UnknownTopicError`` if there is none."""
    try:
        return TOPICS[topic]
    except KeyError:
        raise UnknownTopicError(f"topic {topic!r} is not in hil/record/topics.py") from None


def wire_topic(port: str, direction: str) -> str:
    """``/hil/wire/<port>/<tx|rx>``; ``UnknownTopicError`` for an unknown port or direction."""
    topic = f"/hil/wire/{port}/{direction}"
    if topic not in TOPICS:
        raise UnknownTopicError(f"no wire topic for port {port!r} direction {direction!r} "
                                f"(ports {WIRE_PORTS}, directions {WIRE_DIRECTIONS})")
    return topic


def topics_markdown() -> str:
    """The topics table of docs/recording.md (wire topics folded into one row)."""
    rows = ["| topic | schema | encoding | rate | content | units / frames |", "|---|---|---|---|---|---|",
            f"| `/hil/wire/<port>/<tx\\|rx>` ({', '.join(WIRE_PORTS)}) | `hil.WireChunks` | protobuf | "
            "<= 10 Hz (100 ms batches) | raw bytes per port and direction (`data` bytes, `chunk_len`, "
            "`chunk_dt_ns`, `chunk_dt_host_ns`) | bytes; ns |"]
    for s in _TABLE:
        if not s.topic.startswith("/hil/wire/"):
            enc = s.encoding.value + (" (float32)" if s.float32 else "")
            rows.append(f"| `{s.topic}` | `{s.schema_name}` | {enc} | {s.rate or 'irregular'} | {s.description} | {s.units} |")
    return "\n".join(rows)
