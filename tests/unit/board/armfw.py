"""C programs on the lpc2148 hardware layer (firmware/hal/lpc2148/), built with
arm-none-eabi-gcc for the core's tests; cached by the sources' contents."""

from __future__ import annotations

import fcntl
import hashlib
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
HAL = ROOT / "firmware" / "hal" / "lpc2148"
GCC = "arm-none-eabi-gcc"
CFLAGS = ["-std=c11", "-O2", "-g", "-mcpu=arm7tdmi", "-marm", "-mfloat-abi=soft", "-Wall", "-Wextra",
          "-ffunction-sections", "-fdata-sections"]
LDFLAGS = ["-nostartfiles", "-Wl,--gc-sections", "--specs=nano.specs"]
CACHE = Path(tempfile.gettempdir()) / "hil-board-fw"


def need_gcc() -> None:
    if shutil.which(GCC) is None:
        pytest.skip("arm-none-eabi-gcc is not installed (the firmware's ARM build installs it)")


def build_on_hal(main_c: Path) -> Path:
    """``main_c`` linked with the lpc2148 layer, its startup code and linker script."""
    need_gcc()
    sources = sorted(HAL.glob("*.c")) + sorted(HAL.glob("*.S")) + [main_c]
    headers = sorted(HAL.glob("*.h")) + [ROOT / "firmware" / "include" / "hal.h", HAL / "lpc2148.ld"]
    digest = hashlib.sha1()
    for f in sources + headers:
        digest.update(f.name.encode() + f.read_bytes())
    CACHE.mkdir(exist_ok=True)
    elf = CACHE / f"{main_c.stem}-{digest.hexdigest()[:16]}.elf"
    with (CACHE / "lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not elf.exists():
            tmp = elf.with_suffix(".tmp")
            cmd = [GCC, *CFLAGS, f"-I{ROOT / 'firmware' / 'include'}", f"-I{HAL}", *map(str, sources), *LDFLAGS,
                   "-T", str(HAL / "lpc2148.ld"), "-o", str(tmp)]
            done = subprocess.run(cmd, capture_output=True, text=True)
            if done.returncode:
                raise AssertionError(f"building {main_c.name} on the lpc2148 layer failed:\n{done.stderr}")
            tmp.replace(elf)
    return elf


def build_firmware() -> Path:
    """The flight firmware's ARM build (``make arm``), in a build directory of its own."""
    need_gcc()
    build = CACHE / "firmware-build"
    CACHE.mkdir(exist_ok=True)
    with (CACHE / "lock-firmware").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        done = subprocess.run(["make", "-s", "-C", str(ROOT / "firmware"), "arm", f"BUILD={build}"],
                              capture_output=True, text=True)
    elf = build / "arm" / "fc.elf"
    if not elf.exists():
        raise AssertionError(f"make arm failed:\n{done.stdout}\n{done.stderr}")
    return elf
