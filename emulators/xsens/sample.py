"""Build the data messages' payloads from one measured sample.

Input: a :class:`~emulators.xsens.errors.Measured` sample (NED reference, FRD sensor frame)
plus the environment. Output: the MTData2 packets due at this instant, each in its XDI's
coordinate system and precision (frames.py), or a legacy MTData payload. Saturation at the
sensor ranges sets the clip bits of the status word and clears "orientation valid", as the
golden MTi-300 capture shows during a hard shake (0x00481401).

Each configured item is decoded once into a :class:`Planned` record holding the function
that produces its bytes, so the 400 Hz path does no per-item type dispatch. A list of due
items whose floats are all float32/float64 is further compiled into one big-endian struct
(cached per list): the whole payload is then one ``pack`` of the headers and values, the
same bytes the per-item encoders give.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from mypy_extensions import mypyc_attr

from emulators.xsens import legacy
from emulators.xsens.defs import (
    XDI,
    XDI_COORD_MASK,
    XDI_FORMAT_MASK,
    CoordSys,
    Precision,
    StatusFlag,
)
from emulators.xsens.errors import Measured
from emulators.xsens.frames import (
    Q_IDENTITY,
    Quat,
    Vec3,
    delta_q,
    gravity_in,
    orientation_in,
    quat_mul,
    quat_normalize,
    quat_to_euler_deg,
    quat_to_matrix,
    rotate,
    rotate_inv,
    vector_in,
)
from emulators.xsens.mtdata2 import encode_values, precision_of
from emulators.xsens.output_config import ITEMS
from emulators.xsens.params import XsensParams

_CLIP_ACC = (int(StatusFlag.CLIP_ACC_X), int(StatusFlag.CLIP_ACC_Y), int(StatusFlag.CLIP_ACC_Z))
_CLIP_GYR = (int(StatusFlag.CLIP_GYR_X), int(StatusFlag.CLIP_GYR_Y), int(StatusFlag.CLIP_GYR_Z))
_OK = int(StatusFlag.SELFTEST_OK)
_VALID = int(StatusFlag.ORIENTATION_VALID)
_CLIPPED = int(StatusFlag.CLIPPING_DETECTED)
_U16, _U32 = struct.Struct(">H"), struct.Struct(">I")


@dataclass(frozen=True, init=False)
class Ctx:
    """Per-message inputs shared by the item encoders."""

    m: Measured
    status: int
    packet_counter: int
    sample_time_fine: int
    t_device_ns: int

    def __init__(self, m: Measured, status: int, packet_counter: int, sample_time_fine: int, t_device_ns: int) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "m", m)
        object.__setattr__(self, "status", status)
        object.__setattr__(self, "packet_counter", packet_counter)
        object.__setattr__(self, "sample_time_fine", sample_time_fine)
        object.__setattr__(self, "t_device_ns", t_device_ns)


@dataclass(frozen=True)
class Planned:
    """One configured MTData2 item, decoded once when the configuration is applied.

    ``period_ns`` None = in every message; ``dt_s`` is the interval DeltaV/DeltaQ span;
    ``report`` names the SampleSent field the item's values go to (or "").
    """

    xdi: int
    kind: XDI
    coord: CoordSys
    precision: Precision
    period_ns: int | None
    dt_s: float
    header: bytes
    encode: Callable[[SampleBuilder, Planned, Ctx], tuple[bytes, tuple[float, ...] | None]]
    report: str


def plan(items: Iterable[tuple[int, int | None]], message_period_ns: int) -> tuple[Planned, ...]:
    """Decode ``(xdi, period ns or None)`` pairs of a schedule into :class:`Planned` items."""
    out = []
    for xdi, period in items:
        kind = XDI(xdi & ~XDI_FORMAT_MASK & 0xFFFF)
        span = message_period_ns if period is None else period
        encode = _ENCODERS[kind]
        out.append(Planned(xdi, kind, CoordSys(xdi & XDI_COORD_MASK), precision_of(xdi), period, span * 1e-9,
                           xdi.to_bytes(2, "big"), encode, _REPORT.get(kind, "")))
    return tuple(out)


@dataclass(frozen=True, init=False)
class Built:
    """A payload and what it carried (output frame values, None if absent)."""

    payload: bytes
    euler_deg: Vec3 | None
    rate_radps: Vec3 | None
    acc_mps2: Vec3 | None

    def __init__(self, payload: bytes, euler_deg: Vec3 | None, rate_radps: Vec3 | None, acc_mps2: Vec3 | None) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "payload", payload)
        object.__setattr__(self, "euler_deg", euler_deg)
        object.__setattr__(self, "rate_radps", rate_radps)
        object.__setattr__(self, "acc_mps2", acc_mps2)


def _clip(v: Vec3, limit: float, flags: tuple[int, int, int]) -> tuple[Vec3, int]:
    x, y, z = v
    if -limit <= x <= limit and -limit <= y <= limit and -limit <= z <= limit:
        return v, 0
    status, out = 0, []
    for c, flag in zip(v, flags, strict=True):
        if c > limit or c < -limit:
            status |= flag
            c = limit if c > 0 else -limit
        out.append(c)
    return (out[0], out[1], out[2]), status


#: Most compiled item lists kept per builder (a configuration has one per distinct due set).
_MAX_PACKERS = 64


@mypyc_attr(allow_interpreted_subclasses=True)
class SampleBuilder:
    """Turns measured samples into payloads; holds the slowly varying environment."""

    def __init__(self, params: XsensParams) -> None:
        self.p = params
        self.temperature_degC = params.temperature_degC
        self.pressure_Pa = params.pressure_Pa
        self.alignment: tuple[Quat, Quat] = (Q_IDENTITY, Q_IDENTITY)
        #: ids of a due-item list -> its packer (None: not compilable). Each packer holds
        #: its items, so the ids in its key cannot be reused by other objects meanwhile.
        self._packers: dict[tuple[int, ...], _Packer | None] = {}

    def saturate(self, m: Measured) -> tuple[Measured, int]:
        """Clip at the sensor ranges; return the clipped sample and its status word."""
        f, s_acc = _clip(m.f_S_mps2, self.p.acc_range_mps2, _CLIP_ACC)
        w, s_gyr = _clip(m.omega_S_radps, self.p.gyro_range_radps, _CLIP_GYR)
        if not (s_acc or s_gyr):
            return m, _OK | _VALID
        return Measured(m.q_NS, w, f), _OK | s_acc | s_gyr | _CLIPPED

    def orientation(self, q_NS: Quat, coord: CoordSys) -> Quat:
        """Orientation in the output frame, alignment rotations applied."""
        q = orientation_in(q_NS, coord)
        sensor, local = self.alignment
        if sensor is not Q_IDENTITY or local is not Q_IDENTITY:
            q = quat_normalize(quat_mul(quat_mul(local, q), sensor))
        return q

    def vector(self, v_S: Vec3, coord: CoordSys) -> Vec3:
        """A sensor-frame vector in the output sensor frame, sensor alignment applied."""
        v = vector_in(v_S, coord)
        sensor = self.alignment[0]
        return v if sensor is Q_IDENTITY else rotate_inv(sensor, v)

    def mag_au(self, q_NS: Quat, coord: CoordSys) -> Vec3:
        return self.vector(rotate_inv(q_NS, self.p.mag_field_N_au), coord)

    def mtdata2(self, items: Iterable[Planned], ctx: Ctx) -> Built:
        """MTData2 payload of the planned items due now."""
        due = tuple(items)
        key = tuple(map(id, due))
        packers = self._packers
        if key in packers:
            packer = packers[key]
        else:
            if len(packers) >= _MAX_PACKERS:
                packers.clear()
            packer = packers[key] = _Packer.compile(due)
        if packer is None:
            return self.mtdata2_items(due, ctx)
        args: list[float | int] = []
        e = r = a = None
        m = ctx.m
        for xdi, size, int_value, float_values, it, report in packer.steps:
            args.append(xdi)
            args.append(size)
            if int_value is not None:
                args.append(int_value(self, ctx))
                continue
            assert float_values is not None
            values = float_values(self, it, m)
            args.extend(values)
            if report == "euler":  # a later item of the same kind overrides, as in mtdata2_items
                e = values
            elif report == "rate":
                r = values
            elif report == "acc":
                a = values
        return Built(packer.layout.pack(*args), None if e is None else (e[0], e[1], e[2]),
                     None if r is None else (r[0], r[1], r[2]), None if a is None else (a[0], a[1], a[2]))

    def mtdata2_items(self, items: Iterable[Planned], ctx: Ctx) -> Built:
        """:meth:`mtdata2` item by item with each item's encoder (any precision)."""
        out = bytearray()
        reported: dict[str, tuple[float, ...]] = {}
        for it in items:
            data, values = it.encode(self, it, ctx)
            if it.report and values is not None:
                reported[it.report] = values
            out += it.header
            out.append(len(data))
            out += data
        e, r, a = reported.get("euler"), reported.get("rate"), reported.get("acc")
        return Built(bytes(out), None if e is None else (e[0], e[1], e[2]), None if r is None else (r[0], r[1], r[2]),
                     None if a is None else (a[0], a[1], a[2]))

    def legacy_sample(self, settings: int, m: Measured, status: int, counter: int) -> legacy.LegacySample:
        """The legacy sample in the frame settings bit 31 selects (NED, else NWU)."""
        coord = CoordSys.NED if legacy.is_ned(settings) else CoordSys.NWU
        return legacy.LegacySample(
            temperature_degC=self.temperature_degC,
            acc_mps2=self.vector(m.f_S_mps2, coord),
            rate_radps=self.vector(m.omega_S_radps, coord),
            mag_au=self.mag_au(m.q_NS, coord),
            q=self.orientation(m.q_NS, coord),
            status=status & 0xFF,
            sample_counter=counter,
        )


