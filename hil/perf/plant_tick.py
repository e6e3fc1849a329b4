"""Cost of one plant tick, for the performance budget (docs/performance.md, The plant in scalar Python).

``python -m hil.perf.plant_tick [n_ticks]`` prints the median and p99 cost in microseconds of
one 2.5 ms tick with the default sub-steps: ``step`` alone, and ``step`` + ``state`` +
``sensors()`` (what the bench does every tick). The vehicle hovers at 10 m in light
turbulence with throttles that wiggle around the hover value, so the rotor lag, drag and
wind paths all run. Host time comes from ``hil.clock`` (the only module that reads the OS
clock); this is a measuring tool, not part of the plant's numerics.
"""

from __future__ import annotations

import math
import sys

import numpy as np

from hil.clock import monotonic_ns
from hil.plant.params import PlantParams
from hil.plant.params_environment import WindParams
from hil.plant.plant import Plant


def _percentile(sorted_values: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(sorted_values), q))


def measure_tick_cost(n_ticks: int = 20_000, *, seed: int = 1, params: PlantParams | None = None) -> dict[str, float]:
    """Run ``n_ticks`` ticks and return costs in microseconds.

    Keys: ``n_ticks``, ``substeps``, ``step_median_us``, ``step_p99_us``,
    ``tick_median_us``, ``tick_p99_us`` (tick = step + state + sensors), ``budget_pct``
    (tick median as a percentage of the 2.5 ms tick).
    """
    if n_ticks < 1:
        raise ValueError("n_ticks must be >= 1")
    if params is None:  # the defaults, in a turbulent wind (the costliest case)
        params = PlantParams(wind=WindParams(mean_N_mps=(2.0, 1.0, 0.0), turbulence_sigma_N_mps=(0.5, 0.5, 0.2)))
    plant = Plant(params, np.random.default_rng(seed))
    om = plant.hover_rotor_omega_radps()
    plant.set_kinematic_state((0.0, 0.0, -10.0), rotor_omega_radps=(om, om, om, om))
    base = plant.hover_throttle()
    tick = params.tick_ns
    step_us: list[float] = []
    tick_us: list[float] = []
    for k in range(1, n_ticks + 1):
        wiggle = 0.02 * math.sin(0.01 * k)
        thr = (base + wiggle, base - wiggle, base + 0.5 * wiggle, base - 0.5 * wiggle)
        t0 = monotonic_ns()
        plant.step(k * tick, thr)
        t1 = monotonic_ns()
        _ = plant.state
        _ = plant.sensors()
        t2 = monotonic_ns()
        step_us.append((t1 - t0) / 1e3)
        tick_us.append((t2 - t0) / 1e3)
    step_us.sort()
    tick_us.sort()
    tick_median = _percentile(tick_us, 50)
    return {
        "n_ticks": float(n_ticks),
        "substeps": float(params.substeps),
        "step_median_us": _percentile(step_us, 50),
        "step_p99_us": _percentile(step_us, 99),
        "tick_median_us": tick_median,
        "tick_p99_us": _percentile(tick_us, 99),
        "budget_pct": 100.0 * tick_median * 1e3 / tick,
    }


def main(argv: list[str] | None = None) -> int:
    """Print the costs; optional first argument: number of ticks."""
    args = sys.argv[1:] if argv is None else argv
    n = int(args[0]) if args else 20_000
    r = measure_tick_cost(n)
    print(f"plant tick cost over {n} ticks, {int(r['substeps'])} RK4 sub-steps per 2.5 ms tick")
    print(f"  step only             median {r['step_median_us']:7.1f} us   p99 {r['step_p99_us']:7.1f} us")
    print(f"  step+state+sensors    median {r['tick_median_us']:7.1f} us   p99 {r['tick_p99_us']:7.1f} us")
    print(f"  = {r['budget_pct']:.1f} % of the 2.5 ms tick (median)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
