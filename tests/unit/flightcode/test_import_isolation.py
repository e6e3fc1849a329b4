"""The flight code knows nothing of the bench: AST of every flightcode module, every import."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
MODULES = sorted((ROOT / "flightcode").rglob("*.py"))
# scipy: the start-up design (flightcode/control/design.py, python-control's computation
# without its import cost); python-control stays allowed for flight code that wants it
ALLOWED = set(sys.stdlib_module_names) | {"numpy", "scipy", "filterpy", "control", "serial", "flightcode"}


def _imported(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(), filename=str(path))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: stays inside the flightcode package by construction
                found.append((node.lineno, "flightcode"))
            elif node.module:
                found.append((node.lineno, node.module))
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", "")) in (
                "import_module", "__import__"):
            found += [(node.lineno, a.value) for a in node.args if isinstance(a, ast.Constant)
                      and isinstance(a.value, str)]
    return found


def test_there_are_modules_to_check() -> None:
    names = {p.relative_to(ROOT).as_posix() for p in MODULES}
    assert {"flightcode/loop.py", "flightcode/drivers/xsens.py", "flightcode/__main__.py"} <= names


@pytest.mark.parametrize("path", MODULES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_only_stdlib_numpy_scipy_filterpy_control_pyserial(path: Path) -> None:
    bad = [(line, mod) for line, mod in _imported(path) if mod.split(".")[0] not in ALLOWED]
    assert not bad, f"{path.relative_to(ROOT)} imports outside the flight code's set: {bad}"
    ours = [(line, mod) for line, mod in _imported(path) if mod.split(".")[0] in {"hil", "emulators", "tests"}]
    assert not ours, f"{path.relative_to(ROOT)} imports the bench: {ours}"


def test_the_checker_catches_a_bench_import(tmp_path: Path) -> None:
    bad = tmp_path / "bad.py"
    bad.write_text("import os\nfrom hil.clock import X\nimport emulators.xsens\nimportlib.import_module('hil.x')\n")
    mods = [m for _, m in _imported(bad)]
    assert [m for m in mods if m.split(".")[0] not in ALLOWED] == ["hil.clock", "emulators.xsens", "hil.x"]