# -- item encoders ---------------------------------------------------------------------------------
_Encoded = tuple[bytes, tuple[float, ...] | None]


_IntValue = Callable[[SampleBuilder, Ctx], int]

#: Integer items: big-endian struct code and value.
_INT_VALUES: dict[XDI, tuple[str, _IntValue]] = {
    XDI.PACKET_COUNTER: ("H", lambda b, c: c.packet_counter & 0xFFFF),
    XDI.SAMPLE_TIME_FINE: ("I", lambda b, c: c.sample_time_fine),
    XDI.SAMPLE_TIME_COARSE: ("I", lambda b, c: (c.t_device_ns // 1_000_000_000) & 0xFFFF_FFFF),
    XDI.STATUS_WORD: ("I", lambda b, c: c.status & 0xFFFF_FFFF),
    XDI.STATUS_BYTE: ("B", lambda b, c: c.status & 0xFF),
    XDI.BARO_PRESSURE: ("I", lambda b, c: max(0, round(b.pressure_Pa)) & 0xFFFF_FFFF),
}


def _int_item(code: str, fn: _IntValue) -> Callable[[SampleBuilder, Planned, Ctx], _Encoded]:
    packer = struct.Struct(">" + code)

    def encode(b: SampleBuilder, it: Planned, ctx: Ctx) -> _Encoded:
        return packer.pack(fn(b, ctx)), None

    return encode


_INT_ENCODERS: dict[XDI, Callable[[SampleBuilder, Planned, Ctx], _Encoded]] = {
    kind: _int_item(code, fn) for kind, (code, fn) in _INT_VALUES.items()
}


def _matrix(b: SampleBuilder, it: Planned, m: Measured) -> tuple[float, ...]:
    rows = quat_to_matrix(b.orientation(m.q_NS, it.coord))
    return tuple(rows[r][c] for c in range(3) for r in range(3))  # column-major


def _free_acc(b: SampleBuilder, it: Planned, m: Measured) -> tuple[float, ...]:
    a = rotate(b.orientation(m.q_NS, it.coord), b.vector(m.f_S_mps2, it.coord))
    g = gravity_in(b.p.gravity_mps2, it.coord)
    return (a[0] + g[0], a[1] + g[1], a[2] + g[2])


_VALUES: dict[XDI, Callable[[SampleBuilder, Planned, Measured], tuple[float, ...]]] = {
    XDI.EULER_ANGLES: lambda b, it, m: quat_to_euler_deg(b.orientation(m.q_NS, it.coord)),
    XDI.QUATERNION: lambda b, it, m: b.orientation(m.q_NS, it.coord),
    XDI.ROTATION_MATRIX: _matrix,
    XDI.ACCELERATION: lambda b, it, m: b.vector(m.f_S_mps2, it.coord),
    XDI.RATE_OF_TURN: lambda b, it, m: b.vector(m.omega_S_radps, it.coord),
    XDI.DELTA_V: lambda b, it, m: tuple(x * it.dt_s for x in b.vector(m.f_S_mps2, it.coord)),
    XDI.DELTA_Q: lambda b, it, m: delta_q(b.vector(m.omega_S_radps, it.coord), it.dt_s),
    XDI.FREE_ACCELERATION: _free_acc,
    XDI.MAGNETIC_FIELD: lambda b, it, m: b.mag_au(m.q_NS, it.coord),
    XDI.TEMPERATURE: lambda b, it, m: (b.temperature_degC,),
}
_REPORT = {XDI.EULER_ANGLES: "euler", XDI.RATE_OF_TURN: "rate", XDI.ACCELERATION: "acc"}


def _float_item(fn: Callable[[SampleBuilder, Planned, Measured], tuple[float, ...]]
                ) -> Callable[[SampleBuilder, Planned, Ctx], _Encoded]:
    def encode(b: SampleBuilder, it: Planned, ctx: Ctx) -> _Encoded:
        values = fn(b, it, ctx.m)
        return encode_values(values, it.precision), values

    return encode


_ENCODERS = {**_INT_ENCODERS, **{kind: _float_item(fn) for kind, fn in _VALUES.items()}}


_FloatValues = Callable[[SampleBuilder, Planned, Measured], tuple[float, ...]]
_FLOAT_CODES = {Precision.FLOAT32: "f", Precision.FLOAT64: "d"}


@dataclass(frozen=True)
class _Packer:
    """One list of due items as a single big-endian struct: per item ``H`` (XDI), ``B``
    (size) and its data. ``steps`` per item: (xdi, size, int value or None, float values
    or None, the item, its report name)."""

    items: tuple[Planned, ...]
    layout: struct.Struct
    steps: tuple[tuple[int, int, _IntValue | None, _FloatValues | None, Planned, str], ...]

    @staticmethod
    def compile(items: tuple[Planned, ...]) -> _Packer | None:
        """The packer of ``items``; None if an item needs the per-item path (fixed-point
        precision, or an encoder other than this module's)."""
        fmt = ">"
        steps: list[tuple[int, int, _IntValue | None, _FloatValues | None, Planned, str]] = []
        for it in items:
            if _ENCODERS.get(it.kind) is not it.encode:
                return None
            if it.kind in _INT_VALUES:
                code, int_value = _INT_VALUES[it.kind]
                size = struct.calcsize(">" + code)
                steps.append((it.xdi, size, int_value, None, it, it.report))
            else:
                float_code = _FLOAT_CODES.get(it.precision)
                if float_code is None:
                    return None
                n = ITEMS[it.kind].scalars
                code = f"{n}{float_code}"
                size = struct.calcsize(">" + code)
                steps.append((it.xdi, size, None, _VALUES[it.kind], it, it.report))
            if size > 255:
                return None
            fmt += "HB" + code
        return _Packer(items, struct.Struct(fmt), tuple(steps))
