"""Benchmark (not a test): the flight loop's compute time per sample, I/O waits excluded.

Run: ``.venv/bin/python tests/bench/bench_flightcode_compute.py [--samples N] [--warmup N]``

The real :class:`flightcode.loop.FlightLoop` runs in lockstep against the in-process fake
devices of ``tests/unit/flightcode/fakes.py`` (a small plant; arm, take off, fly to 2 m with
stick inputs). Per sample it takes the loop's own compute figure (``perf_counter_ns`` around
the iteration minus the blocking IMU and ADC reads, the number sent in telemetry) and
subtracts the time the fake devices spent answering the loop's writes inside it, so the
figure is the flight code's own work: parse the sample, ADC decode and conversion, RC
decode, KF, controllers, mixer, ESC and telemetry encoding.
Prints median, p90, p99 and max in microseconds, while disarmed and while flying.
"""

from __future__ import annotations

import argparse
import io
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from flightcode.config import parse  # noqa: E402
from flightcode.log import Logger  # noqa: E402
from flightcode.loop import FlightLoop, make_devices  # noqa: E402
from flightcode.modes import Mode  # noqa: E402
from tests.unit.flightcode.fakes import FakeSerial, FakeWorld  # noqa: E402

CONFIG = "".join(f'[ports.{n}]\npath = "{n}"\nbaud = 115200\n' for n in ("imu", "adc", "rc", "esc", "telemetry"))


def sticks(t: float) -> list[float]:
    thr, yaw = (1000.0, 2000.0) if 1.2 <= t < 2.4 else (1000.0, 1500.0)
    if t >= 2.6:
        thr = 1200.0
    roll = 1550.0 if int(t) % 4 == 3 else 1500.0  # some attitude activity
    return [roll, 1500.0, thr, yaw, 1000.0, 1000.0, 1000.0, 1000.0]


def _timed(port: FakeSerial, sink: list[int]) -> None:
    inner: Callable[[bytes], None] = port.on_write

    def on_write(data: bytes) -> None:
        t0 = time.perf_counter_ns()
        inner(data)
        sink[0] += time.perf_counter_ns() - t0

    port.on_write = on_write


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q * (len(ordered) - 1))))]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=8000, help="loop iterations measured (400 per s)")
    ap.add_argument("--warmup", type=int, default=400)
    args = ap.parse_args()

    cfg = parse(CONFIG)
    world = FakeWorld(sticks)
    device_ns = [0]
    for name in ("adc", "esc", "telemetry"):
        _timed(world.ports[name], device_ns)
    log = Logger(io.StringIO())
    loop = FlightLoop(cfg, make_devices(cfg, world.ports, log), log)  # type: ignore[arg-type]
    loop.boot()
    loop.run(max_iterations=args.warmup)
    by_mode: dict[str, list[float]] = {"disarmed/armed": [], "flying": []}
    wall0 = time.perf_counter()
    for _ in range(args.samples):
        device_ns[0] = 0
        loop.step()
        own_us = (int(loop.last["compute_ns"]) - device_ns[0]) / 1000.0  # type: ignore[call-overload]
        by_mode["flying" if loop.last["mode"] is Mode.FLYING else "disarmed/armed"].append(own_us)
    wall = time.perf_counter() - wall0
    print(f"flight-loop compute time per sample (us), {args.samples} samples, "
          f"{wall / args.samples * 1e6:.0f} us wall per in-process lockstep sample")
    print(f"{'phase':16s} {'n':>6s} {'median':>8s} {'p90':>8s} {'p99':>8s} {'max':>8s}")
    for phase, values in by_mode.items():
        if values:
            print(f"{phase:16s} {len(values):6d} {statistics.median(values):8.1f} {percentile(values, 0.90):8.1f} "
                  f"{percentile(values, 0.99):8.1f} {max(values):8.1f}")
    print(f"budget: 2500 us per sample at 400 Hz; final altitude {world.plant.z_m:.2f} m, mode {loop.modes.mode.name}")


if __name__ == "__main__":
    main()
