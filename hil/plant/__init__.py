"""The plant: 6-DOF quad-rotor, rotors with lag, battery, drag, ground effect and contact,
ISA atmosphere and wind. Pure numerics: no I/O, no clock, randomness only from the
Generator passed in.

Usage (what the bench does each 2.5 ms tick)::

    import numpy as np
    from hil.plant import Plant, PlantParams

    plant = Plant(PlantParams(), np.random.default_rng(seed_sequence.spawn(1)[0]))
    for k in range(1, n_ticks + 1):
        plant.step(k * 2_500_000, throttles)      # 4 ESC throttles in [0, 1], held
        truth = plant.state                        # PlantState (NED/FRD, SI units)
        sensed = plant.sensors()                   # SensorTruth for the emulators

Rig TOML (``[plant]`` and its sub-tables map onto PlantParams and its nested dataclasses;
every key is optional and defaults to the paper's vehicle)::

    [plant]
    substeps = 4
    [plant.body]
    mass_kg = 1.1
    inertia_B_kgm2 = [0.0153, 0.0153, 0.024]
    [plant.rotors]
    layout = "x"
    tau_up_s = 0.0125
    [plant.wind]
    mean_N_mps = [2.0, 0.0, 0.0]

Frames and numbering are described in ``hil/plant/params.py``.
"""

from hil.plant.params import (
    AeroParams,
    BatteryParams,
    BodyParams,
    EnvironmentParams,
    FrameLayout,
    GustParams,
    GustShape,
    PlantParams,
    RotorParams,
    SensorMountParams,
    VibrationParams,
    WindParams,
)
from hil.plant.plant import Plant, PlantState, SensorTruth
from hil.plant.rotors import throttle_from_pulse_us

__all__ = [
    "AeroParams",
    "BatteryParams",
    "BodyParams",
    "EnvironmentParams",
    "FrameLayout",
    "GustParams",
    "GustShape",
    "Plant",
    "PlantParams",
    "PlantState",
    "RotorParams",
    "SensorMountParams",
    "SensorTruth",
    "VibrationParams",
    "WindParams",
    "throttle_from_pulse_us",
]
