"""Battery: open-circuit voltage vs charge, sag with current, coulomb counting."""

from __future__ import annotations

from itertools import pairwise

import pytest

from hil.plant import BatteryParams
from hil.plant.battery import Battery

from .support import TICK_NS, hover_at, make_plant, run


def test_open_circuit_voltage_follows_the_lipo_curve() -> None:
    b = Battery(BatteryParams())
    assert b.open_circuit_V(1.0) == pytest.approx(12.6)
    assert b.open_circuit_V(0.5) == pytest.approx(3 * 3.84)
    assert b.open_circuit_V(0.0) == pytest.approx(3 * 3.27)
    assert b.open_circuit_V(0.525) == pytest.approx(3 * (3.84 + 3.85) / 2)
    socs = [i / 100 for i in range(101)]
    volts = [b.open_circuit_V(s) for s in socs]
    assert all(v1 > v0 for v0, v1 in pairwise(volts))


def test_voltage_sags_with_current() -> None:
    b = Battery(BatteryParams())
    points = [b.operating_point(p, 0.8) for p in (0.0, 50.0, 100.0, 200.0, 300.0)]
    volts = [v for v, _, _ in points]
    amps = [i for _, i, _ in points]
    assert all(v1 < v0 for v0, v1 in pairwise(volts))
    assert all(i1 > i0 for i0, i1 in pairwise(amps))
    for (v, i, limited), p in zip(points, (0.0, 50.0, 100.0, 200.0, 300.0), strict=True):
        assert v == pytest.approx(12.6 - i * 0.04)
        assert (i - 0.5) * v == pytest.approx(p / 0.8)  # motor power delivered
        assert not limited
    b.extra_resistance_ohm = 0.2
    v_sagged, i_sagged, _ = b.operating_point(200.0, 0.8)
    assert v_sagged < volts[3] and i_sagged > amps[3]


def test_power_beyond_the_pack_is_limited() -> None:
    b = Battery(BatteryParams(internal_resistance_ohm=0.5))
    v, _, limited = b.operating_point(1000.0, 1.0)  # E^2/4R ~ 79 W available
    assert limited
    assert v == pytest.approx((12.6 - 0.5 * 0.5) / 2 + 0.0, rel=0.05)


def test_charge_is_counted() -> None:
    b = Battery(BatteryParams(avionics_current_A=0.0, internal_resistance_ohm=0.0))
    v0 = b.update(111.0, 1.0, 1.0)
    assert b.current_A == pytest.approx(111.0 / 12.6)
    drawn_As = b.current_A
    for _ in range(599):
        b.update(111.0, 1.0, 1.0)
        drawn_As += b.current_A
    assert 1.0 - b.soc == pytest.approx(drawn_As / (2.1 * 3600), rel=1e-12)
    assert b.voltage_V < v0 - 0.5  # voltage falls as the charge goes
    assert b.current_A > 111.0 / v0  # so the same power needs more current


def test_plant_battery_drains_and_sags_in_hover() -> None:
    plant = make_plant()
    hover_at(plant, 10.0)
    run(plant, 400, lambda p: [p.hover_throttle()] * 4)
    s = plant.state
    assert 9.0 < s.battery_A < 13.0  # ~11 A: the ~10 min flight of Table 1
    assert 2.1 / s.battery_A * 60 == pytest.approx(11.0, abs=1.5)
    assert s.battery_V == pytest.approx(plant._battery.open_circuit_V() - s.battery_A * 0.04)
    assert 1.0 - s.battery_soc == pytest.approx(s.battery_A * 400 * TICK_NS * 1e-9 / 7560, rel=0.02)
    thr = plant.hover_throttle()
    plant.set_battery_sag(0.3)
    assert plant.hover_throttle() > thr * 1.02  # more sag, less omega_max, more throttle
    run(plant, 4, [thr] * 4)
    assert plant.state.battery_V < s.battery_V - 2.0
