"""The repository holds sources, not build products.

A compiled extension module in git shadows its ``.py`` source on every checkout, and breaks any
checkout whose interpreter or build differs (the tracked modules import a shared library that
only one machine had). Build products go in .gitignore; this test fails when one is tracked.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
#: suffixes of compiled or generated build products
BUILD_SUFFIXES = (".so", ".pyd", ".dll", ".dylib", ".o", ".a", ".pyc")
#: magic numbers of executables and object files (ELF, Mach-O, PE)
MAGICS = (b"\x7fELF", b"\xcf\xfa\xed\xfe", b"\xce\xfa\xed\xfe", b"MZ")


def _tracked() -> list[str]:
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True)
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return [p for p in out.stdout.decode().split("\0") if p]


def test_no_build_product_is_tracked() -> None:
    tracked = _tracked()
    by_suffix = [p for p in tracked if p.endswith(BUILD_SUFFIXES) or ".cpython-" in p]
    assert by_suffix == [], f"build products tracked in git (git rm --cached them): {by_suffix}"


def test_no_tracked_file_is_a_binary_executable_or_object() -> None:
    binaries = []
    for rel in _tracked():
        path = ROOT / rel
        if path.is_file():
            with path.open("rb") as f:
                if f.read(4).startswith(MAGICS):
                    binaries.append(rel)
    assert binaries == [], f"compiled binaries tracked in git: {binaries}"


def test_build_products_are_ignored() -> None:
    # a product of each kind the build makes, anywhere in the tree
    probes = ["hil/flight/tickloop.cpython-311-x86_64-linux-gnu.so", "emulators/x/y.so", "hil/vtime/_shim.abi3.so",
              "build/temp/x.o"]
    out = subprocess.run(["git", "check-ignore", "--no-index", *probes], cwd=ROOT, capture_output=True, text=True)
    if out.returncode == 128:
        pytest.skip("not a git checkout")
    assert sorted(out.stdout.split()) == sorted(probes)
