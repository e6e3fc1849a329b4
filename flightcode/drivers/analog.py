"""ADC codes -> physical units: the barometer and accelerometer analog chains.

Chain (every constant comes from the config; defaults are the paper's vehicle and the
interim chain of the ADC notes, to be aligned with docs/analog-chain.md):

* MCP3204: ``code = floor(4096 v / vref_V)``; the inverse uses the bin centre,
  ``v = (code + 0.5) vref_V / 4096`` (unbiased for a uniformly distributed input).
* MPX5100AP (docs/protocols.md 3): ``v_sensor = supply_V (k_per_kPa P_kPa - offset_ratio)`` with
  k_per_kPa = 0.009, offset_ratio = 0.095, supply_V = 5 V; then the offset-and-gain stage
  ``v_adc = gain (v_sensor - offset_V) + ref_V`` (gain 16: 27.1 Pa / 16 = 1.7 Pa, i.e.
  0.14 m per code near sea level, docs/controllers.md 3.4). Default offset_V = 3.928375 V puts a
  sea-level field (101.325 kPa) at 2.5 V (mid-scale) on the ADC pin, as the bench's default
  rig does: 97.85..104.80 kPa fit into 0..5 V, about 290 m either way, room for the
  sensor's +-2.5 kPa unit error.
* Altitude: ISA troposphere (U.S. Standard Atmosphere 1976 layer 0),
  ``h(P) = T0/L (1 - (P/101325)^(R L / g0 M))``, relative to the pressure averaged at boot:
  ``z = h(P) - h(P_boot)`` (m, positive up).
* ADXL335 (docs/protocols.md 4), ratiometric: ``v = supply_V (zero_g_ratio + sens_ratio_per_g a_g)``
  per axis with supply 3.3 V, zero_g_ratio 0.5, sens_ratio_per_g 0.1 (330 mV/g); a_g is the
  specific force along the sensor axis in g. ``mount_B`` maps sensor axes to body FRD axes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

RESOLUTION_CODES = 4096
G0_MPS2 = 9.80665
ISA_P0_PA = 101_325.0
#: T0 / L = 288.15 K / 0.0065 K/m.
ISA_H_SCALE_M = 44_330.769
#: R* L / (g0 M) = 8.3144598 * 0.0065 / (9.80665 * 0.0289644).
ISA_EXPONENT = 0.190_263
_AXES = {"X": 0, "Y": 1, "Z": 2}


@dataclass(frozen=True)
class BaroChainParams:
    """``[adc.baro]``: MPX5100AP plus its offset-and-gain conditioning stage.

    Fields:
        supply_V: sensor supply Vs, V.
        k_per_kPa: transfer slope ratio, 1/kPa (datasheet 0.009).
        offset_ratio: transfer offset ratio (datasheet 0.095).
        gain: conditioning gain, V/V (1 = no stage).
        offset_V: sensor voltage subtracted before the gain, V.
        ref_V: voltage added after the gain, V.
        zero_average_s: sensor time averaged at boot for the altitude reference, s.
        rail_margin_V: a reading closer than this to either ADC rail is not a pressure, V
            (0.05: twice the 25 mV output swing limit of a rail-to-rail op-amp such as
            Microchip's MCP6002, datasheet DS21733; closer in, the stage is saturated or its
            input is open and floating to a rail).
    """

    __pydantic_config__ = {"extra": "forbid"}

    supply_V: float = 5.0
    k_per_kPa: float = 0.009
    offset_ratio: float = 0.095
    gain: float = 16.0
    offset_V: float = 3.928375  # 5 V x (0.009 x 101.325 - 0.095) - 2.5 V / 16
    ref_V: float = 0.0
    zero_average_s: float = 1.0
    rail_margin_V: float = 0.05


@dataclass(frozen=True)
class AccelChainParams:
    """``[adc.accel]``: ADXL335, ratiometric, and how it is mounted.

    Fields:
        supply_V: sensor supply Vs, V (<= 3.6 V for the ADXL335).
        zero_g_ratio: zero-g output as a fraction of Vs (0.5).
        sens_ratio_per_g: sensitivity as a fraction of Vs per g (0.1 -> 330 mV/g at 3.3 V).
        mount_B: for body axes x (forward), y (right), z (down): which sensor axis, with sign,
            measures it. Default ("+X", "-Y", "-Z"): the board flat, component side up, sensor
            X forward (sensor Y points left and Z up, so Z reads +1 g at rest).
    """

    __pydantic_config__ = {"extra": "forbid"}

    supply_V: float = 3.3
    zero_g_ratio: float = 0.5
    sens_ratio_per_g: float = 0.1
    mount_B: tuple[str, str, str] = ("+X", "-Y", "-Z")


def parse_mount(mount_B: tuple[str, str, str]) -> tuple[tuple[int, float], ...]:
    """("+X", "-Y", "-Z") -> ((0, 1.0), (1, -1.0), (2, -1.0)); ValueError if not a signed permutation."""
    out = []
    for entry in mount_B:
        if len(entry) != 2 or entry[0] not in "+-" or entry[1].upper() not in _AXES:
            raise ValueError(f"mount entry {entry!r}: expected a sign and an axis, like '+X' or '-Z'")
        out.append((_AXES[entry[1].upper()], 1.0 if entry[0] == "+" else -1.0))
    if sorted(axis for axis, _ in out) != [0, 1, 2]:
        raise ValueError(f"mount {list(mount_B)} must use each sensor axis X, Y, Z once")
    return tuple(out)


def isa_altitude_m(p_Pa: float) -> float:
    """ISA pressure altitude above the 101325 Pa level, m (troposphere)."""
    return ISA_H_SCALE_M * (1.0 - (p_Pa / ISA_P0_PA) ** ISA_EXPONENT)


class AnalogChain:
    """Converts MCP3204 codes of the baro and accelerometer channels to physical units.

    Args:
        vref_V: MCP3204 reference voltage, V.
        baro, accel: the two chains.
    """

    def __init__(self, vref_V: float, baro: BaroChainParams, accel: AccelChainParams) -> None:
        self.vref_V = vref_V
        self.baro = baro
        self.accel = accel
        self._v_per_code = vref_V / RESOLUTION_CODES
        margin_codes = max(0, math.ceil(baro.rail_margin_V / self._v_per_code))
        self._rail_lo_code = margin_codes  # codes at or inside these are refused
        self._rail_hi_code = RESOLUTION_CODES - 1 - margin_codes
        self._mount = parse_mount(accel.mount_B)
        self._acc_zero_V = accel.supply_V * accel.zero_g_ratio
        self._acc_mps2_per_V = G0_MPS2 / (accel.supply_V * accel.sens_ratio_per_g)

    def volts(self, code: int) -> float:
        """ADC input voltage at the centre of ``code``'s bin, V."""
        return (code + 0.5) * self._v_per_code

    def baro_pressure_Pa(self, code: int) -> float | None:
        """Absolute pressure, Pa; None if the code lies within ``rail_margin_V`` of either
        rail (the stage saturated, or an open input: out of range)."""
        if code <= self._rail_lo_code or code >= self._rail_hi_code:
            return None
        b = self.baro
        v_sensor = (self.volts(code) - b.ref_V) / b.gain + b.offset_V
        return (v_sensor / b.supply_V + b.offset_ratio) / b.k_per_kPa * 1000.0

    def accel_B_mps2(self, code_x: int, code_y: int, code_z: int) -> tuple[float, float, float]:
        """Specific force in body FRD, m/s^2 (about (0, 0, -9.81) level at rest)."""
        s = ((self.volts(code_x) - self._acc_zero_V) * self._acc_mps2_per_V,
             (self.volts(code_y) - self._acc_zero_V) * self._acc_mps2_per_V,
             (self.volts(code_z) - self._acc_zero_V) * self._acc_mps2_per_V)
        (ix, sx), (iy, sy), (iz, sz) = self._mount
        return (sx * s[ix], sy * s[iy], sz * s[iz])


