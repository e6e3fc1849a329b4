"""The firmware's ARM build links for the LPC2148, and its size report (firmware/tools/
size_report.py, printed by `make arm`) is parsed and held to the limits: at least 25 % of the
512 KB flash and of the 32 KB RAM to spare, and the deepest static call chain within the main
stack. Skipped, naming it, only where arm-none-eabi-gcc is not installed."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from elftools.elf.elffile import ELFFile

from tests.unit.firmware.fwbuild import ARM_ELF, FIRMWARE, arm_toolchain, make

MISSING = arm_toolchain()
pytestmark = pytest.mark.skipif(MISSING is not None, reason=MISSING or "")


@pytest.fixture(scope="module")
def report() -> dict:
    proc = make("arm")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    lines = [ln for ln in (proc.stdout + proc.stderr).splitlines() if ln.startswith("size_report: {")]
    assert lines, f"make arm printed no size report:\n{proc.stdout}{proc.stderr}"
    return json.loads(lines[-1].removeprefix("size_report: "))


def test_the_image_is_an_arm7tdmi_elf_with_main(report: dict) -> None:
    with ARM_ELF.open("rb") as f:
        elf = ELFFile(f)
        assert elf["e_machine"] == "EM_ARM"
        symbols = {s.name for s in elf.get_section_by_name(".symtab").iter_symbols()}
    assert {"main", "loop_tick", "xbus_feed", "altitude_kf_update", "memory_attitude_update"} <= symbols
    attrs = subprocess.run(["arm-none-eabi-readelf", "-A", str(ARM_ELF)], capture_output=True, text=True).stdout
    assert "ARM7TDMI" in attrs.upper() or "v4T" in attrs, attrs  # the core the build was made for
    assert "VFP" not in attrs  # soft-float: no floating-point unit instructions


def test_flash_and_ram_keep_a_quarter_spare(report: dict) -> None:
    assert report["flash_total_B"] == 512 * 1024 and report["ram_total_B"] == 32 * 1024
    assert report["flash_spare_pct"] >= 25.0, report
    assert report["ram_spare_pct"] >= 25.0, report
    assert report["ram_B"] >= report["data_B"] + report["bss_B"] + report["stack_reserved_B"]


def test_the_deepest_call_chain_fits_the_main_stack(report: dict) -> None:
    assert report["stack_reserved_B"] > 0, "the linker script reserves no main stack (__stack_size)"
    assert 0 < report["stack_worst_B"] <= report["stack_reserved_B"], report


def test_the_report_fails_a_build_over_its_limits(report: dict) -> None:
    """The same report with a limit the image cannot meet exits 1 and says so: the check can fail."""
    proc = subprocess.run([sys.executable, str(FIRMWARE / "tools" / "size_report.py"), str(ARM_ELF),
                           "--callgraph-dir", str(FIRMWARE / "build" / "arm" / "obj"), "--min-spare", "99"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1
    assert "FAIL" in proc.stderr
