"""Shared helpers for the plant tests (not a test module)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from hil.plant import AeroParams, BatteryParams, Plant, PlantParams

TICK_NS = 2_500_000
G = 9.80665

NO_DRAG = AeroParams(
    linear_drag_B_N_per_mps=(0.0, 0.0, 0.0),
    quadratic_drag_B_N_per_mps2=(0.0, 0.0, 0.0),
    rotor_drag_N_per_mps_per_radps=0.0,
    rotor_drag_vertical_N_per_mps_per_radps=0.0,
    flapping_moment_Nm_per_mps_per_radps=0.0,
    angular_drag_B_Nm_per_radps=(0.0, 0.0, 0.0),
)
#: A battery that never sags (zero resistance): omega_max only follows the (slow) charge.
STIFF_BATTERY = BatteryParams(internal_resistance_ohm=0.0)


def make_plant(params: PlantParams | None = None, seed: int = 1, **fields: object) -> Plant:
    """A plant with ``params`` (default: the paper's vehicle), fields replaced as given."""
    p = params or PlantParams()
    if fields:
        p = replace(p, **fields)  # type: ignore[arg-type]
    return Plant(p, np.random.default_rng(seed))


def hover_at(plant: Plant, h_m: float, **kwargs: object) -> float:
    """Place ``plant`` level at ``h_m`` with its rotors at the hover speed; returns that speed."""
    plant.set_kinematic_state((0.0, 0.0, -h_m), **kwargs)  # type: ignore[arg-type]
    om = plant.hover_rotor_omega_radps()
    plant.set_kinematic_state((0.0, 0.0, -h_m), rotor_omega_radps=(om, om, om, om), **kwargs)  # type: ignore[arg-type]
    return om


def run(plant: Plant, n_ticks: int, throttle: Sequence[float] | Callable[[Plant], Sequence[float]]) -> None:
    """Step ``n_ticks`` ticks; ``throttle`` is fixed or a function of the plant."""
    for _ in range(n_ticks):
        thr = throttle(plant) if callable(throttle) else throttle
        plant.step(plant.t_ns + TICK_NS, thr)
