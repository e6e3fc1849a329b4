"""FaultSchedule: when faults apply and end, programmatic start/stop, logging, clean-up, and a
state machine checking that overlapping faults always combine to the right device settings."""

from __future__ import annotations

import math
from typing import Any

import hypothesis.strategies as st
import pytest
from hypothesis import settings
from hypothesis.stateful import Bundle, RuleBasedStateMachine, consumes, invariant, rule

from emulators.analog.frontend import AccelFault, BaroFault
from emulators.rc.script import StickScript
from hil.config import ConfigError
from hil.faults import FaultHandle, load_faults
from hil.config.rig import Rig, load_rig
from tests.unit.faults.harness import Bench, imu_samples

MS = 1_000_000


async def test_applied_on_the_first_tick_at_or_after_t_s_and_reverted_likewise(frig: Rig) -> None:
    raw = [{"kind": "imu.silence", "t_s": 0.0101, "duration_s": 0.005}]
    b = Bench(frig, load_faults(raw, frig, source="s.toml"))
    await b.tick(5)  # 0 .. 10 ms
    assert b.schedule.active() == [] and len(b.schedule.pending()) == 1
    await b.tick()  # 12.5 ms
    (a,) = b.schedule.active()
    assert (a.kind, a.target, a.t_start_ns, a.end_ns, a.params) == ("imu.silence", "imu", 10_100_000, 15_100_000, {})
    await b.tick(2)  # 15 ms: still on; 17.5 ms: off
    assert b.schedule.active() == [] and b.schedule.pending() == []
    (t0, n0, d0), (t1, n1, d1) = b.fault_events()
    assert (t0, n0, t1, n1) == (12_500_000, "imu.silence start", 17_500_000, "imu.silence end")
    assert d0 == {
        "handle": 1, "kind": "imu.silence", "target": "imu", "t_s": 0.0101, "duration_s": pytest.approx(0.005),
        "params": {}, "index": 0, "changed": {"streaming": False},
    }
    assert d1["why"] == "ended" and d1["active_s"] == pytest.approx(0.0074) and d1["changed"] == {"streaming": True}
    counters = [s["counter"] for s in imu_samples(b.received("imu"))]
    assert counters == [0, 1, 2, 3, 4, 7]  # samples at 12.5 and 15 ms silenced


async def test_same_time_faults_apply_in_file_order_and_overlap(rig: Rig) -> None:
    raw = [
        {"kind": "baro.bias", "t_s": 0.0, "duration_s": 0.01, "bias_Pa": 10.0},
        {"kind": "baro.bias", "t_s": 0.0, "bias_Pa": 5.0},
        {"kind": "baro.scale", "t_s": 0.005, "duration_s": 0.01, "scale": 1.01},
    ]
    b = Bench(rig, load_faults(raw, rig, source="s"))
    fe = b.devices.analog
    await b.tick()
    assert fe.baro_fault == BaroFault(bias_Pa=15.0) and [a.handle.id for a in b.schedule.active()] == [1, 2]
    await b.tick(2)
    assert fe.baro_fault == BaroFault(bias_Pa=15.0, scale=1.01)
    await b.tick(2)  # 10 ms: the first ends
    assert fe.baro_fault == BaroFault(bias_Pa=5.0, scale=1.01)
    await b.tick(2)  # 15 ms: the scale ends; the open-ended bias stays
    assert fe.baro_fault == BaroFault(bias_Pa=5.0)
    b.schedule.finish(b.t_ns)
    assert fe.baro_fault == BaroFault() and b.fault_events(" end")[-1][2]["why"] == "end of run"


