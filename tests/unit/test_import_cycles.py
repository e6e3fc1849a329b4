"""No import circles among our modules (hil, emulators, flightcode), found on the source (AST).

Every import counts: at module level, inside functions (a deferred import still ties the two
modules together) and under ``if TYPE_CHECKING:`` (mypy and readers follow those too). An edge
goes to the module imported, not to its parent packages: ``from hil.record import frames``
names the module ``hil.record.frames``; ``from hil.record import Recorder`` names the package
``hil.record`` (its ``__init__``).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("hil", "emulators", "flightcode")


def module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def find_modules(root: Path, packages: tuple[str, ...] = PACKAGES) -> dict[str, Path]:
    """Dotted module name -> source file, for every ``.py`` of ``packages`` under ``root``."""
    return {module_name(p, root): p for package in packages for p in sorted((root / package).rglob("*.py"))}


def _ours(name: str, modules: dict[str, Path]) -> str | None:
    """The longest prefix of ``name`` that is one of our modules, or None (not ours)."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def imported_modules(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """Our modules that ``name`` (at ``path``) imports anywhere in its source."""
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found: set[str | None] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            found.update(_ours(alias.name, modules) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - (node.level - 1)]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            for alias in node.names:
                sub = f"{source}.{alias.name}"
                found.add(sub if sub in modules else _ours(source, modules))
    found.discard(None)
    found.discard(name)
    return {m for m in found if m is not None}


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative), each
    sorted; every import circle lies within one of them."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    cycles.append(sorted(component))
    return cycles


def import_graph(root: Path) -> dict[str, set[str]]:
    modules = find_modules(root)
    return {name: imported_modules(name, path, modules) for name, path in modules.items()}


def test_no_import_cycles() -> None:
    cycles = import_cycles(import_graph(ROOT))
    assert not cycles, "import circles (break each; docs/architecture.md):\n" + "\n".join(
        " <-> ".join(c) for c in cycles)


# -- the finder itself finds circles ---------------------------------------------------------------

def _write(root: Path, files: dict[str, str]) -> None:
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


@pytest.mark.parametrize("files, expected", [
    # a three-module circle, one leg only for types
    ({"hil/__init__.py": "", "hil/a.py": "from hil.b import x\n", "hil/b.py": "import hil.c\n",
      "hil/c.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from hil.a import A\n"},
     [["hil.a", "hil.b", "hil.c"]]),
    # a deferred import inside a function, and a relative import naming a submodule
    ({"hil/__init__.py": "", "hil/p/__init__.py": "", "hil/p/a.py": "def f():\n    from hil.p import b\n",
      "hil/p/b.py": "from .a import f\n"},
     [["hil.p.a", "hil.p.b"]]),
    # across packages
    ({"hil/__init__.py": "", "emulators/__init__.py": "", "hil/a.py": "import emulators.b\n",
      "emulators/b.py": "from hil import a\n"},
     [["emulators.b", "hil.a"]]),
    # a chain, and a package importing its own module: no circle
    ({"hil/__init__.py": "from hil import a\n", "hil/a.py": "import hil.b\nimport numpy\n", "hil/b.py": ""},
     []),
])
def test_the_finder_finds_circles(tmp_path: Path, files: dict[str, str], expected: list[list[str]]) -> None:
    _write(tmp_path, files)
    assert import_cycles(import_graph(tmp_path)) == expected
