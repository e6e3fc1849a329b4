"""The LiPo pack: open-circuit voltage from state of charge, ohmic sag, coulomb counting.

Model: ``V = cells * OCV_cell(soc) - I * (R + R_extra)``. The load is the motors' shaft
power (through the motor+ESC efficiency) plus a constant avionics current, so the current
solves ``(E - I_m R) I_m = P_shaft / efficiency`` with ``E = OCV - I_avionics R``: a
quadratic whose smaller root is the operating point. Beyond the pack's maximum power
(``E^2 / 4R``) the current stays at the maximum-power point and ``power_limited`` is set.
``soc`` falls by ``I dt / capacity`` and stops at 0 (the OCV curve is flat-ish there; a
real pack would collapse, and the plant counts ``battery_empty``).
"""

from __future__ import annotations

import bisect
import math

from hil.plant.params_vehicle import BatteryParams


class Battery:
    """State: ``soc`` (0..1); outputs the last ``voltage_V`` and ``current_A``."""

    def __init__(self, params: BatteryParams) -> None:
        self.params = params
        self.soc = params.soc_initial
        self.extra_resistance_ohm = 0.0
        self._soc_pts = params.soc_points
        self._ocv_pts = tuple(params.cells * v for v in params.cell_ocv_V)
        self._coulombs = params.capacity_Ah * 3600.0
        self.current_A = params.avionics_current_A
        self.voltage_V = self.open_circuit_V() - self.current_A * self.resistance_ohm
        self.power_limited = False

    @property
    def resistance_ohm(self) -> float:
        """Internal resistance plus any injected sag (ohm)."""
        return self.params.internal_resistance_ohm + self.extra_resistance_ohm

    def open_circuit_V(self, soc: float | None = None) -> float:
        """Pack open-circuit voltage (V) at ``soc`` (default: the current state)."""
        s = self.soc if soc is None else soc
        pts = self._soc_pts
        if s <= pts[0]:
            return self._ocv_pts[0]
        if s >= pts[-1]:
            return self._ocv_pts[-1]
        i = bisect.bisect_right(pts, s)
        s0, s1 = pts[i - 1], pts[i]
        v0, v1 = self._ocv_pts[i - 1], self._ocv_pts[i]
        return v0 + (v1 - v0) * (s - s0) / (s1 - s0)

    def operating_point(self, shaft_power_W: float, efficiency: float) -> tuple[float, float, bool]:
        """``(voltage_V, current_A, power_limited)`` for a motor shaft power (W), soc unchanged."""
        r = self.resistance_ohm
        i_av = self.params.avionics_current_A
        e = self.open_circuit_V() - i_av * r
        p = max(shaft_power_W, 0.0) / efficiency
        limited = False
        if p <= 0.0:
            i_m = 0.0
        elif r <= 0.0:
            i_m = p / e
        else:
            disc = e * e - 4.0 * r * p
            if disc < 0.0:
                disc = 0.0
                limited = True
            i_m = (e - math.sqrt(disc)) / (2.0 * r)
        current = i_m + i_av
        return e + i_av * r - current * r, current, limited

    def update(self, shaft_power_W: float, efficiency: float, dt_s: float) -> float:
        """Set the operating point for this load, drain for ``dt_s``; returns the voltage (V)."""
        self.voltage_V, self.current_A, self.power_limited = self.operating_point(shaft_power_W, efficiency)
        self.soc = max(0.0, self.soc - self.current_A * dt_s / self._coulombs)
        return self.voltage_V