async def test_start_now_and_stop(frig: Rig) -> None:
    b = Bench(frig)
    await b.tick(2)
    h = b.schedule.start_now("wire.silence", b.t_ns, port="imu")
    assert h == FaultHandle(1, "wire.silence")
    await b.tick(2)
    changed = b.schedule.stop(h, b.t_ns)
    assert changed["counts"]["tx_bytes_out"] == 0 and b.devices.wire_filters == {}
    await b.tick(2)
    counters = [s["counter"] for s in imu_samples(b.received("imu"))]
    assert counters == [0, 1, 4, 5]
    assert b.schedule.stop(h, b.t_ns) == {}  # already ended: nothing to do
    timed = b.schedule.start_now("imu.bias", b.t_ns, duration_s=0.005, gyro_bias_S_radps=[0.1, 0, 0])
    assert timed.id == 2 and b.devices.imu_motion is not None
    await b.tick(3)
    assert b.schedule.active() == [] and b.devices.imu_motion is None
    with pytest.raises(ConfigError, match=r"start_now\('wire.silence'\): \(wire.silence\) port: no port 'x'"):
        b.schedule.start_now("wire.silence", b.t_ns, port="x")
    with pytest.raises(ConfigError, match="unknown fault kind 'nope'"):
        b.schedule.start_now("nope", b.t_ns)


async def test_stop_cancels_a_fault_not_started_yet(rig: Rig) -> None:
    b = Bench(rig, load_faults([{"kind": "plant.battery_sag", "t_s": 1.0, "extra_ohm": 0.5}], rig, source="s"))
    assert b.schedule.stop(FaultHandle(1, "plant.battery_sag"), 0) == {}
    assert b.schedule.pending() == [] and b.fault_events()[0][1] == "plant.battery_sag cancelled"


async def test_finish_restores_every_device(rig: Rig) -> None:
    b = Bench(rig, script=StickScript([]))
    t = 0
    for kind, params in [
        ("imu.freeze", {}), ("rc.signal_loss", {}), ("wire.delay", {"port": "imu", "delay_s": 0.05}),
        ("accel.saturation", {}), ("esc.stuck", {"esc": 1, "throttle": 0.5}), ("telemetry.dropout", {}),
        ("adc.channel_open", {"channel": 3}), ("plant.motor_failure", {"rotor": 0}), ("adc.vref_drift", {"step_V": -1.0}),
    ]:
        b.schedule.start_now(kind, t, **params)
    await b.tick(4)
    assert type(b.devices.ppm.script) is not StickScript and b.devices.imu_motion is not None
    b.schedule.finish(b.t_ns)
    await b.tick(25)  # the delay releases what it held, then leaves the port
    d = b.devices
    assert d.imu_motion is None and type(d.ppm.script) is StickScript
    assert d.wire_filters == {} and d.analog.accel_fault == AccelFault() and d.mcp.vref_V == 5.0
    assert not d.escs[1]._stuck and b.schedule.env.rotors.factors() == [1.0] * 4
    assert b.schedule.env.link_loss.combined() == rig.telemetry.link.loss_probability
    assert len(b.fault_events(" end")) == 9


def test_rng_children_follow_file_order(rig: Rig) -> None:
    raw = [
        {"kind": "wire.bit_flips", "t_s": 5.0, "port": "imu", "bit_error_rate": 0.1},
        {"kind": "wire.bit_flips", "t_s": 1.0, "port": "rc", "bit_error_rate": 0.1},
    ]
    one = Bench(rig, load_faults(raw, rig, source="s")).schedule
    two = Bench(rig, load_faults(raw, rig, source="s")).schedule
    first = [e.fault.rng.random() for e in one._pending]
    assert first == [e.fault.rng.random() for e in two._pending]
    assert one._pending[0].spec.t_s == 1.0
    # a fault's draws depend on the seed and its place in the file, not on what follows it
    alone = Bench(rig, load_faults(raw[:1], rig, source="s")).schedule
    assert alone._pending[0].fault.rng.random() == first[1] != first[0]
    other_seed = Bench(rig, load_faults(raw[:1], rig, source="s"), seed=2).schedule
    assert other_seed._pending[0].fault.rng.random() != first[1]


# -- overlapping faults always combine to the right settings ---------------------------------------
RIG = load_rig(None)

