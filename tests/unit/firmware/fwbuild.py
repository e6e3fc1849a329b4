"""The firmware's Makefile builds for the tests: the host binary and the ARM image, made once
per session under a file lock (parallel pytest workers share firmware/build)."""

from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
FIRMWARE = ROOT / "firmware"
HOST_BIN = FIRMWARE / "build" / "host" / "fc"
ARM_ELF = FIRMWARE / "build" / "arm" / "fc.elf"


def make(target: str, timeout_s: float = 900.0, **variables: str) -> subprocess.CompletedProcess[str]:
    """``make -C firmware <target>`` (no clock shim: this is the build, not a flight)."""
    lock_path = FIRMWARE / "build" / ".lock"
    lock_path.parent.mkdir(parents=True, exist_ok=True)
    env = {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}
    with open(lock_path, "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        return subprocess.run(["make", "-s", "-C", str(FIRMWARE), target, *(f"{k}={v}" for k, v in variables.items())],
                              capture_output=True, text=True, timeout=timeout_s, env=env)


def host_binary() -> Path:
    """The host build, made if needed; AssertionError with make's output if it fails."""
    proc = make("host")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return HOST_BIN


def arm_toolchain() -> str | None:
    """Why the ARM build cannot be made here (the compiler missing), or None."""
    if shutil.which("arm-none-eabi-gcc") is None:
        return "arm-none-eabi-gcc is not installed (firmware/install-toolchain.sh installs it)"
    return None
