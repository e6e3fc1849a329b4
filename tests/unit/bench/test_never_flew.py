"""Every shipped flying scenario fails on a vehicle that never took off.

The trace is what a run records when the flight code never arms (an early failsafe, a
missed arming gesture): truth at rest on the ground with the IMU's small orientation bias,
ESCs at their minimum, telemetry flowing with zero references and torques. Each scenario's
criteria are evaluated on it; at least one must fail. (tests/system/test_scenarios.py flies
the hover without its arming gesture to show the same end to end.)
"""

from __future__ import annotations

import math
import re

import pytest

from hil.config import SCENARIOS_DIR
from hil.analysis.criteria import evaluate
from hil.config.scenario import load_scenario
from hil.analysis.trace import Trace

TICK_NS = 2_500_000
TM_PERIOD_NS = 20_000_000
SHIPPED = sorted(p.stem for p in SCENARIOS_DIR.glob("*.toml"))
#: scenarios that do not need to fly: arm-idle judges the vehicle on the ground
GROUND_ONLY: set[str] = {"arm-idle"}


def _ground_trace(duration_s: float, tm_names: set[str]) -> Trace:
    tr = Trace()
    tr.define(
        "truth",
        {
            "roll_deg": 1, "pitch_deg": 1, "yaw_deg": 1, "h_m": 1, "x_m": 1, "y_m": 1, "vz_mps": 1,
            "omega_B_degps": 3, "rotor_omega_radps": 4, "battery_V": 1, "mass_kg": 1, "on_ground": 1,
        },
    )  # fmt: skip
    tr.define("esc", {"cmd_us": 4, "throttle": 4, "armed": 4})
    tr.define("dev", {"adc_conversions": 1})
    n = int(duration_s * 1e9) // TICK_NS + 1
    for k in range(n):
        t = k * TICK_NS
        # a 0.2 deg orientation bias and a little sensor-like wobble: the "angles" of a
        # vehicle standing still
        bias = 0.2 + 0.01 * math.sin(k * 0.01)
        tr.row("truth", t, (bias, -bias, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 12.4, 1.1, 1.0))
        tr.row("esc", t, (1000.0,) * 4 + (0.0,) * 4 + (0.0,) * 4)
        tr.row("dev", t, (3.0 * k,))  # the ADC read at every sample, on the ground too
    for t in range(0, n * TICK_NS, TM_PERIOD_NS):
        for name in tm_names:
            tr.point(name, t, 0.0)
        tr.point("rc.throttle_us", t, 1000.0)
    return tr


def _tm_names(scenario) -> set[str]:
    names: set[str] = set()
    for c in scenario.criteria:
        for text in (c.signal, c.reference or ""):
            names |= set(re.findall(r"tm\.[A-Za-z0-9_]+", text))
    return names


@pytest.mark.parametrize("name", [s for s in SHIPPED if s not in GROUND_ONLY])
def test_scenario_fails_when_the_vehicle_never_took_off(name: str) -> None:
    scenario = load_scenario(SCENARIOS_DIR / f"{name}.toml")
    results = evaluate(scenario.criteria, _ground_trace(scenario.scenario.duration_s, _tm_names(scenario)))
    assert results, f"{name} has no criteria"
    failed = [r.name for r in results if not r.passed]
    assert failed, f"{name} passes on the ground: {[(r.name, r.value) for r in results]}"


@pytest.mark.parametrize("name", [s for s in SHIPPED if s not in GROUND_ONLY])
def test_scenario_says_it_must_have_flown(name: str) -> None:
    """Not only some criterion fails by luck: each flying scenario has an explicit lower
    bound on the height (a min or mean of truth.h_m with a positive minimum)."""
    scenario = load_scenario(SCENARIOS_DIR / f"{name}.toml")
    assert any(
        c.signal == "truth.h_m" and c.metric in {"min", "mean"} and c.min is not None and c.min > 0.5
        for c in scenario.criteria
    ), name