SENSOR_FAULTS = st.one_of(
    st.tuples(st.just("baro.bias"), st.fixed_dictionaries({"bias_Pa": st.sampled_from([-30.0, 20.0, 50.0])})),
    st.tuples(st.just("baro.scale"), st.fixed_dictionaries({"scale": st.sampled_from([0.99, 1.02])})),
    st.tuples(st.just("baro.noise"), st.fixed_dictionaries({"noise_factor": st.sampled_from([2.0, 3.0])})),
    st.tuples(st.just("baro.freeze"), st.just({})),
    st.tuples(st.just("accel.bias"), st.fixed_dictionaries({"bias_B_mps2": st.sampled_from([(1.0, 0, 0), (0, 0, -2.0)])})),
    st.tuples(st.just("accel.saturation"), st.just({})),
    st.tuples(st.just("accel.scale"), st.fixed_dictionaries({"scale": st.sampled_from([1.1, 0.5])})),
    st.tuples(st.just("imu.bias"), st.fixed_dictionaries({"acc_bias_S_mps2": st.just((0.1, 0.0, 0.0))})),
    st.tuples(st.just("rc.signal_loss"), st.just({})),
    st.tuples(st.just("wire.silence"), st.fixed_dictionaries({"port": st.sampled_from(["imu", "rc", "ground"])})),
)


class Overlaps(RuleBasedStateMachine):
    """Random starts, stops and ticks; the devices' settings must equal the model's combination."""

    handles = Bundle("handles")

    def __init__(self) -> None:
        super().__init__()
        self.b = Bench(RIG)
        self.t_ns = 0
        self.model: dict[FaultHandle, tuple[str, dict[str, Any]]] = {}

    @rule(target=handles, fault=SENSOR_FAULTS)
    def start(self, fault: tuple[str, dict[str, Any]]) -> FaultHandle:
        kind, params = fault
        h = self.b.schedule.start_now(kind, self.t_ns, **params)
        self.model[h] = (kind, params)
        return h

    @rule(h=consumes(handles))
    def stop(self, h: FaultHandle) -> None:
        self.b.schedule.stop(h, self.t_ns)
        del self.model[h]

    @rule()
    def tick(self) -> None:
        self.t_ns += 2_500_000
        self.b.schedule.before_tick(self.t_ns)

    def _of(self, kind: str) -> list[dict[str, Any]]:
        return [p for k, p in self.model.values() if k == kind]

    @invariant()
    def baro_and_accel_combine(self) -> None:
        fe = self.b.devices.analog
        bias = sum(p["bias_Pa"] for p in self._of("baro.bias"))
        scale = math.prod(p["scale"] for p in self._of("baro.scale"))
        noise = math.prod(p["noise_factor"] for p in self._of("baro.noise"))
        bf = fe.baro_fault
        assert (bf.bias_Pa, bf.scale, bf.noise_factor) == pytest.approx((bias, scale, noise))
        assert bf.frozen == bool(self._of("baro.freeze"))
        ab = [sum(p["bias_B_mps2"][i] for p in self._of("accel.bias")) for i in range(3)]
        af = fe.accel_fault
        assert list(af.bias_mps2) == pytest.approx(ab)
        assert af.scale == pytest.approx(math.prod(p["scale"] for p in self._of("accel.scale")))
        assert af.saturate == bool(self._of("accel.saturation")) and not af.frozen

    @invariant()
    def wrappers_only_while_needed(self) -> None:
        d = self.b.devices
        assert (d.imu_motion is not None) == bool(self._of("imu.bias"))
        if self._of("rc.signal_loss"):  # (a closed window lingers until the sweep of the next tick)
            assert type(d.ppm.script) is not StickScript and d.ppm.script.signal_present(self.t_ns) is False
        assert set(d.wire_filters) == {p["port"] for p in self._of("wire.silence")}

    @invariant()
    def active_matches_the_model(self) -> None:
        assert {a.handle for a in self.b.schedule.active()} == set(self.model)


Overlaps.TestCase.settings = settings(deadline=None, max_examples=25, stateful_step_count=20)
TestOverlaps = Overlaps.TestCase
