"""Benchmark (not a test): the CCLK cycles of the firmware's estimation and control calls on the
emulated LPC2148 (hil/board: ARM7TDMI timings, MAM 2/3 at 60 MHz), soft-float as flown.

Run: ``.venv/bin/python tests/bench/bench_firmware_estctl_cycles.py [--config FLIGHT_CONFIG]``

Builds tests/bench/firmware_estctl_cycles.c with the modules of firmware/src and the design
header firmware/gen makes from the config (arm-none-eabi-gcc -O2, as ``make -C firmware arm``
compiles), runs it on the emulated core and prints each call's cycles and microseconds. The
numbers are the core's cycle model, the same on every machine.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from emulators.lpc2148 import Lpc2148  # noqa: E402
from hil.board.core import Core  # noqa: E402
from hil.board.elf import load_elf  # noqa: E402

CALLS = ("altitude_kf_predict", "altitude_kf_update (barometer + acceleration)", "altitude_kf_update_at_rest",
         "plausibility_baro_Pa", "baro_motion_add", "prefilter3_update", "memory_attitude_update",
         "yaw_rate_update", "lqi_altitude_update", "mixer_mix", "mixer_mix (saturated)")
CCLK_HZ = 60e6


def build(config: Path, out: Path) -> Path:
    gen = out / "gen"
    subprocess.run([sys.executable, str(ROOT / "firmware" / "gen"), "--config", str(config), "--out", str(gen)],
                   check=True, capture_output=True)
    src = ROOT / "firmware" / "src"
    elf = out / "cycles.elf"
    cmd = ["arm-none-eabi-gcc", "-std=c11", "-O2", "-ffp-contract=off", "-mcpu=arm7tdmi", "-marm", "-mfloat-abi=soft",
           "-ffreestanding", "-nostartfiles", f"-I{gen}", f"-I{src}", str(Path(__file__).with_name("firmware_estctl_cycles.c")),
           *map(str, sorted((src / "estimation").glob("*.c"))), *map(str, sorted((src / "control").glob("*.c"))),
           "-Wl,-Ttext=0x0", "-Wl,-Tdata=0x40000000", "-Wl,-e,_start", "--specs=nano.specs", "-lm", "-lc", "-lgcc",
           "-o", str(elf)]
    subprocess.run(cmd, check=True)
    return elf


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", type=Path, default=ROOT / "rigs" / "flightcode-paper-quad.toml")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        img = load_elf(build(args.config, Path(tmp)))
    core = Core(Lpc2148())
    core.load(img)
    core.reset(img.symbols["_start"])
    prev = core.run_to(img.symbols["mark_0"], 50_000_000)
    total = 0
    for i, name in enumerate(CALLS):
        now = core.run_to(img.symbols[f"mark_{i + 1}"], 50_000_000)
        print(f"{name:48s} {now - prev:7d} cycles {1e6 * (now - prev) / CCLK_HZ:8.1f} us")
        total += now - prev
        prev = now
    print(f"{'all of the above':48s} {total:7d} cycles {1e6 * total / CCLK_HZ:8.1f} us (of a 2500 us sample)")


if __name__ == "__main__":
    main()
