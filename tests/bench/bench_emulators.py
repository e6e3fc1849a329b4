"""Benchmark of the emulators' per-tick hot paths (not a test): median us per 2.5 ms tick.

Run: ``.venv/bin/python tests/bench/bench_emulators.py [--ticks N] [--rounds R]
[--baseline DIR]``. Prints, per piece, the median us per tick and the mean without the
slowest 1 % of ticks (the mean counts the rare expensive ticks, e.g. a PPM frame every ninth
tick; the top 1 % are mostly the shared machine's scheduling gaps).

Pieces, each driven the way ``hil/flight/devices.py`` drives it on every tick:

* ``adc``: the four pipelined MCP3204 conversions as the flight code sends them (per
  channel ``02 12 <3 bytes> 03``, all four channels in ONE ``BusPirate.receive`` call), then
  ``take_output`` / ``take_events`` of the Bus Pirate and the MCP3204 (the analog latch is
  updated outside the timed section).
* ``imu``: ``MtiDevice.set_motion`` + ``advance`` + ``take_output`` + ``take_events`` at
  400 Hz MTData2 with the flight code's mk4 output configuration.
* ``rc``: ``PpmGenerator.edges_until`` + ``CaptureFrontEnd.feed_edges`` / ``advance`` /
  ``take_output`` / ``take_events`` (``rc_capture`` is the front-end part alone).
* ``analog``: ``AnalogFrontEnd.update`` with a moving pressure and specific force.
* ``vibration``: four rotor tones (about 100 Hz, as in hover) through the XSENS
  (``MtiDevice.vibration_S``, mk4 averaging) and the ADXL335 chain
  (``AnalogFrontEnd.set_vibration`` and the three accel channels' tone volts).

``--baseline DIR`` runs the same measurement against the ``emulators`` package found in
DIR (e.g. an export of an older commit: ``git archive HEAD~5 emulators | tar -x -C DIR``),
in subprocesses interleaved with runs of this checkout, and prints the per-piece ratio
baseline / current of each round's medians (the machine is shared and noisy: compare
ratios taken in the same run, not numbers from different runs).
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

TICK_NS = 2_500_000
REPO = Path(__file__).resolve().parents[2]

#: Flight code's mk4 output configuration (flightcode/drivers/mtdata.py
#: ``mk4_output_configuration(400)``), copied so this script needs nothing but emulators.
MK4_OUTPUT_CONFIGURATION = ((0x1020, 0xFFFF), (0x1060, 0xFFFF), (0x2034, 400), (0x8024, 400), (0x4024, 400),
                            (0xE020, 0xFFFF))


def _adc_tick() -> tuple[Callable[[int], None], Callable[[int], None]]:
    """(prepare(t_ns), timed(t_ns)) for the Bus Pirate + MCP3204 transaction."""
    import numpy as np

    from emulators.analog.frontend import AnalogFrontEnd
    from emulators.analog.params import AnalogParams
    from emulators.buspirate.device import BusPirate
    from emulators.buspirate.params import BusPirateParams
    from emulators.mcp3204.device import Mcp3204
    from emulators.mcp3204.params import Mcp3204Params

    analog = AnalogFrontEnd(AnalogParams(), np.random.default_rng(1))
    mcp = Mcp3204(Mcp3204Params(), analog.volts)
    bp = BusPirate(BusPirateParams(), mcp)
    bp.line_settings_changed(115_200, -1)
    # Entry and setup exactly as flightcode/drivers/buspirate_spi.py: 20 x 00, 01, then
    # 8A (3.3 V push-pull, mode 0), 63 (1 MHz), 49 (power on, CS high), 03.
    bp.receive(bytes(20) + b"\x01" + bytes((0x8A, 0x63, 0x49, 0x03)), -1)
    assert bp.take_output().endswith(b"SPI1\x01\x01\x01\x01"), "Bus Pirate did not enter SPI mode"
    bp.take_events()
    mcp.take_events()
    wire = b"".join(bytes((0x02, 0x12, 0x06, (ch & 3) << 6, 0x00, 0x03)) for ch in range(4))

    def prepare(t_ns: int) -> None:
        s = t_ns * 1e-9
        analog.update(t_ns, 101_325.0 - 30.0 * math.sin(s), (0.3 * math.sin(3 * s), 0.2, -9.8), 25.0)

    def timed(t_ns: int) -> None:
        bp.receive(wire, t_ns)
        out = bp.take_output()
        events = bp.take_events()
        events += mcp.take_events()
        assert len(out) == 24 and events

    return prepare, timed


def _imu_tick() -> tuple[Callable[[int], None], Callable[[int], None]]:
    import numpy as np

    from emulators.xsens.codec import encode_frame
    from emulators.xsens.defs import MID
    from emulators.xsens.device import MtiDevice
    from emulators.xsens.params import XsensParams

    dev = MtiDevice(XsensParams(), np.random.default_rng(2))
    dev.line_settings_changed(921_600, -10_000_000)
    config = b"".join(xdi.to_bytes(2, "big") + f.to_bytes(2, "big") for xdi, f in MK4_OUTPUT_CONFIGURATION)
    dev.receive(encode_frame(MID.GOTO_CONFIG), -9_000_000)
    dev.receive(encode_frame(MID.SET_OUTPUT_CONFIGURATION, config), -8_000_000)
    dev.receive(encode_frame(MID.GOTO_MEASUREMENT), -7_000_000)
    dev.take_output()
    dev.take_events()

    def prepare(t_ns: int) -> None:
        pass

    def timed(t_ns: int) -> None:
        s = t_ns * 1e-9
        h = 0.1 * math.sin(s)
        dev.set_motion((math.cos(h), math.sin(h), 0.0, 0.0), (0.01, -0.02, 0.03 * math.cos(s)), (0.1, 0.2, -9.8))
        dev.advance(t_ns)
        out = dev.take_output()
        events = dev.take_events()
        assert out and events

    return prepare, timed


def _rc_tick(front_end_only: bool) -> tuple[Callable[[int], None], Callable[[int], None]]:
    import numpy as np

    from emulators.rc.capture import CaptureFrontEnd
    from emulators.rc.params import CaptureParams, PpmParams
    from emulators.rc.ppm import PpmGenerator
    from emulators.rc.script import StickScript

    ppm = PpmGenerator(PpmParams(), np.random.default_rng(3), StickScript())
    cap = CaptureFrontEnd(CaptureParams())
    edges: list = []

    def prepare(t_ns: int) -> None:
        if front_end_only:
            edges[:] = ppm.edges_until(t_ns)

    def timed(t_ns: int) -> None:
        e = edges if front_end_only else ppm.edges_until(t_ns)
        if e:
            cap.feed_edges(e)
        cap.advance(t_ns)
        cap.take_output()
        cap.take_events()

    return prepare, timed


def _analog_tick() -> tuple[Callable[[int], None], Callable[[int], None]]:
    import numpy as np

    from emulators.analog.frontend import AnalogFrontEnd
    from emulators.analog.params import AnalogParams

    analog = AnalogFrontEnd(AnalogParams(), np.random.default_rng(4))

    def prepare(t_ns: int) -> None:
        pass

    def timed(t_ns: int) -> None:
        s = t_ns * 1e-9
        analog.update(t_ns, 101_325.0 - 30.0 * math.sin(s), (0.3 * math.sin(3 * s), 0.2, -9.8), 25.0)

    return prepare, timed


def _vibration_tick() -> tuple[Callable[[int], None], Callable[[int], None]]:
    import numpy as np

    from emulators.analog.frontend import AnalogFrontEnd
    from emulators.analog.params import AnalogParams
    from emulators.xsens.device import MtiDevice
    from emulators.xsens.params import XsensParams
    from hil.plant.records import VibrationTone

    imu = MtiDevice(XsensParams(), np.random.default_rng(5))
    analog = AnalogFrontEnd(AnalogParams(), np.random.default_rng(6))
    tones = [VibrationTone(2 * math.pi * (97.0 + 2.0 * i), 0.7 * i, (0.4, -0.2, 0.1 * i), (0.1, 0.3, -0.05))
             for i in range(4)]

    def prepare(t_ns: int) -> None:
        pass

    def timed(t_ns: int) -> None:
        imu.vibration_S(tones, tones, 1e-4)
        analog.set_vibration(t_ns, tones)
        for ch in (1, 2, 3):
            analog.volts(ch, t_ns)

    return prepare, timed


PIECES: dict[str, Callable[[], tuple[Callable[[int], None], Callable[[int], None]]]] = {
    "adc": _adc_tick,
    "imu": _imu_tick,
    "rc": lambda: _rc_tick(False),
    "rc_capture": lambda: _rc_tick(True),
    "analog": _analog_tick,
    "vibration": _vibration_tick,
}


def measure(ticks: int) -> dict[str, dict[str, float]]:
    """Per piece: median and trimmed mean (slowest 1 % dropped) of the timed section, us per tick."""
    result: dict[str, dict[str, float]] = {}
    for name, factory in PIECES.items():
        prepare, timed = factory()
        samples: list[int] = []
        clock = time.perf_counter_ns
        for k in range(ticks + 200):  # the first 200 ticks warm up
            t_ns = k * TICK_NS
            prepare(t_ns)
            t0 = clock()
            timed(t_ns)
            dt = clock() - t0
            if k >= 200:
                samples.append(dt)
        samples.sort()
        result[name] = {
            "median_us": statistics.median(samples) / 1000.0,
            "mean_us": statistics.fmean(samples[: int(0.99 * len(samples))]) / 1000.0,
        }
    return result


def _child(root: str, ticks: int) -> dict[str, dict[str, float]]:
    env_path = [root, str(REPO)]
    code = (
        "import sys, json; sys.path[:0] = " + json.dumps(env_path) + "; "
        "import importlib.util as u; spec = u.spec_from_file_location('b', " + json.dumps(__file__) + "); "
        "m = u.module_from_spec(spec); spec.loader.exec_module(m); "
        f"print(json.dumps(m.measure({ticks})))"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True, cwd="/")
    return json.loads(out.stdout)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ticks", type=int, default=4000, help="timed ticks per piece and run")
    ap.add_argument("--rounds", type=int, default=3, help="runs (each a fresh process) per variant")
    ap.add_argument("--baseline", type=str, default=None, help="dir holding an older emulators/ package")
    args = ap.parse_args(argv)
    variants = {"current": str(REPO)}
    if args.baseline:
        variants = {"baseline": str(Path(args.baseline).resolve()), "current": str(REPO)}
    runs: dict[str, list[dict[str, dict[str, float]]]] = {v: [] for v in variants}
    for _ in range(args.rounds):  # interleaved, so a noisy neighbour hits both variants alike
        for v, root in variants.items():
            runs[v].append(_child(root, args.ticks))
    print(f"us per tick: median / trimmed mean (each the median over {args.rounds} runs of {args.ticks} ticks)")
    header = f"{'piece':<12}" + "".join(f"{v:>20}" for v in variants)
    if args.baseline:
        header += f"{'baseline/current':>22}"
    print(header)
    for piece in PIECES:
        line = f"{piece:<12}"
        for v in variants:
            med = statistics.median(r[piece]["median_us"] for r in runs[v])
            mean = statistics.median(r[piece]["mean_us"] for r in runs[v])
            line += f"{med:>11.2f} /{mean:>7.2f}"
        if args.baseline:
            ratios = [
                statistics.median(b[piece][k] / c[piece][k] for b, c in zip(runs["baseline"], runs["current"],
                                                                             strict=True))
                for k in ("median_us", "mean_us")
            ]
            line += f"{ratios[0]:>12.2f}x /{ratios[1]:>5.2f}x"
        print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
