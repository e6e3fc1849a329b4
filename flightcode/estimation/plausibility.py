"""Plausibility of the ADC's converted readings, before the altitude filter sees them.

The Bus Pirate link checks its acks and the MCP3204's null bits, but a bit error in a data
byte with good acks around it is a valid-looking code (``wire.bit_flips`` on the bench: about
one reply in four at a bit error rate of 1e-2). Such a code is caught here from what the
sensors can physically produce, and the reading is treated as missing (counted):

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
  strapped to the same airframe).

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
        accel_max_g: largest believable specific force on any ADXL335 axis before the offset
            correction, g (5: the supply rails of a 3.3 V part at 330 mV/g).
        accel_xsens_tolerance_mps2: largest believable difference between the ADXL335's and
            the XSENS's vertical acceleration, m/s^2 (3: the ADXL335's 10 % sensitivity
            tolerance at 2 g plus its 50 Hz output filter's lag behind a touchdown).
    """

    __pydantic_config__ = {"extra": "forbid"}

    baro_max_step_Pa: float = 60.0
    accel_max_g: float = 5.0
    accel_xsens_tolerance_mps2: float = 3.0


class AdcPlausibility:
    """Judges each converted ADC reading; ``counters`` says how many were refused and why.

    Counters: ``baro_out_of_range``, ``baro_step``, ``accel_out_of_range``,
    ``accel_disagrees_xsens`` (one per refused reading).
    """

    def __init__(self, params: PlausibilityParams) -> None:
        self.params = params
        self._max_f_mps2 = params.accel_max_g * G0_MPS2
        self._p_prev_Pa: float | None = None
        self.counters: Counter[str] = Counter()

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
        if prev is not None and abs(p_Pa - prev) > self.params.baro_max_step_Pa:
            self.counters["baro_step"] += 1
            return None
        return p_Pa

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
