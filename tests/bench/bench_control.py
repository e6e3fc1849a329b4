"""Micro-benchmark of the flight code's estimation and control modules (not a test).

Run: ``.venv/bin/python tests/bench/bench_control.py [--repeats N]``. Prints the median cost
per call in microseconds of each module's tick method and of one whole 400 Hz tick of them
(3 prefilters, 2 attitude axes, yaw, KF predict + update, LQI, mixer, anti-windup feedback).
The budget for all of them together is well under 500 us per tick.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable

from flightcode.control.lqi_altitude import AltitudeModel, LqiAltitude
from flightcode.control.memory_attitude import MemoryAttitudeController, MemoryGains
from flightcode.control.mixer import Mixer
from flightcode.control.reference import Prefilter3, RefState
from flightcode.control.yaw_rate import YawRateController
from flightcode.estimation.altitude_kf import AltitudeKF

T = 0.0025


def median_us(fn: Callable[[int], object], repeats: int, batch: int = 50) -> float:
    """Median over ``repeats`` batches of the per-call wall time of ``fn(i)``, microseconds."""
    samples = []
    i = 0
    for _ in range(repeats):
        t0 = time.perf_counter_ns()
        for _ in range(batch):
            fn(i)
            i += 1
        samples.append((time.perf_counter_ns() - t0) / batch / 1e3)
    return statistics.median(samples)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=200)
    args = ap.parse_args()

    model = AltitudeModel()
    pre_roll, pre_pitch, pre_alt = Prefilter3(8.0, T), Prefilter3(8.0, T), Prefilter3(1.5, T)
    roll, pitch = MemoryAttitudeController(MemoryGains()), MemoryAttitudeController(MemoryGains())
    yaw = YawRateController()
    lqi = LqiAltitude(model)
    kf = AltitudeKF(model)
    mixer = Mixer()
    ref = RefState(0.1, 0.2, 0.3, 0.4)

    def cmd(i: int) -> float:
        return 0.2 * math.sin(i * 1e-3)

    cases: dict[str, Callable[[int], object]] = {
        "Prefilter3.update": lambda i: pre_roll.update(cmd(i)),
        "MemoryAttitudeController.update": lambda i: roll.update(ref, cmd(i), 0.01, True),
        "YawRateController.update": lambda i: yaw.update(0.1, cmd(i), True),
        "LqiAltitude.update": lambda i: lqi.update(5.0, 4.0 + cmd(i), 0.1, 0.0, True),
        "AltitudeKF.predict": lambda i: kf.predict(cmd(i) * 0.1),
        "AltitudeKF.update (baro + acc)": lambda i: kf.update(cmd(i), 0.05),
        "AltitudeKF.update (acc only)": lambda i: kf.update(None, 0.05),
        "Mixer.mix (unsaturated)": lambda i: mixer.mix(0.724, (0.1 * cmd(i), 0.05, 0.01)),
        "Mixer.mix (saturated)": lambda i: mixer.mix(0.95, (0.8, 0.3 * cmd(i), 0.1)),
    }

    def tick(i: int) -> None:
        r_ref = pre_roll.update(cmd(i))
        p_ref = pre_pitch.update(-cmd(i))
        z_ref = pre_alt.update(5.0).angle_rad
        kf.update(4.0 + cmd(i), 0.05)
        tau_r = roll.update(r_ref, cmd(i) * 0.9, 0.01, True)
        tau_p = pitch.update(p_ref, -cmd(i) * 0.9, -0.01, True)
        tau_y = yaw.update(0.0, 0.01, True)
        d_c = lqi.update(z_ref, kf.z_m, kf.vz_mps, kf.az_mps2, True)
        kf.predict(lqi.last_u)
        res = mixer.mix(d_c, (tau_r, tau_p, tau_y))
        roll.set_applied(res.applied_tau_Nm[0])
        pitch.set_applied(res.applied_tau_Nm[1])
        yaw.set_applied(res.applied_tau_Nm[2])

    cases["whole tick (all of the above)"] = tick
    width = max(len(k) for k in cases)
    print(f"{'module':<{width}}  median us/call")
    for name, fn in cases.items():
        print(f"{name:<{width}}  {median_us(fn, args.repeats):8.2f}")


if __name__ == "__main__":
    main()
