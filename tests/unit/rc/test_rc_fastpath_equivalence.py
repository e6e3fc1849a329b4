"""The RC chain's per-tick fast paths against the straightforward code they replaced.

``PpmGenerator._queue_edges`` computes edge times in Python floats instead of numpy arrays;
``CaptureFrontEnd.feed_edges`` packs each record with an unrolled CRC (``pack_fields``)
instead of building a ``CaptureRecord`` and calling ``pack_record``. The references below
are the previous code; the two must agree on every edge time and level, every record byte,
event and counter, and leave the jitter Generator in the same state.

Golden record: docs/rc-capture-format.md (``A5 17 00 34 12 D6``: seq 0x17, level low, no
overrun, capture 0x1234, CRC-8/SMBUS over bytes 1..4).
"""

from __future__ import annotations

from collections.abc import Iterable

import hypothesis.strategies as st
import numpy as np
from hypothesis import given, settings

from emulators.rc.capture import (
    CaptureFrontEnd,
    CaptureRecord,
    pack_fields,
    pack_record,
)
from emulators.rc.params import CaptureParams, PpmParams
from emulators.rc.ppm import NS_PER_US, PpmEdge, PpmGenerator
from emulators.rc.script import Setpoint, Sine, StickScript


class ReferencePpm(PpmGenerator):
    """Edge times with numpy arrays (the previous code)."""

    def _queue_edges(self, t0: int, pulses: list[tuple[float, float]]) -> None:
        p = self.params
        t_rel_ns = np.array([[a, b] for a, b in pulses], dtype=float).ravel() * NS_PER_US
        if p.jitter_us_rms > 0:
            jitter = self.rng.normal(0.0, p.jitter_us_rms * NS_PER_US, size=t_rel_ns.size)
            t_rel_ns += np.clip(jitter, -self._clip_ns, self._clip_ns)
        active = not p.idle_high
        for i, t_rel in enumerate(t_rel_ns):
            level = active if i % 2 == 0 else p.idle_high
            self._pending.append(PpmEdge(max(0, t0 + int(round(t_rel))), level))  # noqa: RUF046 - verbatim


def reference_feed_edges(cap: CaptureFrontEnd, edges: Iterable[PpmEdge]) -> None:
    """``CaptureFrontEnd.feed_edges`` as it was: one ``CaptureRecord`` and ``pack_record``
    per capture, acting on ``cap``'s state. (A function, not a subclass: the device classes
    are compiled, and compiled devices take no Python subclasses.)"""
    p = cap.params
    for edge in edges:
        if edge.t_ns < cap._last_edge_ns:
            cap.counters["edges_out_of_order"] += 1
            continue
        cap._last_edge_ns = edge.t_ns
        cap.counters["edges"] += 1
        if (cap._last_capture_ns is not None
                and edge.t_ns - cap._last_capture_ns < p.min_capture_interval_us * NS_PER_US):
            cap._lose(edge.t_ns, "latency")
            continue
        while cap._uart_starts and cap._uart_starts[0] <= edge.t_ns:
            cap._uart_starts.popleft()
        if len(cap._uart_starts) >= p.fifo_records:
            cap._lose(edge.t_ns, "fifo_full")
            continue
        cap._last_capture_ns = edge.t_ns
        rec = CaptureRecord(cap._seq, edge.level, cap._overrun, cap.timer_us(edge.t_ns))
        cap._seq = (cap._seq + 1) & 0xFF
        cap._overrun = False
        start = max(edge.t_ns, cap._uart_free_ns)
        cap._uart_free_ns = start + cap._record_ns
        if start > edge.t_ns:
            cap._uart_starts.append(start)
        cap._scheduled.append((edge.t_ns, pack_record(rec)))


def test_golden_record() -> None:
    assert pack_fields(0x17, False, False, 0x1234).hex(" ").upper() == "A5 17 00 34 12 D6"


@settings(deadline=None, max_examples=300)
@given(st.integers(0, 1000), st.booleans(), st.booleans(), st.integers(0, 0x1_0000_0000))
def test_pack_fields_is_pack_record(seq: int, level: bool, overrun: bool, capture_us: int) -> None:
    assert pack_fields(seq, level, overrun, capture_us) == pack_record(CaptureRecord(seq, level, overrun, capture_us))


FAULTS = st.lists(st.tuples(st.integers(0, 4), st.integers(0, 400_000_000), st.integers(1, 16), st.integers(0, 3000)),
                  max_size=6)


@settings(deadline=None, max_examples=80)
@given(st.integers(0, 2**16), st.sampled_from([0.0, 0.5, 5.0]), st.sampled_from([0.0, 2.0, 0.7, 40.0]),
       st.integers(1, 16), st.booleans(), FAULTS, st.lists(st.integers(1, 20_000_000), min_size=1, max_size=60),
       st.sampled_from([2.0, 30.0]), st.integers(1, 40), st.sampled_from([9600, 115_200, 1_000_000]))
def test_ppm_and_capture_match_the_reference(
    seed: int, jitter_us: float, clip_us: float, n_channels: int, idle_high: bool, faults: list[tuple[int, ...]],
    steps: list[int], min_capture_us: float, fifo: int, baud: int
) -> None:
    ppm_params = PpmParams(jitter_us_rms=jitter_us, jitter_clip_us=clip_us, n_channels=n_channels,
                           idle_high=idle_high)
    cap_params = CaptureParams(min_capture_interval_us=min_capture_us, fifo_records=fifo, baud=baud)
    script = StickScript([Setpoint(t_s=0.05, channel=3, pulse_us=1900, ramp_s=0.3),
                          Sine(t_s=0.0, duration_s=2.0, channel=1, amplitude_us=300.0, freq_hz=2.7, fade_s=0.1)])
    fast_rng, ref_rng = np.random.default_rng(seed), np.random.default_rng(seed)
    fast_ppm, ref_ppm = PpmGenerator(ppm_params, fast_rng, script), ReferencePpm(ppm_params, ref_rng, script)
    fast_cap, ref_cap = CaptureFrontEnd(cap_params), CaptureFrontEnd(cap_params)
    for kind, t, a, b in faults:
        for g in (fast_ppm, ref_ppm):
            if kind == 0:
                g.inject_loss(t, a * 1_000_000)
            elif kind == 1:
                g.inject_glitch(t, 10 + b % 50, a % 9)
            elif kind == 2:
                g.set_channel_count(t, a)
            else:
                g.set_stuck(t, a % 9, 900 + b if kind == 3 else None)
    t_ns = 0
    for dt in steps:
        t_ns += dt
        edges = fast_ppm.edges_until(t_ns)
        assert edges == ref_ppm.edges_until(t_ns)
        fast_cap.feed_edges(edges)
        reference_feed_edges(ref_cap, edges)
        fast_cap.advance(t_ns)
        ref_cap.advance(t_ns)
        assert fast_cap.take_output() == ref_cap.take_output()
        assert fast_cap.take_events() == ref_cap.take_events()
        assert list(fast_cap.counters.items()) == list(ref_cap.counters.items())
        assert (fast_ppm.counters, fast_ppm.level) == (ref_ppm.counters, ref_ppm.level)
        assert fast_ppm.take_frames() == ref_ppm.take_frames()
    assert fast_rng.bit_generator.state == ref_rng.bit_generator.state
