"""Build the data messages' payloads from one measured sample.

Input: a :class:`~emulators.xsens.errors.Measured` sample (NED reference, FRD sensor frame)
plus the environment. Output: the MTData2 packets due at this instant, each in its XDI's
coordinate system and precision (frames.py), or a legacy MTData payload. Saturation at the
sensor ranges sets the clip bits of the status word and clears "orientation valid", as the
golden MTi-300 capture shows during a hard shake (0x00481401).
"""

from __future__ import annotations

import struct
from collections.abc import Iterable
from dataclasses import dataclass

from emulators.xsens import legacy
from emulators.xsens.defs import XDI, XDI_COORD_MASK, XDI_FORMAT_MASK, CoordSys, StatusFlag
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
from emulators.xsens.params import XsensParams

_CLIP_ACC = (StatusFlag.CLIP_ACC_X, StatusFlag.CLIP_ACC_Y, StatusFlag.CLIP_ACC_Z)
_CLIP_GYR = (StatusFlag.CLIP_GYR_X, StatusFlag.CLIP_GYR_Y, StatusFlag.CLIP_GYR_Z)
_U16, _U32 = struct.Struct(">H"), struct.Struct(">I")


@dataclass(frozen=True)
class Built:
    """A payload and what it carried (output frame values, None if absent)."""

    payload: bytes
    euler_deg: Vec3 | None
    rate_radps: Vec3 | None
    acc_mps2: Vec3 | None


def _clip(v: Vec3, limit: float, flags: tuple[StatusFlag, ...]) -> tuple[Vec3, int]:
    status, out = 0, []
    for x, flag in zip(v, flags, strict=True):
        if x > limit or x < -limit:
            status |= flag
            x = limit if x > 0 else -limit
        out.append(x)
    return (out[0], out[1], out[2]), status


class SampleBuilder:
    """Turns measured samples into payloads; holds the slowly varying environment."""

    def __init__(self, params: XsensParams) -> None:
        self.p = params
        self.temperature_degC = params.temperature_degC
        self.pressure_Pa = params.pressure_Pa
        self.alignment: tuple[Quat, Quat] = (Q_IDENTITY, Q_IDENTITY)

    def saturate(self, m: Measured) -> tuple[Measured, int]:
        """Clip at the sensor ranges; return the clipped sample and its status word."""
        f, s_acc = _clip(m.f_S_mps2, self.p.acc_range_mps2, _CLIP_ACC)
        w, s_gyr = _clip(m.omega_S_radps, self.p.gyro_range_radps, _CLIP_GYR)
        status = StatusFlag.SELFTEST_OK | s_acc | s_gyr
        if s_acc or s_gyr:
            status |= StatusFlag.CLIPPING_DETECTED
        else:
            status |= StatusFlag.ORIENTATION_VALID
        return Measured(m.q_NS, w, f), int(status)

    def _orientation(self, q_NS: Quat, coord: CoordSys) -> Quat:
        q = orientation_in(q_NS, coord)
        sensor, local = self.alignment
        if sensor is not Q_IDENTITY or local is not Q_IDENTITY:
            q = quat_normalize(quat_mul(quat_mul(local, q), sensor))
        return q

    def _vector(self, v_S: Vec3, coord: CoordSys) -> Vec3:
        v = vector_in(v_S, coord)
        sensor = self.alignment[0]
        return v if sensor is Q_IDENTITY else rotate_inv(sensor, v)

    def mtdata2(self, items: Iterable[tuple[int, int]], m: Measured, status: int, packet_counter: int,
                sample_time_fine: int, t_device_ns: int) -> Built:
        """MTData2 payload for ``(xdi, item period ns)`` pairs due now (period for DeltaV/Q)."""
        out = bytearray()
        euler = rate = acc = None
        for xdi, period_ns in items:
            kind = XDI(xdi & ~XDI_FORMAT_MASK & 0xFFFF)
            if kind is XDI.PACKET_COUNTER:
                data = _U16.pack(packet_counter & 0xFFFF)
            elif kind is XDI.SAMPLE_TIME_FINE:
                data = _U32.pack(sample_time_fine)
            elif kind is XDI.SAMPLE_TIME_COARSE:
                data = _U32.pack((t_device_ns // 1_000_000_000) & 0xFFFF_FFFF)
            elif kind is XDI.STATUS_WORD:
                data = _U32.pack(status & 0xFFFF_FFFF)
            elif kind is XDI.STATUS_BYTE:
                data = bytes((status & 0xFF,))
            elif kind is XDI.BARO_PRESSURE:
                data = _U32.pack(max(0, round(self.pressure_Pa)) & 0xFFFF_FFFF)
            else:
                coord = CoordSys(xdi & XDI_COORD_MASK)
                values = self._values(kind, coord, m, period_ns * 1e-9)
                if kind is XDI.EULER_ANGLES:
                    euler = (values[0], values[1], values[2])
                elif kind is XDI.RATE_OF_TURN:
                    rate = (values[0], values[1], values[2])
                elif kind is XDI.ACCELERATION:
                    acc = (values[0], values[1], values[2])
                data = encode_values(values, precision_of(xdi))
            out += xdi.to_bytes(2, "big")
            out.append(len(data))
            out += data
        return Built(bytes(out), euler, rate, acc)

    def _values(self, kind: XDI, coord: CoordSys, m: Measured, dt_s: float) -> tuple[float, ...]:
        if kind is XDI.EULER_ANGLES:
            return quat_to_euler_deg(self._orientation(m.q_NS, coord))
        if kind is XDI.QUATERNION:
            return self._orientation(m.q_NS, coord)
        if kind is XDI.ROTATION_MATRIX:
            rows = quat_to_matrix(self._orientation(m.q_NS, coord))
            return tuple(rows[r][c] for c in range(3) for r in range(3))
        if kind is XDI.ACCELERATION:
            return self._vector(m.f_S_mps2, coord)
        if kind is XDI.RATE_OF_TURN:
            return self._vector(m.omega_S_radps, coord)
        if kind is XDI.DELTA_V:
            return tuple(x * dt_s for x in self._vector(m.f_S_mps2, coord))
        if kind is XDI.DELTA_Q:
            return delta_q(self._vector(m.omega_S_radps, coord), dt_s)
        if kind is XDI.FREE_ACCELERATION:
            a = rotate(self._orientation(m.q_NS, coord), self._vector(m.f_S_mps2, coord))
            g = gravity_in(self.p.gravity_mps2, coord)
            return (a[0] + g[0], a[1] + g[1], a[2] + g[2])
        if kind is XDI.MAGNETIC_FIELD:
            return self._vector(rotate_inv(m.q_NS, self.p.mag_field_N_au), coord)
        if kind is XDI.TEMPERATURE:
            return (self.temperature_degC,)
        raise ValueError(f"no value model for {kind.name}")

    def legacy_sample(self, settings: int, m: Measured, status: int, counter: int) -> legacy.LegacySample:
        """The legacy sample in the frame settings bit 31 selects (NED, else NWU)."""
        coord = CoordSys.NED if legacy.is_ned(settings) else CoordSys.NWU
        return legacy.LegacySample(
            temperature_degC=self.temperature_degC,
            acc_mps2=self._vector(m.f_S_mps2, coord),
            rate_radps=self._vector(m.omega_S_radps, coord),
            mag_au=self._vector(rotate_inv(m.q_NS, self.p.mag_field_N_au), coord),
            q=self._orientation(m.q_NS, coord),
            status=status & 0xFF,
            sample_counter=counter,
        )
