"""The firmware's barometer-motion check against flightcode's BaroMotionCheck.

The firmware counts sensor time in integer nanoseconds, so its blocks close exactly on the
sample grid. flightcode adds float64 seconds, and at 400 Hz the sum of 0.0025 s steps drifts
off the grid: its block 3 holds 101 samples (300 x 0.0025 < 0.75 in float64), about 0.3 % of
its blocks are a sample long or short. So the exact comparison flies a 512 Hz grid (2^-9 s: a
float64 sum of it is exact), where both close the same blocks: every verdict identical, the
disagreements and the re-anchor targets within 1e-3 m (float32 block means and integrals;
measured 7e-6 m). At 400 Hz the same refusals and take-backs come within 2 samples of each
other, the disagreements and targets within 0.1 m (a sample's share of a block mean).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest

from flightcode.estimation.baro_motion import BaroMotionCheck
from tests.unit.firmware import cfw

#: 2^-9 s in ns: a grid both flight codes count exactly
GRID_NS = 1_953_125
TOL_M = 1e-3


def f32(v: float) -> float:
    return float(np.float32(v))


def flight(rng: np.random.Generator, n: int, dt_s: float) -> dict[str, np.ndarray]:
    """Climbs and descents of a few metres, the estimate a little off the truth, a barometer
    that is blocked in some stretches, missing in others, judged only part of the time."""
    a = np.convolve(rng.normal(0.0, 6.0, n), np.ones(150) / 150.0, mode="same")
    v = np.cumsum(a) * dt_s
    v -= np.convolve(v, np.ones(3000) / 3000.0, mode="same")
    z = 5.0 + np.cumsum(v) * dt_s
    t = np.arange(n) * dt_s
    blocked = []
    for t0 in rng.uniform(0.0, t[-1] - 10.0, 5):  # climbs and descents of 3-6 m in 1-2 s
        tau = np.clip((t - t0) / rng.uniform(1.0, 2.0), 0.0, 1.0)
        z += rng.choice([-1.0, 1.0]) * rng.uniform(3.0, 6.0) * (tau - np.sin(2 * np.pi * tau) / (2 * np.pi))
        blocked.append(int(t0 / dt_s) - int(rng.integers(0, 400)))
    a = np.gradient(np.gradient(z, dt_s), dt_s)
    baro = z + rng.normal(0.0, 0.44, n)
    for start in [*blocked, *rng.integers(0, n - 2000, 3)]:  # a blocked port: the trapped level, the sensor's noise
        start = max(0, start)
        length = int(rng.integers(300, 3000))
        baro[start:start + length] = z[start] + rng.normal(0.0, 0.44, baro[start:start + length].size)
    judging = np.ones(n, dtype=bool)
    for start in rng.integers(0, n - 600, 6):
        judging[start:start + int(rng.integers(1, 600))] = False
    return {"z": z, "v": v, "a": a, "baro": baro, "judging": judging,
            "z_hat": z + np.convolve(rng.normal(0.0, 0.05, n), np.ones(50) / 50, mode="same"),
            "vz_hat": v + np.convolve(rng.normal(0.0, 0.1, n), np.ones(200) / 200 * 3, mode="same"),
            "missing": rng.random(n) < 0.01, "gap": rng.random(n) < 0.0005, "rejected": rng.random(n) < 0.0005,
            "no_acc": rng.random(n) < 0.01, "ground": rng.random(n) < 0.0003, "skip": rng.random(n) < 0.002}


@dataclass
class Trace:
    refusing: list[bool] = field(default_factory=list)
    reanchors: list[tuple[int, float, float]] = field(default_factory=list)
    worst: list[float] = field(default_factory=list)


def fly(check: BaroMotionCheck | cfw.CBaroMotion, f: dict[str, np.ndarray], dt_ns: int, seed: int) -> Trace:
    """Feed one check the flight; flightcode's takes seconds, the firmware's nanoseconds."""
    rng = np.random.default_rng(seed)
    out = Trace()
    gap_left = 0
    baro, acc, z_hat, vz_hat = (f[key].astype(np.float32).tolist() for key in ("baro", "a", "z_hat", "vz_hat"))
    skip, gap, missing, no_acc, judging, rejected, ground = (
        f[key].tolist() for key in ("skip", "gap", "missing", "no_acc", "judging", "rejected", "ground"))
    for k in range(len(baro)):
        dt = dt_ns * (2 if skip[k] else 1)
        if gap[k]:
            gap_left = int(rng.integers(20, 200))  # an ADC resync: no readings for a while
        gap_left = max(0, gap_left - 1)
        zb = None if (missing[k] or gap_left) else baro[k]
        a = None if no_acc[k] else acc[k]
        args = (zb, a, z_hat[k], vz_hat[k], judging[k])
        out.refusing.append(check.add(dt * 1e-9, *args) if isinstance(check, BaroMotionCheck) else check.add(dt, *args))
        target = check.take_reanchor()
        if target is not None:
            out.reanchors.append((k, *target))
        if rejected[k]:
            check.reading_rejected()
        if ground[k]:
            check.on_ground()
        if k % 400 == 0:
            out.worst.append(check.take_worst())
    return out


def fly_both(lib: cfw.Lib, seed: int, n: int, dt_ns: int) -> tuple[BaroMotionCheck, cfw.CBaroMotion, Trace, Trace]:
    py, c = BaroMotionCheck(1.5, 0.25, 1.5), cfw.CBaroMotion(lib, 1.5, 0.25, 1.5)
    assert c.ok
    f = flight(np.random.default_rng(seed), n, dt_ns * 1e-9)
    return py, c, fly(py, f, dt_ns, seed), fly(c, f, dt_ns, seed)


def transitions(refusing: list[bool]) -> list[int]:
    r = np.array(refusing, dtype=int)
    return np.flatnonzero(np.diff(r)).tolist()


@pytest.mark.parametrize("seed", [11, 12, 13, 14])
def test_identical_on_an_exact_grid(lib: cfw.Lib, seed: int) -> None:
    assert GRID_NS * 1e-9 == 2.0**-9  # both count it exactly
    py, c, tp, tc = fly_both(lib, seed, 120_000, GRID_NS)
    # the first sample apart, not pytest's diff of two 120,000-long lists (minutes on a mutant)
    apart = next((k for k, (a, b) in enumerate(zip(tc.refusing, tp.refusing, strict=True)) if a != b), None)
    assert apart is None, f"C refuses {tc.refusing[apart]}, Python {tp.refusing[apart]} at sample {apart}"
    assert [k for k, _, _ in tc.reanchors] == [k for k, _, _ in tp.reanchors]
    np.testing.assert_allclose([r[1:] for r in tc.reanchors], [r[1:] for r in tp.reanchors], atol=TOL_M)
    np.testing.assert_allclose(tc.worst, tp.worst, atol=TOL_M)
    counters, _, blocks_back = c.read()
    assert counters == {k: py.counters[k] for k in ("windows", "disagreements", "taken_back")}
    assert blocks_back == 6
    assert py.counters["windows"] > 200 and py.counters["disagreements"] >= 2 and py.counters["taken_back"] >= 1


@pytest.mark.parametrize("seed", [21, 22])
def test_same_verdicts_at_400_hz(lib: cfw.Lib, seed: int) -> None:
    """flightcode's blocks drift off the 400 Hz grid by a sample now and then, so a verdict may
    come a sample apart: the same refusals and take-backs, within 2 samples, the re-anchor
    targets and the disagreements within 0.1 m (a sample's share of the block means in a
    4 m/s climb; measured 0.054 m)."""
    py, c, tp, tc = fly_both(lib, seed, 100_000, 2_500_000)
    kp, kc = transitions(tp.refusing), transitions(tc.refusing)
    assert len(kp) == len(kc) >= 2 and np.all(np.abs(np.array(kp) - np.array(kc)) <= 2), (kp, kc)
    assert len(tp.reanchors) == len(tc.reanchors)
    np.testing.assert_allclose([r[1:] for r in tc.reanchors], [r[1:] for r in tp.reanchors], atol=0.1)
    np.testing.assert_allclose(tc.worst, tp.worst, atol=0.1)
    assert c.read()[0]["windows"] == pytest.approx(py.counters["windows"], abs=2)


@pytest.mark.parametrize("window_ns, block_ns, max_m, ok, blocks", [
    (1_500_000_000, 250_000_000, 1.5, True, 6),
    (0, 250_000_000, 1.5, True, 0),  # off
    (499_999_999, 250_000_000, 1.5, False, 0),  # shorter than two blocks
    (500_000_000, 250_000_000, 1.5, True, 2),
    (625_000_000, 250_000_000, 1.5, True, 2),  # 2.5 blocks: half to even, as Python's round()
    (875_000_000, 250_000_000, 1.5, True, 4),  # 3.5 -> 4
    (3_750_000_000, 250_000_000, 1.5, True, 15),
    (4_000_000_000, 250_000_000, 1.5, False, 0),  # 16 blocks: beyond BARO_MOTION_MAX_BLOCKS - 1
    (1_500_000_000, 0, 1.5, False, 0),
    (1_500_000_000, 250_000_000, 0.0, False, 0),
])
def test_params(lib: cfw.Lib, window_ns: int, block_ns: int, max_m: float, ok: bool, blocks: int) -> None:
    c = cfw.CBaroMotion(lib, window_ns * 1e-9, block_ns * 1e-9, max_m)
    assert c.ok == ok
    if ok:
        assert c.read()[2] == blocks
        if blocks:
            assert round(window_ns / block_ns) == blocks


def test_off_never_refuses(lib: cfw.Lib) -> None:
    c = cfw.CBaroMotion(lib, 0.0, 0.25, 1.5)
    for k in range(4000):
        assert not c.add(2_500_000, 100.0, 9.0, 0.0, 0.0, True)  # a barometer that never moves in a fall
    assert c.read()[0]["windows"] == 0