class AccelRestOffset:
    """The accelerometer's offsets in body axes, learnt at rest during the boot averaging.

    At rest the specific force is ``f_B = R_NB^T (0, 0, -g)`` = (g sin(theta),
    -g sin(phi) cos(theta), -g cos(phi) cos(theta)) for the IMU's roll phi and pitch theta;
    the mean of ``measured - expected`` is each axis' zero-g offset (up to 0.5 g on X/Y and
    1 g on Z for an ADXL335, docs/analog-chain.md 5), plus the Z sensitivity error at 1 g,
    which flight at hover thrust sees too. An offset beyond ``limit_mps2`` on any axis is not
    a believable part (a loose connector, the board mounted otherwise than ``mount_B``): it is
    rejected and the offsets stay zero.
    """

    def __init__(self, limit_mps2: float = 1.5 * G0_MPS2) -> None:
        self.limit_mps2 = limit_mps2
        self._sum = [0.0, 0.0, 0.0]
        self._n = 0
        #: (x, y, z) offsets, m/s^2, subtracted from every reading once fixed.
        self.offset_B_mps2: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self.rejected = False

    def add(self, f_B_mps2: tuple[float, float, float], roll_rad: float, pitch_rad: float) -> None:
        """One reading at rest with the IMU's attitude."""
        sphi, cphi = math.sin(roll_rad), math.cos(roll_rad)
        sth, cth = math.sin(pitch_rad), math.cos(pitch_rad)
        s = self._sum
        s[0] += f_B_mps2[0] - G0_MPS2 * sth
        s[1] += f_B_mps2[1] + G0_MPS2 * sphi * cth
        s[2] += f_B_mps2[2] + G0_MPS2 * cphi * cth
        self._n += 1

    def fix(self) -> tuple[float, float, float]:
        """Average what was added; returns the offsets (zeros if none or rejected)."""
        if self._n:
            mean = (self._sum[0] / self._n, self._sum[1] / self._n, self._sum[2] / self._n)
            if max(abs(v) for v in mean) > self.limit_mps2:
                self.rejected = True
            else:
                self.offset_B_mps2 = mean
        return self.offset_B_mps2

    def correct(self, f_B_mps2: tuple[float, float, float]) -> tuple[float, float, float]:
        """A reading with the offsets removed, m/s^2 (body FRD)."""
        o = self.offset_B_mps2
        return (f_B_mps2[0] - o[0], f_B_mps2[1] - o[1], f_B_mps2[2] - o[2])


