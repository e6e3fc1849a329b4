"""ISA troposphere (U.S. Standard Atmosphere 1976, layer 0) with QNH and field elevation.

``p(h) = QNH * (1 - L h / T0) ** (g0 M / (R* L))`` with h the geometric height above mean
sea level (the troposphere form of docs/protocols.md section 3). Geometric height is used as
geopotential height, as the usual tables do; the difference, h^2 / R_earth, is 4 m at 5 km.
A QNH other than 101325 Pa is the altimeter setting: the same curve scaled, so a standard
altimeter set to QNH reads the true elevation. Temperature is ISA plus a constant deviation;
density follows from the ideal gas law.
"""

from __future__ import annotations

from mypy_extensions import mypyc_attr

from hil.plant.params_environment import EnvironmentParams

#: ISA sea-level constants (U.S. Standard Atmosphere 1976 / ISO 2533).
ISA_P0_PA = 101325.0
ISA_T0_K = 288.15
ISA_LAPSE_K_PER_M = 0.0065
ISA_G0_MPS2 = 9.80665
#: Molar mass of dry air (kg/mol) and the universal gas constant (J/(mol K)).
AIR_MOLAR_MASS_KG_PER_MOL = 0.0289644
GAS_CONSTANT_J_PER_MOL_K = 8.3144598
#: Specific gas constant of dry air, J/(kg K).
AIR_R_J_PER_KG_K = GAS_CONSTANT_J_PER_MOL_K / AIR_MOLAR_MASS_KG_PER_MOL
#: Pressure exponent g0 M / (R* L) = 5.25588 (docs/protocols.md 3).
ISA_EXPONENT = ISA_G0_MPS2 * AIR_MOLAR_MASS_KG_PER_MOL / (GAS_CONSTANT_J_PER_MOL_K * ISA_LAPSE_K_PER_M)
#: ISA sea-level density, kg/m^3 (1.2250).
ISA_RHO0_KGPM3 = ISA_P0_PA / (AIR_R_J_PER_KG_K * ISA_T0_K)
#: Top of the troposphere layer this model covers.
TROPOPAUSE_M = 11000.0
ZERO_C_K = 273.15


def isa_pressure_Pa(h_msl_m: float, qnh_Pa: float = ISA_P0_PA) -> float:
    """Static pressure (Pa) at ``h_msl_m`` metres above mean sea level (clamped to 0..11 km+)."""
    h = min(h_msl_m, TROPOPAUSE_M)
    p: float = qnh_Pa * (1.0 - ISA_LAPSE_K_PER_M * h / ISA_T0_K) ** ISA_EXPONENT
    return p


def isa_temperature_K(h_msl_m: float, offset_K: float = 0.0) -> float:
    """Air temperature (K) at ``h_msl_m`` on an ISA + ``offset_K`` day."""
    return ISA_T0_K + offset_K - ISA_LAPSE_K_PER_M * min(h_msl_m, TROPOPAUSE_M)


def air_density_kgpm3(p_Pa: float, T_K: float) -> float:
    """Dry-air density (kg/m^3) from the ideal gas law."""
    return p_Pa / (AIR_R_J_PER_KG_K * T_K)


@mypyc_attr(allow_interpreted_subclasses=True)
class Atmosphere:
    """The air around the vehicle, as a function of height above the field (m).

    ``h_field_m`` is the height above the ground surface of the field, so the field itself
    is at ``field_elevation_m`` above mean sea level.
    """

    def __init__(self, params: EnvironmentParams) -> None:
        self.params = params
        self._elev_m = params.field_elevation_m
        self._qnh_Pa = params.qnh_Pa
        self._dT_K = params.temperature_offset_K

    def pressure_Pa(self, h_field_m: float) -> float:
        """Static pressure (Pa)."""
        return isa_pressure_Pa(self._elev_m + h_field_m, self._qnh_Pa)

    def temperature_K(self, h_field_m: float) -> float:
        """Air temperature (K)."""
        return isa_temperature_K(self._elev_m + h_field_m, self._dT_K)

    def density_kgpm3(self, h_field_m: float) -> float:
        """Air density (kg/m^3)."""
        return air_density_kgpm3(self.pressure_Pa(h_field_m), self.temperature_K(h_field_m))

    def density_ratio(self, h_field_m: float) -> float:
        """Density relative to ISA sea level (rotor thrust and drag scale with it)."""
        return self.density_kgpm3(h_field_m) / ISA_RHO0_KGPM3
