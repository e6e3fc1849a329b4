"""Plant parameters: frozen dataclasses whose defaults are the paper's vehicle.

Every field carries its unit in its name. Each class sets ``__pydantic_config__`` so that
``hil/config/files.py`` can validate a rig TOML table straight into it (unknown keys rejected);
these modules import nothing but the standard library. This module holds ``PlantParams``, the
rig's ``[plant]`` table, and gathers the classes it is made of: the vehicle's
(``params_vehicle.py``) and its environment's (``params_environment.py``).

Where a number comes from is said next to it:

* "Table 1"   - Wang/Ma/Sun, Table 1 (1.1 kg, 500 mm, 250 mm high, ~8000 rpm, 1 kg lift,
  3S 2100 mAh, 10 min flight), as read in docs/controllers.md section 1.
* "docs/controllers.md" - the paper's design re-derived (sections 2.3, 3.1).
* "protocols" - docs/protocols.md (section 3: ISA; section 6.1: motor lag).
* "assumed"   - not in any source; a physically plausible choice, change it in the rig.

Frames: body FRD with its origin at the hub centre, which is also the CG of the empty
vehicle; world NED. Rotor ``i`` is ESC channel ``i`` (0-based), numbered like the
ArduPilot/PX4 quad: X frame 0 front-right, 1 rear-left, 2 front-left, 3 rear-right;
+ frame 0 right, 1 left, 2 front, 3 back; rotors 0 and 1 spin counter-clockwise seen
from above, 2 and 3 clockwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from hil.plant.params_environment import (
    G0_MPS2,
    EnvironmentParams,
    GustParams,
    GustShape,
    Vec3,
    WindParams,
    _require,
)
from hil.plant.params_vehicle import (
    LIPO_CELL_OCV_V,
    LIPO_SOC_POINTS,
    ROTOR_ROTATING_MASS_KG,
    AeroParams,
    BatteryParams,
    BodyParams,
    FrameLayout,
    RotorParams,
    SensorMountParams,
    VibrationParams,
    iso1940_imbalance_kgm,
)

# Every parameter name stays importable from here: the rig maps ``[plant]`` onto
# ``hil.plant.params:PlantParams`` (hil/config/rig.py) and users import the others from here.
__all__ = [
    "G0_MPS2",
    "LIPO_CELL_OCV_V",
    "LIPO_SOC_POINTS",
    "ROTOR_ROTATING_MASS_KG",
    "AeroParams",
    "BatteryParams",
    "BodyParams",
    "EnvironmentParams",
    "FrameLayout",
    "GustParams",
    "GustShape",
    "PlantParams",
    "RotorParams",
    "SensorMountParams",
    "Vec3",
    "VibrationParams",
    "WindParams",
    "iso1940_imbalance_kgm",
]


@dataclass(frozen=True)
class PlantParams:
    """Everything the plant needs; the defaults are the paper's quad-rotor.

    ``tick_ns`` is the bench tick (400 Hz IMU period); each tick is integrated with
    ``substeps`` fixed RK4 steps.
    """

    __pydantic_config__ = {"extra": "forbid"}

    body: BodyParams = field(default_factory=BodyParams)
    rotors: RotorParams = field(default_factory=RotorParams)
    battery: BatteryParams = field(default_factory=BatteryParams)
    aero: AeroParams = field(default_factory=AeroParams)
    environment: EnvironmentParams = field(default_factory=EnvironmentParams)
    wind: WindParams = field(default_factory=WindParams)
    sensors: SensorMountParams = field(default_factory=SensorMountParams)
    vibration: VibrationParams = field(default_factory=VibrationParams)
    tick_ns: int = 2_500_000
    substeps: int = 4
    initial_yaw_rad: float = 0.0

    def __post_init__(self) -> None:
        _require(self.tick_ns > 0, "tick_ns must be > 0")
        _require(1 <= self.substeps <= 1000, "substeps must be in 1..1000")
        _require(math.isfinite(self.initial_yaw_rad), "initial_yaw_rad must be finite")
