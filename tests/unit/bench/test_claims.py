"""Each shipped criterion that claims a reaction judges the reaction itself (issue: verdicts on
what the actuators do). Synthetic flights, built as the bench records them (per-tick truth and
ESC rows, 50 Hz telemetry points), each playing a flight code that did not react while a proxy
looks right: the claim's own criterion fails it, and the criterion that judged the proxy alone
still passes it (what the suite said before).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

from hil.analysis.criteria import CriterionResult, evaluate
from hil.analysis.criteria_stream import CriteriaStream
from hil.analysis.trace import Trace
from hil.analysis.trace_stream import TraceStream, TraceTee
from hil.config.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[3] / "rigs" / "scenarios"
TICK_NS = 2_500_000
FRAME_NS = 20_000_000  # telemetry at 50 Hz
DISARMED, FLYING, FAILSAFE_RC = 1, 3, 4

Row = Callable[[float], float]


def fly(scenario: str, *, h_m: Row, cmd_us: Row, throttle: Row, tm: dict[str, Row],
        tm_until_s: float = math.inf) -> dict[str, CriterionResult]:
    """The scenario's criteria on a synthetic flight (each row a function of sim seconds;
    telemetry sent until ``tm_until_s``), batch and streamed: the two must agree."""
    sc = load_scenario(SCENARIOS / f"{scenario}.toml")
    trace, stream = Trace(), TraceStream(horizon_ns=FRAME_NS)
    sink = TraceTee(trace, stream)
    sink.define("truth", {"roll_deg": 1, "pitch_deg": 1, "h_m": 1, "vz_mps": 1})
    sink.define("esc", {"cmd_us": 4, "throttle": 4, "armed": 4})
    sink.define("dev", {"adc_conversions": 1})
    streamed = CriteriaStream(sc.criteria, stream)
    for k in range(round(sc.scenario.duration_s * 1e9 / TICK_NS) + 1):
        t_ns = k * TICK_NS
        t_s = t_ns / 1e9
        if t_ns % FRAME_NS == 0 and t_s <= tm_until_s:
            for name, value in tm.items():
                sink.point(f"tm.{name}", t_ns, value(t_s))
        sink.row("truth", t_ns, (0.0, 0.0, h_m(t_s), 0.0))
        sink.row("esc", t_ns, (cmd_us(t_s),) * 4 + (throttle(t_s),) * 4 + (1.0,) * 4)
        sink.row("dev", t_ns, (float(k * 4),))
    batch, live = evaluate(sc.criteria, trace), streamed.results()
    for b, s in zip(batch, live, strict=True):
        assert (b.passed, b.detail) == (s.passed, s.detail), (b, s)
    return {r.name: r for r in batch}


def step(t_change_s: float, before: float, after: float) -> Row:
    return lambda t: before if t < t_change_s else after


def test_motors_judged_at_the_escs_not_only_in_the_commands_that_arrived() -> None:
    """The watchdog sent minimum pulses, but the motors kept their thrust (an ESC fed by
    something else, a Maestro that never applied them): the command criterion passes, the
    ESCs' throttle fails."""
    r = fly("fault-imu-silence", h_m=step(3.5, 0.0, 2.0), cmd_us=step(10.0975, 1450.0, 1000.0),
            throttle=lambda t: 0.72, tm={"mode": step(10.32, FLYING, DISARMED)})
    assert r["motors at minimum from the watchdog on"].passed
    claim = r["the ESCs ran the motors down from one PWM frame after the watchdog"]
    assert not claim.passed and math.isclose(claim.margin, 0.01 - 0.72), claim


def test_a_flight_code_silent_while_it_waits_is_judged_on_the_pulses_held() -> None:
    """No command at all after the silence began: the Maestro holds the last in-flight pulses,
    and the trace's esc.cmd_us is that held value at every tick, so the criterion fails."""
    r = fly("fault-imu-silence", h_m=step(3.5, 0.0, 2.0), cmd_us=lambda t: 1450.0, throttle=lambda t: 0.72,
            tm={"mode": step(10.32, FLYING, DISARMED)})
    assert not r["motors at minimum from the watchdog on"].passed
    assert not r["the ESCs ran the motors down from one PWM frame after the watchdog"].passed


