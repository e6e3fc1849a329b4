"""The layer rules of docs/architecture.md, checked on the source (AST), not by convention."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
STDLIB = set(sys.stdlib_module_names)


def _imports(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(), filename=str(path))
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name.split(".")[0]) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.append((node.lineno, node.module.split(".")[0]))
    return found


def _modules(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


@pytest.mark.parametrize("path", _modules("flightcode"), ids=lambda p: str(p.relative_to(ROOT)))
def test_flightcode_imports_only_its_allowed_set(path: Path) -> None:
    allowed = STDLIB | {"numpy", "filterpy", "control", "serial", "scipy", "flightcode"}
    bad = [(line, mod) for line, mod in _imports(path) if mod not in allowed]
    assert not bad, f"{path}: flightcode may import only stdlib, numpy, filterpy, control, pyserial: {bad}"


@pytest.mark.parametrize("path", _modules("emulators"), ids=lambda p: str(p.relative_to(ROOT)))
def test_emulators_are_sans_io(path: Path) -> None:
    forbidden = {"asyncio", "os", "time", "random", "hil", "flightcode", "socket", "select", "threading", "serial"}
    bad = [(line, mod) for line, mod in _imports(path) if mod in forbidden]
    assert not bad, f"{path}: emulators must not import I/O, clocks or other layers: {bad}"


@pytest.mark.parametrize("path", _modules("hil"), ids=lambda p: str(p.relative_to(ROOT)))
def test_hil_never_imports_flightcode(path: Path) -> None:
    bad = [(line, mod) for line, mod in _imports(path) if mod == "flightcode"]
    assert not bad, f"{path}: the bench must not import the flight code: {bad}"


@pytest.mark.parametrize("path", _modules("hil"), ids=lambda p: str(p.relative_to(ROOT)))
def test_only_clock_reads_the_os_clock(path: Path) -> None:
    if path.name == "clock.py" and path.parent.name == "hil":
        return
    tree = ast.parse(path.read_text())
    calls = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "time":
            if node.attr in {"time", "time_ns", "monotonic", "monotonic_ns", "perf_counter", "perf_counter_ns", "sleep"}:
                calls.add(node.attr)
        if isinstance(node, ast.ImportFrom) and node.module == "time":
            calls |= {a.name for a in node.names}
    assert not calls, f"{path}: only hil/clock.py may read the OS clock (found time.{sorted(calls)})"


@pytest.mark.parametrize("path", _modules("hil/plant"), ids=lambda p: str(p.relative_to(ROOT)))
def test_plant_is_pure_numerics(path: Path) -> None:
    forbidden = {"asyncio", "os", "time", "random", "socket", "serial", "emulators", "flightcode", "threading"}
    bad = [(line, mod) for line, mod in _imports(path) if mod in forbidden]
    # the benchmark script may use the clock module of the bench, nothing else
    assert not bad, f"{path}: the plant is pure numerics: {bad}"
