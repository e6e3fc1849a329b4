"""Plant faults: the plant's truth while each is active and after it ends (ESCs driven over the
esc port as the flight code would, where thrust matters)."""

from __future__ import annotations

import math
from typing import Any

import pytest

from hil.faults import load_faults
from hil.config.rig import Rig
from tests.unit.faults.harness import Bench, S, arm_and_spin

SPIN_US = 1500.0  # ~0.48 throttle: rotors turn, the vehicle stays on the ground


async def spinning(rig: Rig, raw: list[dict[str, Any]]) -> Bench:
    b = Bench(rig, load_faults(raw, rig, source="test"))
    await arm_and_spin(b, SPIN_US)  # armed and spinning from 0.6 s
    return b


async def test_wind_step_for_its_duration(rig: Rig) -> None:
    b = Bench(rig, load_faults([{"kind": "plant.wind", "t_s": 0.1, "duration_s": 0.1, "wind_N_mps": [3, -1, 0]}],
                               rig, source="t"))
    clean = Bench(rig)
    winds = []
    for t_s in (0.0975, 0.1, 0.1975, 0.2):
        await b.run_to(t_s)
        await clean.run_to(t_s)
        w, w0 = b.devices.plant.state.wind_N_mps, clean.devices.plant.state.wind_N_mps
        winds.append(tuple(round(x - y, 9) for x, y in zip(w, w0)))
    assert winds == [(0, 0, 0), (3, -1, 0), (3, -1, 0), (0, 0, 0)]


async def test_gust_rises_peaks_and_is_gone_at_the_end(rig: Rig) -> None:
    raw = [{"kind": "plant.gust", "t_s": 0.1, "duration_s": 0.2, "peak_N_mps": [0, 4, 0]}]
    b, clean = Bench(rig, load_faults(raw, rig, source="t")), Bench(rig)
    ys = []
    ticks = (0.15, 0.2, 0.25, 0.3025)
    for t_s in ticks:
        await b.run_to(t_s)
        await clean.run_to(t_s)
        ys.append(b.devices.plant.state.wind_N_mps[1] - clean.devices.plant.state.wind_N_mps[1])
    # 1 - cos over [0.1, 0.3) s; the plant reports the wind it held over the last tick (t - 2.5 ms)
    expect = [2.0 * (1 - math.cos(2 * math.pi * min(t - 0.0025 - 0.1, 0.2) / 0.2)) for t in ticks]
    assert ys == pytest.approx(expect, abs=1e-6) and max(ys) > 3.9 and ys[-1] == 0.0
    assert [n for _, n, _ in b.fault_events()] == ["plant.gust start", "plant.gust end"]


async def test_payload_change_and_the_previous_payload_returns(rig: Rig) -> None:
    b = Bench(rig, load_faults([{"kind": "plant.payload", "t_s": 0.1, "duration_s": 0.1, "extra_mass_kg": 0.5,
                                 "r_B_m": [0.1, 0.0, 0.05]}], rig, source="t"))
    plant = b.devices.plant
    plant.set_payload(0.2, (0.0, 0.0, 0.1))  # a scenario event before the fault
    m0 = rig.plant.body.mass_kg
    await b.run_to(0.1)
    assert plant.state.mass_kg == pytest.approx(m0 + 0.5)
    start = b.fault_events(" start")[0][2]["changed"]
    assert start["previous_extra_mass_kg"] == pytest.approx(0.2)
    await b.run_to(0.2)
    assert plant.state.mass_kg == pytest.approx(m0 + 0.2)
    cg = plant.mass_properties.cg_B_m
    assert cg[0] == pytest.approx(0.0, abs=1e-12)  # back at the old payload's place too


async def test_motor_failure_stops_one_rotor_and_it_recovers(rig: Rig) -> None:
    b = await spinning(rig, [{"kind": "plant.motor_failure", "t_s": 1.0, "duration_s": 0.2, "rotor": 2}])
    await b.run_to(0.99)
    before = b.devices.plant.state.thrust_N
    assert min(before) > 0.5
    await b.run_to(1.1)
    during = b.devices.plant.state.thrust_N
    assert during[2] == 0.0 and min(during[0], during[1], during[3]) > 0.5
    await b.run_to(1.3)
    after = b.devices.plant.state.thrust_N
    assert after[2] == pytest.approx(after[0], rel=0.02)


async def test_thrust_losses_multiply_and_unwind(rig: Rig) -> None:
    raw = [
        {"kind": "plant.thrust_loss", "t_s": 1.0, "duration_s": 0.2, "rotor": 1, "thrust_factor": 0.5},
        {"kind": "plant.thrust_loss", "t_s": 1.1, "duration_s": 0.2, "rotor": 1, "thrust_factor": 0.8},
    ]
    b = await spinning(rig, raw)
    ratios = []
    for t_s in (1.05, 1.15, 1.25, 1.35):
        await b.run_to(t_s)
        th = b.devices.plant.state.thrust_N
        ratios.append(th[1] / th[3])  # rotor 3 shares rotor 1's spin direction
    assert ratios == pytest.approx([0.5, 0.4, 0.8, 1.0], abs=0.02)
    ends = [d["changed"]["thrust_factor"] for _, _, d in b.fault_events(" end")]
    assert ends == [0.8, 1.0]


async def test_battery_sag_drops_the_voltage_under_load(rig: Rig) -> None:
    raw = [{"kind": "plant.battery_sag", "t_s": 1.0, "duration_s": 0.2, "extra_ohm": 0.3}]
    b, clean = await spinning(rig, raw), await spinning(rig, [])
    for bench in (b, clean):
        await bench.run_to(1.1)
    s, c = b.devices.plant.state, clean.devices.plant.state
    assert c.battery_A > 3.0
    assert c.battery_V - s.battery_V == pytest.approx(0.3 * s.battery_A, rel=0.1)
    for bench in (b, clean):
        await bench.run_to(1.3)
    assert b.devices.plant.state.battery_V == pytest.approx(clean.devices.plant.state.battery_V, abs=0.01)
    assert math.isclose(b.t_ns / S, 1.3025)
