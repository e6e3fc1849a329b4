"""Which programs the clock shim can enter, and the reasons given when it cannot."""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from hil.vtime.preload import Fallback, check_program, shim_library


def test_the_shim_is_built_by_the_install() -> None:
    library = shim_library()
    assert isinstance(library, Path) and library.is_file()


def test_python_is_dynamic_and_can_be_preloaded() -> None:
    assert check_program([sys.executable, "-m", "flightcode"]) is None


def test_a_script_is_judged_by_its_interpreter(tmp_path: Path) -> None:
    script = tmp_path / "fc"
    script.write_text("#!/usr/bin/env python3\nprint('hi')\n")
    script.chmod(0o755)
    assert check_program([str(script)]) is None


def test_a_static_program_is_refused_with_the_reason(tmp_path: Path) -> None:
    cc = shutil.which("cc") or shutil.which("gcc")
    assert cc
    src = tmp_path / "s.c"
    src.write_text("int main(void) { return 0; }\n")
    exe = tmp_path / "static-fc"
    built = subprocess.run([cc, "-static", "-o", str(exe), str(src)], capture_output=True)
    if built.returncode != 0:
        pytest.skip(f"no static C library here: {built.stderr.decode()[-200:]}")
    verdict = check_program([str(exe)])
    assert isinstance(verdict, Fallback) and "statically linked" in verdict.reason


def test_a_set_user_id_program_is_refused(tmp_path: Path) -> None:
    exe = tmp_path / "suid-fc"
    shutil.copy(sys.executable, exe)
    os.chmod(exe, 0o755 | stat.S_ISUID)
    verdict = check_program([str(exe)])
    assert isinstance(verdict, Fallback) and "set-user/group-ID" in verdict.reason
