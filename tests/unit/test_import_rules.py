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


def _runtime_imports(path: Path, *, types_too: bool = False) -> list[tuple[int, str]]:
    """Full module names imported when the module runs: ``if TYPE_CHECKING:`` blocks (types
    only, never executed) are left out unless ``types_too``; ``from hil import x`` counts as
    ``hil.x``."""
    found: list[tuple[int, str]] = []

    def visit(node: ast.AST) -> None:
        if (not types_too and isinstance(node, ast.If) and isinstance(node.test, ast.Name)
                and node.test.id == "TYPE_CHECKING"):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import):
            found.extend((node.lineno, alias.name) for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module in {"hil", "hil.config"}:
                found.extend((node.lineno, f"{node.module}.{alias.name}") for alias in node.names)
            found.append((node.lineno, node.module))
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(ast.parse(path.read_text(), filename=str(path)))
    return found


def _within(module: str, packages: set[str]) -> bool:
    return any(module == p or module.startswith(p + ".") for p in packages)


#: the packages of hil/ that do one job each (docs/architecture.md), and what each may not
#: import when it runs. The layers beneath them (plant, faults, record, transport, vtime,
#: config) import none of them.
JOBS = {"hil.flight", "hil.analysis", "hil.fleet", "hil.host", "hil.perf", "hil.testing", "hil.cli",
        "hil.pytest_plugin"}
FORBIDDEN = {
    # beneath the jobs
    "hil/plant": JOBS, "hil/faults": JOBS, "hil/record": JOBS, "hil/transport": JOBS, "hil/vtime": JOBS,
    "hil/config": JOBS, "hil/board": JOBS,
    # what a run or a log says: read-only, never starts a flight
    "hil/analysis": JOBS - {"hil.analysis"},
    # one flight knows nothing of many flights, of users' tests, of benchmarks or of the command line
    "hil/flight": {"hil.fleet", "hil.testing", "hil.perf", "hil.cli", "hil.pytest_plugin"},
    "hil/fleet": {"hil.testing", "hil.perf", "hil.cli", "hil.pytest_plugin"},
    # the host's figures
    "hil/host": JOBS - {"hil.host"},
    "hil/testing": {"hil.fleet", "hil.perf", "hil.cli"},
    # hil perf: measures the bench, flies it, and nothing but the command uses it
    "hil/perf": {"hil.fleet", "hil.testing", "hil.cli", "hil.pytest_plugin"},
}


@pytest.mark.parametrize("path", [p for package in FORBIDDEN for p in _modules(package)],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_hil_packages_keep_to_their_jobs(path: Path) -> None:
    package = next(p for p in FORBIDDEN if path.is_relative_to(ROOT / p))
    forbidden = FORBIDDEN[package]
    bad = [(line, mod) for line, mod in _runtime_imports(path) if _within(mod, forbidden)]
    assert not bad, f"{path}: {package} may not import {sorted(forbidden)} (docs/architecture.md): {bad}"


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
    assert not bad, f"{path}: the plant is pure numerics: {bad}"


def _c_includes(path: Path) -> list[tuple[int, str]]:
    import re

    pattern = re.compile(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]')
    return [(n, m.group(1)) for n, line in enumerate(path.read_text().splitlines(), 1) if (m := pattern.match(line))]


_FIRMWARE_C = sorted(p for p in (ROOT / "firmware").rglob("*.[chS]") if "build" not in p.relative_to(ROOT).parts)


@pytest.mark.parametrize("path", _FIRMWARE_C, ids=lambda p: str(p.relative_to(ROOT)))
def test_firmware_includes_nothing_of_the_bench(path: Path) -> None:
    """The firmware knows nothing of the bench: no header of hil/ (the clock shim's ABI
    included) and no path into the repository outside firmware/."""
    bad = [(n, inc) for n, inc in _c_includes(path) if "hvt" in inc or inc.startswith(("hil", "../")) or "/hil/" in inc]
    assert not bad, f"{path}: the firmware must not include the bench's headers: {bad}"


#: what only a hardware layer may include: the host's system interfaces
_POSIX_ONLY = ("unistd.h", "termios.h", "poll.h", "fcntl.h", "signal.h", "pthread.h", "time.h", "sys/", "asm/")


@pytest.mark.parametrize("path", sorted((ROOT / "firmware" / "src").rglob("*.[ch]")),
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_firmware_above_the_hal_is_portable(path: Path) -> None:
    """Drivers, estimation, control, modes, loop and main run on the LPC2148 too: they reach
    the hardware through firmware/include/hal.h only, never the host's system headers."""
    bad = [(n, inc) for n, inc in _c_includes(path) if inc.startswith(_POSIX_ONLY)]
    assert not bad, f"{path}: only firmware/hal/<board>/ may include system interfaces: {bad}"
