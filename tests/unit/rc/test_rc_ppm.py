"""PPM pulse train: timing measured from the generated edges, polarity, jitter, faults."""

from __future__ import annotations

import numpy as np
import pytest

from emulators.rc.params import PpmParams
from emulators.rc.ppm import PpmEdge, PpmGenerator
from emulators.rc.script import Loss, Setpoint, StickScript

MS = 1_000_000
S = 1_000_000_000


def separator_starts(edges: list[PpmEdge], idle_high: bool = True) -> list[int]:
    """Times of the edges that start a separator (leave the idle level)."""
    return [e.t_ns for e in edges if e.level != idle_high]


def split_frames(starts: list[int], sync_ns: int = 2_700_000) -> list[list[int]]:
    """Channel widths (ns) per frame, from separator starts; frames end at the sync gap."""
    frames: list[list[int]] = []
    cur: list[int] | None = None
    for a, b in zip(starts, starts[1:]):
        w = b - a
        if w >= sync_ns:
            if cur is not None:
                frames.append(cur)
            cur = []
        elif cur is not None:
            cur.append(w)
    return frames


def gen(script: StickScript | None = None, seed: int = 1, **kw: object) -> PpmGenerator:
    return PpmGenerator(PpmParams(**kw), np.random.default_rng(seed), script or StickScript())  # type: ignore[arg-type]


def test_frame_timing_measured_from_edges() -> None:
    script = StickScript([Setpoint(0.0, 1, 1100), Setpoint(0.0, 2, 1900), Setpoint(0.0, 4, 2000)])
    g = gen(script)
    edges = g.edges_until(1 * S)
    starts = separator_starts(edges)
    # Frame period: separators that follow a sync gap are 22.5 ms apart (+- jitter).
    frame_starts = [b for a, b in zip(starts, starts[1:]) if b - a >= 2_700_000]
    periods = np.diff(frame_starts) / 1e6
    assert len(periods) >= 40
    assert np.all(np.abs(periods - 22.5) < 0.005)
    frames = split_frames(starts)
    assert all(len(f) == 8 for f in frames)
    want = np.array([1100, 1900, 1000, 2000, 1000, 1000, 1000, 1000])
    for f in frames:
        assert np.all(np.abs(np.array(f) / 1e3 - want) < 4.5)  # 2 x 2 us jitter clip
    # Sync gap: last separator start to next frame's first separator start.
    gaps = [b - a for a, b in zip(starts, starts[1:]) if b - a >= 2_700_000]
    assert min(gaps) / 1e6 == pytest.approx(22.5 - want.sum() / 1e3, abs=0.005)
    assert min(gaps) >= 2_700_000


def test_separator_width_and_alternating_levels() -> None:
    edges = gen().edges_until(100 * MS)
    levels = [e.level for e in edges]
    assert all(a != b for a, b in zip(levels, levels[1:]))
    seps = [b.t_ns - a.t_ns for a, b in zip(edges, edges[1:]) if not a.level]
    assert np.all(np.abs(np.array(seps) / 1e3 - 300) < 4.5)
    assert all(b.t_ns >= a.t_ns for a, b in zip(edges, edges[1:]))


def test_worst_case_frame_leaves_sync_gap() -> None:
    g = gen(StickScript([Setpoint(0.0, ch, 2000) for ch in range(1, 9)]))
    starts = separator_starts(g.edges_until(500 * MS))
    gaps = [b - a for a, b in zip(starts, starts[1:]) if b - a > 2_500_000]
    assert min(gaps) >= 6_490_000  # 22.5 - 8 x 2.0 ms


def test_stretched_frame_when_channels_too_long() -> None:
    g = gen(StickScript([Setpoint(0.0, 1, 2000)], max_us=2000), n_channels=8, frame_us=18_000)
    starts = separator_starts(g.edges_until(200 * MS))
    gaps = [b - a for a, b in zip(starts, starts[1:]) if b - a > 2_500_000]
    assert min(gaps) >= 2_990_000  # min_sync_us = 3000 enforced


def test_inverted_polarity() -> None:
    g = gen(idle_high=False)
    edges = g.edges_until(50 * MS)
    assert edges[0].level is True  # separators are high pulses
    frames = split_frames(separator_starts(edges, idle_high=False))
    assert frames and len(frames[0]) == 8


def test_seeded_jitter_is_deterministic_and_bounded() -> None:
    a = gen(seed=7).edges_until(200 * MS)
    b = gen(seed=7).edges_until(200 * MS)
    c = gen(seed=8).edges_until(200 * MS)
    assert a == b and a != c
    exact = gen(jitter_us_rms=0.0).edges_until(200 * MS)
    dev = np.array([x.t_ns - y.t_ns for x, y in zip(a, exact)])
    assert np.max(np.abs(dev)) <= 2_000 and np.std(dev) > 100


def test_incremental_calls_equal_one_call() -> None:
    whole = gen().edges_until(300 * MS)
    g = gen()
    parts: list[PpmEdge] = []
    for t in range(0, 300 * MS + 1, 2_500_000):
        parts += g.edges_until(t)
    assert parts == whole


def test_script_loss_stops_pulses() -> None:
    g = gen(StickScript([Loss(0.1, 0.2)]))
    edges = g.edges_until(500 * MS)
    quiet = [e for e in edges if 100 * MS <= e.t_ns < 300 * MS]
    assert quiet == []
    assert any(e.t_ns >= 300 * MS for e in edges)
    assert g.counters["frames_lost"] == 9  # frames starting at 112.5 ... 292.5 ms


def test_fault_loss_and_stuck_and_count() -> None:
    g = gen()
    g.inject_loss(50 * MS, 50 * MS)
    g.set_stuck(150 * MS, 3, 1700)
    g.set_channel_count(250 * MS, 6)
    frames_by_t = {}
    g.edges_until(400 * MS)
    for f in g.take_frames():
        frames_by_t[f.t_ns] = f
    ts = sorted(frames_by_t)
    assert not any(50 * MS <= t < 100 * MS for t in ts)
    assert frames_by_t[ts[0]].pulses_us[2] == 1000
    assert all(frames_by_t[t].pulses_us[2] == 1700 for t in ts if t >= 150 * MS)
    assert all(len(frames_by_t[t].pulses_us) == 6 for t in ts if t >= 250 * MS)
    assert all(len(frames_by_t[t].pulses_us) == 8 for t in ts if t < 250 * MS)
    g.set_stuck(400 * MS, 3, None)
    g.edges_until(500 * MS)
    assert all(f.pulses_us[2] == 1000 for f in g.take_frames())


def test_glitch_splits_one_frame() -> None:
    g = gen(jitter_us_rms=0.0)
    g.inject_glitch(60 * MS, width_us=20, channel=3)
    edges = g.edges_until(200 * MS)
    frames = split_frames(separator_starts(edges))
    counts = [len(f) for f in frames]
    assert counts.count(9) == 1 and all(c == 8 for c in counts if c != 9)
    glitched = frames[counts.index(9)]
    # Channel 3 (1000 us, separator 300 us) gets a 20 us pulse centred at 650 us.
    assert glitched[2] == 640_000 and glitched[3] == 360_000
    assert g.counters["glitches"] == 1
