"""Plant faults: wind steps and gusts, payload changes, motor failure and thrust loss, battery sag.

They act through the plant's run-time hooks (hil/plant/plant.py): ``add_wind``/``add_gust``
/``remove_wind``, ``set_payload``, ``set_rotor_thrust_factor``, ``set_battery_sag``.
"""

from __future__ import annotations

from typing import Any, TypeVar

from pydantic import Field

from hil.faults.base import NS_PER_S, Fault, FaultParams, Layer, Timing, Vec3
from hil.plant.params import GustShape
from hil.plant.rigid_body import base_mass_properties

ROTOR_HELP = "rotor index 0..3 (ArduPilot quad numbering, hil/plant/params.py; ESC/Maestro channel i drives rotor i)"


class WindParams(FaultParams):
    wind_N_mps: Vec3 = Field(description="wind velocity, NED (blowing towards), m/s")


class WindStep(Fault[WindParams]):
    """A constant wind (step) added from t_s for duration_s (omitted: to the end)."""

    kind = "plant.wind"
    layer = Layer.PLANT
    Params = WindParams

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "wind"

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.handle = self.env.devices.plant.add_wind(self.params.wind_N_mps)
        return {"wind_N_mps": list(self.params.wind_N_mps)}

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.devices.plant.remove_wind(self.handle)
        return {"wind_N_mps": [0.0, 0.0, 0.0]}


class GustParams(FaultParams):
    peak_N_mps: Vec3 = Field(description="peak wind velocity of the gust, NED, m/s")
    shape: GustShape = Field(default=GustShape.ONE_MINUS_COSINE, description="'1-cos' (rises, peaks half-way, returns) or 'step'")


class Gust(Fault[GustParams]):
    """A discrete gust of peak ``peak_N_mps`` lasting duration_s (required)."""

    kind = "plant.gust"
    layer = Layer.PLANT
    timing = Timing.BOUNDED
    Params = GustParams

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "wind"

    def apply(self, t_ns: int) -> dict[str, Any]:
        assert self.end_ns is not None
        self.handle = self.env.devices.plant.add_gust(
            self.params.peak_N_mps, t_ns, self.end_ns - t_ns, self.params.shape
        )
        return {"peak_N_mps": list(self.params.peak_N_mps), "gust_s": (self.end_ns - t_ns) / NS_PER_S}

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.devices.plant.remove_wind(self.handle)
        return {"gust": "over"}


class PayloadParams(FaultParams):
    extra_mass_kg: float = Field(ge=0.0, le=2.0, description="payload mass, kg (0 drops any payload)")
    r_B_m: Vec3 = Field(default=(0.0, 0.0, 0.1), description="payload position from the body origin, body FRD, m")


class Payload(Fault[PayloadParams]):
    """The payload changes (picked up, dropped, shifted); the previous one returns at the end."""

    kind = "plant.payload"
    layer = Layer.PLANT
    Params = PayloadParams

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "payload"

    def _current(self) -> tuple[float, Vec3]:
        """The payload on board now (point mass), from the mass properties."""
        plant = self.env.devices.plant
        base = base_mass_properties(plant.params.body)
        now = plant.mass_properties
        extra = now.mass_kg - base.mass_kg
        if extra <= 1e-12:
            return 0.0, (0.0, 0.0, 0.1)
        r = tuple((now.mass_kg * now.cg_B_m[i] - base.mass_kg * base.cg_B_m[i]) / extra for i in range(3))
        return extra, (r[0], r[1], r[2])

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.previous = self._current()
        self.env.devices.plant.set_payload(self.params.extra_mass_kg, self.params.r_B_m)
        return {
            "extra_mass_kg": self.params.extra_mass_kg,
            "previous_extra_mass_kg": self.previous[0],
            "mass_kg": self.env.devices.plant.mass_properties.mass_kg,
        }

    def revert(self, t_ns: int) -> dict[str, Any]:
        mass, r = self.previous
        self.env.devices.plant.set_payload(mass, r)
        return {"extra_mass_kg": mass, "mass_kg": self.env.devices.plant.mass_properties.mass_kg}


class MotorFailureParams(FaultParams):
    rotor: int = Field(ge=0, le=3, description=ROTOR_HELP)


class ThrustLossParams(MotorFailureParams):
    thrust_factor: float = Field(ge=0.0, lt=1.0, description="remaining fraction of thrust and drag torque (0.7 = 30 % loss)")


RP = TypeVar("RP", bound=MotorFailureParams)


class _RotorFault(Fault[RP]):
    """Scales one rotor's thrust and drag torque (composers.RotorComposer)."""

    layer = Layer.PLANT

    @classmethod
    def target_of(cls, params: Any) -> str:
        return f"rotor {params.rotor}"

    @property
    def rotor(self) -> int:
        return int(self.params.rotor)

    @property
    def thrust_factor(self) -> float:
        raise NotImplementedError

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.env.rotors.add(self, t_ns)
        return {"rotor": self.rotor, "thrust_factor": self.env.rotors.factors()[self.rotor]}

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.rotors.remove(self, t_ns)
        return {"rotor": self.rotor, "thrust_factor": self.env.rotors.factors()[self.rotor]}


class ThrustLoss(_RotorFault[ThrustLossParams]):
    """Partial thrust loss of one rotor (damaged prop, weak motor)."""

    kind = "plant.thrust_loss"
    Params = ThrustLossParams

    @property
    def thrust_factor(self) -> float:
        return float(self.params.thrust_factor)


class MotorFailure(_RotorFault[MotorFailureParams]):
    """One motor (or its prop) fails: no thrust, no drag torque on that rotor."""

    kind = "plant.motor_failure"
    Params = MotorFailureParams

    @property
    def thrust_factor(self) -> float:
        return 0.0


class BatterySagParams(FaultParams):
    extra_ohm: float = Field(gt=0.0, le=10.0, description="added series resistance (aged pack, bad connector), ohm")


class BatterySag(Fault[BatterySagParams]):
    """The battery sags more under load: extra series resistance."""

    kind = "plant.battery_sag"
    layer = Layer.PLANT
    Params = BatterySagParams

    @classmethod
    def target_of(cls, params: Any) -> str:
        return "battery"

    @property
    def extra_ohm(self) -> float:
        return float(self.params.extra_ohm)

    def apply(self, t_ns: int) -> dict[str, Any]:
        self.env.battery.add(self, t_ns)
        return {"extra_ohm": sum(i.extra_ohm for i in self.env.battery.items)}

    def revert(self, t_ns: int) -> dict[str, Any]:
        self.env.battery.remove(self, t_ns)
        return {"extra_ohm": sum(i.extra_ohm for i in self.env.battery.items)}


FAULTS: tuple[type[Fault[Any]], ...] = (WindStep, Gust, Payload, MotorFailure, ThrustLoss, BatterySag)
