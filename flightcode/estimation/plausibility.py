"""Plausibility of the ADC's converted readings, before the altitude filter sees them.

The Bus Pirate link checks its acks, and the MCP3204 driver its null bits and each code against
its LSB-first repeat, which catches one bit flipped on the line. A valid-looking code can still
come: a flip of B0 (sent once), the same bit flipped in both copies, or a wrong value the sensor
or its analog chain produced (a rail, a stuck output, a step). Such a code is caught here from
what the sensors can physically produce, and the reading is treated as missing (counted):

* barometer: the pressure must lie in the MPX5100AP's rated range (15-115 kPa; codes at the
  ADC's rails are already refused by :class:`~flightcode.drivers.analog.AnalogChain`), and
  must not move more than ``baro_max_step_Pa`` from the previous reading: at 400 Hz the
  air around a vehicle changes by a few Pa a sample (5.3 Pa of noise per sample after the
  x16 stage, 12 Pa per metre), never by tens of Pa. The previous *reading* is the reference,
  accepted or not, so a genuine level shift costs one sample, never a lock-out; a reading
  that passes here but disagrees with the estimate is the altitude filter's gate's job;
* accelerometer (ADXL335): each axis' specific force must lie within ``accel_max_g`` (a
  ratiometric output cannot leave its supply rails: 0..3.3 V is -5..+5 g at 330 mV/g, and
  the datasheet's swing ends 0.1-0.2 V inside them; the top bit of a code flipped puts it
  beyond), and, once the boot offsets are removed, its vertical
  acceleration must agree with the XSENS's within ``accel_xsens_tolerance_mps2`` (both are
  strapped to the same airframe), and so must its mean: the difference low-passed over
  ``accel_offset_tau_s`` within ``accel_offset_max_mps2``. An ADXL335 whose offset moves in
  flight (its temperature drift, a supply that moves its ratiometric zero, vibration rectified
  by its output) is otherwise integrated into the height, and the barometer-motion check then
  refuses the barometer that disagrees with it: the estimate runs away. The XSENS's
  accelerometer is factory-calibrated over temperature; while the means disagree, the loop
  flies the altitude filter on it, until they agree within half the limit again.

Pure functions of their inputs plus the previous pressure: no I/O, no clock.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass

#: MPX5100AP rated pressure range, Pa (datasheet: 15 to 115 kPa).
MPX5100AP_RANGE_PA = (15_000.0, 115_000.0)
G0_MPS2 = 9.80665


@dataclass(frozen=True)
class PlausibilityParams:
    """``[plausibility]``: limits of believable ADC readings.

    Fields:
        baro_max_step_Pa: largest pressure change between consecutive readings, Pa (60 Pa:
            about 5 m of altitude in 2.5 ms, 9 sigma of the x16 chain's per-sample noise
            difference; a bit error in the top six bits of the code moves it further).
        baro_flat_readings: readings in the flat-line window (40: 0.1 s at 400 Hz, short, as
            the readings of a window that turns out flat were already fused); 0 turns the
            test off.
        baro_flat_std_Pa: readings whose standard deviation over that window is below this
            are a flat line, Pa (1.5 Pa = 0.13 m: a live sensor moves 5.3 Pa a reading, and
            its windows of 40 stayed above 3 Pa on the bench; a stuck one leaves the pin's
            0.5-0.65 Pa, windows below 0.9 Pa).
        accel_max_g: largest believable specific force on any ADXL335 axis before the offset
            correction, g (5: the supply rails of a 3.3 V part at 330 mV/g).
        accel_xsens_tolerance_mps2: largest believable difference between the ADXL335's and
            the XSENS's vertical acceleration, m/s^2 (3: the ADXL335's 10 % sensitivity
            tolerance at 2 g plus its 50 Hz output filter's lag behind a touchdown).
        accel_offset_tau_s: time constant of the low-pass over the two vertical accelerations'
            difference, s (1: the ADXL335's 50 Hz filter lag and the airframe's vibration
            average out, an offset that moved is seen within a few seconds).
        accel_offset_max_mps2: largest believable mean difference, m/s^2 (0.25; the clean
            suite stays below 0.14, transit's 16 deg of pitch the most; an offset of 0.6
            m/s^2 integrated over the barometer-motion check's window already refuses a
            healthy barometer).
        baro_motion_window_s: the barometer's height change is compared with the
            accelerometers' over this window, s (1.5; 0 turns the check off;
            :mod:`flightcode.estimation.baro_motion`).
        baro_motion_block_s: the blocks whose means are compared at the window's ends, s
            (0.25: 100 readings, one reading's 0.44 m of noise averages to 0.06 m).
        baro_motion_max_m: largest believable disagreement of the two changes, m (1.5: the
            inertial side's error budget over the window with room to spare, the suite's
            hardest manoeuvre uses 1.17 m of it; a blocked static port is seen once the
            vehicle has moved that much more than the filter followed it).
    """

    __pydantic_config__ = {"extra": "forbid"}

    baro_max_step_Pa: float = 60.0
    baro_flat_readings: int = 40
    baro_flat_std_Pa: float = 1.5
    accel_max_g: float = 5.0
    accel_xsens_tolerance_mps2: float = 3.0
    accel_offset_tau_s: float = 1.0
    accel_offset_max_mps2: float = 0.25
    baro_motion_window_s: float = 1.5
    baro_motion_block_s: float = 0.25
    baro_motion_max_m: float = 1.5


class AdcPlausibility:
    """Judges each converted ADC reading; ``counters`` says how many were refused and why.

    Counters: ``baro_out_of_range``, ``baro_flat``, ``baro_step``, ``accel_out_of_range``,
    ``accel_disagrees_xsens``, ``accel_offset_moved`` (one per refused reading).
    """

    def __init__(self, params: PlausibilityParams, T_s: float = 0.0025) -> None:
        self.params = params
        # the mean check's low-pass gain per sample, at the loop's period (T_s, s): fixed, as
        # the C twin keeps a division a sample off the ARM7's soft-float
        self._offset_alpha = T_s / (params.accel_offset_tau_s + T_s)
        self._max_f_mps2 = params.accel_max_g * G0_MPS2
        self._p_prev_Pa: float | None = None
        self._flat = FlatLine(params.baro_flat_readings, params.baro_flat_std_Pa) if params.baro_flat_readings else None
        self.counters: Counter[str] = Counter()
        self._offset_mps2 = 0.0  # low-passed ADXL335 - XSENS vertical acceleration
        self._offset_worst_mps2 = 0.0
        #: True while the ADXL335's mean disagrees with the XSENS's (its offset moved)
        self.offset_moved = False

    @property
    def refused(self) -> int:
        """Readings refused so far (all reasons)."""
        return sum(self.counters.values())

    def baro_Pa(self, p_Pa: float | None) -> float | None:
        """``p_Pa`` if believable, else None; None in (a missing reading) is None out.

        The step test needs the previous reading: the first one, and the first after a
        missing one, are judged on the range only.
        """
        if p_Pa is None:
            self._p_prev_Pa = None
            return None
        prev, self._p_prev_Pa = self._p_prev_Pa, p_Pa
        lo, hi = MPX5100AP_RANGE_PA
        if not (lo <= p_Pa <= hi):
            self.counters["baro_out_of_range"] += 1
            self._p_prev_Pa = None  # not a level to compare the next one with
            return None
        if self._flat is not None and self._flat.add(p_Pa):
            self.counters["baro_flat"] += 1
            return None
        if prev is not None and abs(p_Pa - prev) > self.params.baro_max_step_Pa:
            self.counters["baro_step"] += 1
            return None
        return p_Pa

    @property
    def baro_flat(self) -> bool:
        """True while the barometer's readings are a flat line (refused)."""
        return self._flat is not None and self._flat.flat

    def accel_in_range(self, f_B_mps2: tuple[float, float, float]) -> bool:
        """True if every axis of the ADXL335 reading is within ``accel_max_g`` (counted if not)."""
        m = self._max_f_mps2
        if all(math.isfinite(f) and -m <= f <= m for f in f_B_mps2):
            return True
        self.counters["accel_out_of_range"] += 1
        return False

    def accel_agrees(self, a_up_mps2: float, a_up_xsens_mps2: float) -> bool:
        """True if the ADXL335's vertical acceleration agrees with the XSENS's (counted if not)."""
        if abs(a_up_mps2 - a_up_xsens_mps2) <= self.params.accel_xsens_tolerance_mps2:
            return True
        self.counters["accel_disagrees_xsens"] += 1
        return False

    def accel_offset_holds(self, a_up_mps2: float, a_up_xsens_mps2: float) -> bool:
        """True while the ADXL335's mean vertical acceleration agrees with the XSENS's: their
        difference low-passed over ``accel_offset_tau_s`` (one step a reading, at the loop's
        period) within ``accel_offset_max_mps2``, and once beyond, back within half of it
        (counted when it does not hold). Call it for readings :meth:`accel_agrees` accepted."""
        p = self.params
        self._offset_mps2 += self._offset_alpha * (a_up_mps2 - a_up_xsens_mps2 - self._offset_mps2)
        size = abs(self._offset_mps2)
        self._offset_worst_mps2 = max(self._offset_worst_mps2, size)
        if self.offset_moved:
            self.offset_moved = size > 0.5 * p.accel_offset_max_mps2
        else:
            self.offset_moved = size > p.accel_offset_max_mps2
        if self.offset_moved:
            self.counters["accel_offset_moved"] += 1
        return not self.offset_moved

    def take_offset_worst(self) -> float:
        """The largest |low-passed difference| since the last call, m/s^2 (then reset)."""
        worst, self._offset_worst_mps2 = self._offset_worst_mps2, 0.0
        return worst


class FlatLine:
    """Is a signal a flat line? The standard deviation of its last ``n`` values below
    ``min_std`` (same unit as the values). O(1) a value: running sums over a ring, taken
    relative to a reference value (no cancellation at 1e5 Pa) and summed afresh at every
    turn of the ring (no drift over a flight).
    """

    def __init__(self, n: int, min_std: float) -> None:
        if n < 2:
            raise ValueError(f"a flat-line window needs at least 2 values, got {n}")
        self._ring = [0.0] * n
        self._i = 0
        self._full = False
        self._ref = 0.0
        self._s1 = 0.0
        self._s2 = 0.0
        self._min_var = min_std * min_std
        #: The last verdict of :meth:`add` (False until the window is full).
        self.flat = False

    def add(self, x: float) -> bool:
        """Take value ``x``; True if the window (this value and the ``n - 1`` before) is flat."""
        ring, n = self._ring, len(self._ring)
        if self._i == 0 and self._full:  # a turn of the ring: sums afresh around today's level
            self._ref = sum(ring) / n
            self._s1 = sum(v - self._ref for v in ring)
            self._s2 = sum((v - self._ref) ** 2 for v in ring)
        elif self._i == 0 and not self._full:
            self._ref = x
        d_old = ring[self._i] - self._ref
        d = x - self._ref
        if self._full:
            self._s1 -= d_old
            self._s2 -= d_old * d_old
        self._s1 += d
        self._s2 += d * d
        ring[self._i] = x
        self._i += 1
        if self._i == n:
            self._i = 0
            self._full = True
        if not self._full:
            self.flat = False
            return False
        mean = self._s1 / n
        self.flat = self._s2 / n - mean * mean < self._min_var
        return self.flat
