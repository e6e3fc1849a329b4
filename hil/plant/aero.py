"""Aerodynamics that are not plain drag: ground effect on thrust, rotor wash at the baro port.

Ground effect (Sanchez-Cuevas, Heredia, Ollero, "Characterization of the Aerodynamic Ground
Effect and Its Influence in Multirotor Control", Int. J. Aerospace Eng. 2017, Eq. 4), for
four coplanar rotors of radius R at height z above the ground, hub spacing d between
adjacent rotors and b across the diagonal (b = sqrt(2) d for a square layout, either X or +):

    T_IGE / T_OGE = 1 / (1 - (R/4z)^2 - R^2 z / (d^2 + 4 z^2)^1.5
                           - (R^2/2) z / (2 d^2 + 4 z^2)^1.5 - 2 R^2 K_b z / (b^2 + 4 z^2)^1.5)

It reduces to Cheeseman-Bennett's single-rotor 1 / (1 - (R/4z)^2) for d, b -> infinity and
K_b = 0. It is singular close to the ground, so the gain is capped; above ``cutoff_m`` it
differs from 1 by less than ``CUTOFF_GAIN`` and is taken as 1 (saves time at altitude).
The bench applies one gain to all rotors using the height of the level rotor plane.
"""

from __future__ import annotations

import math

from hil.plant.params_vehicle import AeroParams, RotorParams

#: Gains closer to 1 than this are treated as 1 (above cutoff_m).
CUTOFF_GAIN = 1e-4


class GroundEffect:
    """Thrust gain vs rotor-plane height above the ground (m)."""

    def __init__(self, aero: AeroParams, rotors: RotorParams) -> None:
        self.enabled = aero.ground_effect
        self.max_gain = aero.ground_effect_max_gain
        r = rotors.radius_m
        self._r2 = r * r
        self._r2_16 = r * r / 16.0
        self._d2 = 2.0 * rotors.arm_length_m**2  # adjacent hubs: l * sqrt(2) apart
        self._b2 = 4.0 * rotors.arm_length_m**2  # diagonal hubs: 2 l apart
        self._kb = aero.ground_effect_body_coeff
        self.cutoff_m = self._find_cutoff() if self.enabled else 0.0

    def _raw(self, z: float) -> float:
        """The formula's denominator at height z > 0."""
        z2 = 4.0 * z * z
        den: float = (
            1.0
            - self._r2_16 / (z * z)
            - self._r2 * z / (self._d2 + z2) ** 1.5
            - 0.5 * self._r2 * z / (2.0 * self._d2 + z2) ** 1.5
            - 2.0 * self._r2 * self._kb * z / (self._b2 + z2) ** 1.5
        )
        return den

    def _find_cutoff(self) -> float:
        # The gain falls monotonically with height beyond a rotor radius; double then bisect.
        lo = math.sqrt(self._r2)
        hi = 2.0 * lo
        while 1.0 / self._raw(hi) - 1.0 > CUTOFF_GAIN:
            lo, hi = hi, 2.0 * hi
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if 1.0 / self._raw(mid) - 1.0 > CUTOFF_GAIN:
                lo = mid
            else:
                hi = mid
        return hi

    def gain(self, z_m: float) -> float:
        """Thrust multiplier (>= 1) for a rotor plane ``z_m`` above the ground."""
        if not self.enabled or z_m >= self.cutoff_m:
            return 1.0
        if z_m <= 0.0:
            return self.max_gain
        # Same as _raw(z_m), inlined: this runs in every derivative near the ground.
        z2 = 4.0 * z_m * z_m
        r2 = self._r2
        den: float = (
            1.0
            - self._r2_16 / (z_m * z_m)
            - r2 * z_m / (self._d2 + z2) ** 1.5
            - 0.5 * r2 * z_m / (2.0 * self._d2 + z2) ** 1.5
            - 2.0 * r2 * self._kb * z_m / (self._b2 + z2) ** 1.5
        )
        if den * self.max_gain <= 1.0:
            return self.max_gain
        return 1.0 / den


class BaroWash:
    """Static-port pressure error (Pa, positive = overpressure, i.e. reads low) from rotor wash.

    ``dp = DL * (k_wash + k_ground * exp(-h / H))`` with DL the mean disk loading
    (total thrust / total disk area, Pa) and h the altitude above the resting height.
    """

    def __init__(self, aero: AeroParams, rotors: RotorParams) -> None:
        self._k_wash = aero.baro_prop_wash_gain
        self._k_ground = aero.baro_ground_effect_gain
        self._h_m = aero.baro_ground_effect_height_m
        self._disk_area_m2 = 4.0 * math.pi * rotors.radius_m**2

    def error_Pa(self, total_thrust_N: float, h_m: float) -> float:
        """Pressure error at the port for a total thrust (N) at altitude ``h_m`` (m)."""
        disk_loading_Pa = total_thrust_N / self._disk_area_m2
        return disk_loading_Pa * (self._k_wash + self._k_ground * math.exp(-max(h_m, 0.0) / self._h_m))