class BaroReference:
    """Averages the pressure over the first ``average_ns`` of sensor time; then gives altitude.

    ``add(p_Pa, t_ns)`` until :attr:`ready`; :meth:`altitude_m` is relative to that mean.
    """

    def __init__(self, average_ns: int) -> None:
        self.average_ns = average_ns
        self._t_first_ns: int | None = None
        self._sum = 0.0
        self._n = 0
        self.p_ref_Pa: float | None = None
        self._h_ref_m = 0.0

    @property
    def ready(self) -> bool:
        return self.p_ref_Pa is not None

    @property
    def samples(self) -> int:
        """Readings averaged so far."""
        return self._n

    def add(self, p_Pa: float, t_ns: int) -> bool:
        """Accumulate one reading; returns True once the reference is fixed."""
        if self.p_ref_Pa is not None:
            return True
        if self._t_first_ns is None:
            self._t_first_ns = t_ns
        self._sum += p_Pa
        self._n += 1
        if t_ns - self._t_first_ns >= self.average_ns:
            self.p_ref_Pa = self._sum / self._n
            self._h_ref_m = isa_altitude_m(self.p_ref_Pa)
        return self.p_ref_Pa is not None

    def altitude_m(self, p_Pa: float) -> float:
        """Height above the boot reference, m (positive up)."""
        return isa_altitude_m(p_Pa) - self._h_ref_m