def test_resuming_flight_after_the_imu_came_back_fails() -> None:
    r = fly("fault-imu-silence", h_m=step(3.5, 0.0, 2.0), cmd_us=step(10.0975, 1450.0, 1000.0),
            throttle=step(10.1, 0.72, 0.0), tm={"mode": lambda t: FLYING})
    assert r["motors at minimum from the watchdog on"].passed
    assert not r["disarmed once the IMU is back: the flight code reports DISARMED (1)"].passed


def test_an_rc_failsafe_that_never_disarms_on_the_ground_fails() -> None:
    """Landed at 18 s, collective wound down to zero (throttle 0), but still in FAILSAFE_RC:
    armed, it spins up when picked up. The throttle criterion passes; the mode's fails."""
    r = fly("fault-rc-loss", h_m=lambda t: 2.0 if t < 10.0 else max(0.0, 2.0 - 0.3 * (t - 10.0)),
            cmd_us=step(18.0, 1450.0, 1000.0), throttle=step(18.0, 0.72, 0.0),
            tm={"mode": step(10.5, FLYING, FAILSAFE_RC)})
    assert r["disarmed on the ground: motors stopped"].passed
    assert r["RC failsafe entered: the flight code reports FAILSAFE_RC (4) through the descent"].passed
    claim = r["disarmed on the ground: the flight code reports DISARMED (1)"]
    assert not claim.passed and claim.value == 0.0, claim


def test_an_rc_loss_landed_without_entering_the_failsafe_fails() -> None:
    """The vehicle came down (a landing flown in FLYING, say by a stick read as zero) but the
    flight code never said it lost the link."""
    r = fly("fault-rc-loss", h_m=lambda t: 2.0 if t < 10.0 else max(0.0, 2.0 - 0.3 * (t - 10.0)),
            cmd_us=step(18.0, 1450.0, 1000.0), throttle=step(18.0, 0.72, 0.0),
            tm={"mode": step(18.0, FLYING, DISARMED)})
    assert r["disarmed on the ground: the flight code reports DISARMED (1)"].passed
    assert not r["RC failsafe entered: the flight code reports FAILSAFE_RC (4) through the descent"].passed


def test_a_downlink_that_reports_a_refused_barometer_fails() -> None:
    """The barometer's wire is open (10-16 s); the flight code flies on without it, but tells
    the ground station a number, the rail's reading or a held one."""
    for reported in (lambda t: 2.0, lambda t: 2.0 if t < 10.0 or t > 16.0 else math.nan):
        r = fly("fault-baro-wire", h_m=step(3.5, 0.0, 2.0), cmd_us=lambda t: 1450.0, throttle=lambda t: 0.72,
                tm={"mode": lambda t: FLYING, "alt_baro_m": reported, "alt_est_m": lambda t: 2.0})
        claim = r["the downlink reports no barometric altitude while the barometer is refused"]
        assert claim.passed == (reported(12.0) != reported(12.0)), claim  # NaN only in the second


def test_telemetry_that_stopped_is_not_judged_on_its_last_frame() -> None:
    """The downlink dies at 9 s. The trace holds its last frame on the tick grid; judging that
    would pass "the altitude setpoint stays at 2 m" for 10 s nobody was told anything about."""
    tm = {"alt_ref_m": lambda t: 2.0, "rc_errors": lambda t: 0.0 if t < 10.0 else 3.0}
    kw = {"h_m": step(3.5, 0.0, 2.0), "cmd_us": lambda t: 1450.0, "throttle": lambda t: 0.72}
    flowing = fly("fault-rc-bit-errors", tm=tm, **kw)
    setpoint = "the altitude setpoint stays at the pilot's 2 m (within 0.1 m)"
    assert flowing[setpoint].passed
    stopped = fly("fault-rc-bit-errors", tm=tm, tm_until_s=9.0, **kw)
    claim = stopped[setpoint]
    assert not claim.passed and claim.margin == -math.inf
    assert claim.detail == ("no sample of tm.alt_ref_m arrived in [10, 20] s (a value held from before is not a "
                            "reading)"), claim.detail
