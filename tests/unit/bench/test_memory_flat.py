"""The run's signals and criteria stream in flat memory: what a 10-minute flight keeps is what a
10 s flight keeps.

The run's trace stream and streaming criteria (a shipped scenario's criteria of every kind,
with the delay line and the held telemetry statistics the run keeps) are fed 10 s and 600 s of
synthetic 400 Hz rows with 50 Hz telemetry stamped before it arrives, as hil/flight/runlog.py feeds
them; tracemalloc measures what they hold at the end. A memory measurement with a bound, not a
timed assertion. (tests/bench/bench_memory.py measures a whole bench process.)
"""

from __future__ import annotations

import math

from hil.analysis.criteria_stream import CriteriaStream
from hil.flight.runlog import STAMP_MAX_AGE_NS
from hil.config.scenario import Criterion
from hil.analysis.signal_stream import Held
from hil.analysis.timing_stream import StreamingStats
from tests.unit.bench.traced import traced
from hil.analysis.trace_stream import TraceStream

TICK_NS = 2_500_000
TM_EVERY = 8  # telemetry at 50 Hz
TM_DELAY_TICKS = 6  # a frame arrives 15 ms after the sample it belongs to
TRUTH = {"roll_deg": 1, "pitch_deg": 1, "yaw_deg": 1, "h_m": 1, "x_m": 1, "y_m": 1, "vz_mps": 1,
         "omega_B_degps": 3, "rotor_omega_radps": 4, "battery_V": 1, "mass_kg": 1, "on_ground": 1}
ESC = {"cmd_us": 4, "throttle": 4, "armed": 4}

CRITERIA = [
    Criterion(name="min", signal="truth.h_m", metric="min", window_s=(8.0, 1e9), min=1.0),
    Criterion(name="max_abs", signal="truth.roll_deg", metric="max_abs", max=3.0),
    Criterion(name="rms", signal="truth.roll_deg - tm.roll_ref_deg", metric="rms", max=3.0),
    Criterion(name="std", signal="tm.alt_est_m - truth.h_m", metric="std", max=3.0),
    Criterion(name="rms_delta", signal="esc.cmd_us", metric="rms_delta", max=15.0),
    Criterion(name="saturated", signal="esc.cmd_us", metric="fraction_saturated", lo=1001, hi=1999, max=0.02),
    Criterion(name="final", signal="truth.h_m", metric="final", max=9.0),
    Criterion(name="lag", signal="truth.roll_deg", metric="phase_lag_deg", reference="tm.roll_ref_deg",
              freq_hz=2.0, max=90.0),
    Criterion(name="change", signal="tm.tau_roll_Nm", metric="rms_change_pct", window_s=(5.0, 1e9),
              baseline_window_s=(1.0, 5.0), max=50.0),
    Criterion(name="settle", signal="truth.h_m", metric="settling_time", step_t_s=3.0, step_size=1.0,
              band_fraction=0.05, max=1e9),
    Criterion(name="overshoot", signal="truth.h_m", metric="overshoot", step_t_s=3.0, step_size=1.0,
              min=-1.0, max=1.0),
    Criterion(name="rise", signal="truth.h_m", metric="rise_time", step_t_s=3.0, target=3.0, max=1e9),
]


def _flight(seconds: float) -> tuple[object, ...]:
    """The stream and its criteria after ``seconds`` of synthetic flight (kept alive)."""
    stream = TraceStream(horizon_ns=STAMP_MAX_AGE_NS + 100 * TICK_NS)
    stream.define("truth", TRUTH)
    stream.define("esc", ESC)
    criteria = CriteriaStream(CRITERIA, stream)
    compute, held = StreamingStats(), Held("tm.compute_last_us")
    stream.subscribe(lambda chunk: compute.extend(held.block(chunk)[1]))
    rest = (0.0,) * 13
    for k in range(int(seconds * 400)):
        t_ns = k * TICK_NS
        t_s = t_ns / 1e9
        roll = 2.0 * math.sin(4 * math.pi * t_s)
        h = 2.0 if t_s < 3.0 else 3.0 - math.exp(-(t_s - 3.0))
        if k % TM_EVERY == 0 and k >= TM_DELAY_TICKS:
            stamp = t_ns - TM_DELAY_TICKS * TICK_NS
            for name, v in (("tm.roll_ref_deg", roll), ("tm.alt_est_m", h), ("tm.tau_roll_Nm", 0.01 * roll),
                            ("tm.compute_last_us", 300.0 + k % 7)):
                stream.point(name, stamp, v)
        stream.row("truth", t_ns, (roll, 0.1, 0.0, h, *rest))
        stream.row("esc", t_ns, (1500.0 + roll, 1500.0, 1500.0, 1500.0, 0.5, 0.5, 0.5, 0.5, 1.0, 1.0, 1.0, 1.0))
    results = criteria.results()
    assert all(math.isfinite(r.value) for r in results), results
    assert stream.late_points == 0
    return stream, criteria, compute, held


def _fly(seconds: float) -> int:
    """Bytes the stream and its criteria hold after ``seconds`` of synthetic flight."""
    return traced(lambda: _flight(seconds))[1]


def test_a_10_minute_flight_holds_what_a_10_s_flight_holds() -> None:
    short, long = _fly(10.0), _fly(600.0)
    # the whole-run trace held 248 bytes a tick: 60 MB for these 10 minutes
    assert long - short < 100_000, (short, long)
    assert long < 1_000_000, long
