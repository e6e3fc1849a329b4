"""``hil firmware build``: the C flight code's builds through its own Makefile (firmware/).

The host build (``--target host``, the default) is the posix program a rig such as
rigs/paper-quad-c.toml flies; the ARM build (``--target arm``) is the LPC2148 image, whose
flash, RAM and stack report the Makefile prints (firmware/tools/size_report.py). Builds go to
firmware/build/ (git-ignored). The compiler runs on the host clock: the bench's clock shim is
never preloaded into a build.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape

FIRMWARE_DIR = Path(__file__).resolve().parents[2] / "firmware"
TARGETS = ("host", "arm")
#: wall seconds a build may take (a cold ARM build with the design step on a loaded 2-core
#: machine takes about a minute)
BUILD_TIMEOUT_S = 900.0


class FirmwareBuildError(Exception):
    """The build could not start or failed; the message says what to do."""


def build_firmware(target: str, *, timeout_s: float = BUILD_TIMEOUT_S, firmware_dir: Path = FIRMWARE_DIR,
                   make_vars: dict[str, str] | None = None) -> str:
    """Run ``make -C firmware <target>`` (``firmware_dir``: another copy of the tree, such as a
    mutant's; ``make_vars``: ``NAME=value`` arguments, e.g. ``FLIGHT_CONFIG``); returns its
    output (the ARM size report), or raises :class:`FirmwareBuildError` with make's output."""
    if target not in TARGETS:
        raise FirmwareBuildError(f"unknown target {target!r} (one of {', '.join(TARGETS)})")
    if not (firmware_dir / "Makefile").is_file():
        raise FirmwareBuildError(f"{firmware_dir}: no firmware Makefile (a checkout without firmware/?)")
    if shutil.which("make") is None:
        raise FirmwareBuildError("make is not installed (Debian: apt install make)")
    if target == "arm" and shutil.which("arm-none-eabi-gcc") is None:
        raise FirmwareBuildError("arm-none-eabi-gcc is not installed: run firmware/install-toolchain.sh")
    env = {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}
    lock_path = firmware_dir / "build" / ".lock"  # one make at a time in firmware/build (the tests take it too)
    lock_path.parent.mkdir(parents=True, exist_ok=True)
    try:
        with open(lock_path, "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            args = [f"{k}={v}" for k, v in (make_vars or {}).items()]
            proc = subprocess.run(["make", "-s", "-C", str(firmware_dir), target, *args], capture_output=True,
                                  text=True, timeout=timeout_s, env=env)
    except subprocess.TimeoutExpired:
        raise FirmwareBuildError(f"make -C {firmware_dir} {target} took longer than {timeout_s:g} s") from None
    if proc.returncode != 0:
        raise FirmwareBuildError(f"make -C {firmware_dir} {target} failed (exit {proc.returncode}):\n"
                                 f"{(proc.stdout + proc.stderr).strip()}")
    return proc.stdout + proc.stderr


firmware_app = typer.Typer(help="The C flight code (firmware/): its builds.", no_args_is_help=True)


@firmware_app.command("build")
def firmware_build(
    target: Annotated[str, typer.Option(help="host: the posix program rigs/paper-quad-c.toml flies; "
                                        "arm: the LPC2148 image, with its flash/RAM/stack report.")] = "host",
) -> None:
    """Build the C flight code with its Makefile into firmware/build/ (a rig that flies it
    builds the host program on first use too). Exit status: 0 built, 2 the build could not start
    or failed (make's output says why).
    """
    console = Console()
    try:
        out = build_firmware(target)
    except FirmwareBuildError as exc:
        Console(stderr=True).print(f"[bold red]error:[/] {escape(str(exc))}", soft_wrap=True)
        raise typer.Exit(2) from None
    if out.strip():
        console.print(escape(out.rstrip()), soft_wrap=True)
    console.print(f"built the firmware's {target} target in firmware/build/{target}/")


__all__ = ["BUILD_TIMEOUT_S", "FIRMWARE_DIR", "TARGETS", "FirmwareBuildError", "build_firmware", "firmware_app"]
