"""Operator mutants: cosmic-ray's mutation operators over chosen modules, drawn by seed.

Every (module, operator, occurrence) that cosmic-ray's operators offer in the modules is
enumerated in a fixed order; ``random.Random(seed).sample`` draws ``n`` of them, so the same
seed over the same source draws the same mutants. Operators that need arguments are left out.
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hil.fleet.mutation.edits import Edit


@dataclass(frozen=True)
class OperatorSite:
    """One place an operator can mutate: module (relative to the tree), operator, occurrence."""

    file: str
    operator: str
    occurrence: int

    @property
    def id(self) -> str:
        stem = self.file.removesuffix(".py").replace("/", ".")
        return f"op-{stem}-{self.operator.split('/')[-1].lower()}-{self.occurrence}"


def _modules(tree: Path, modules: tuple[str, ...] | list[str]) -> list[str]:
    out: set[str] = set()
    for m in modules:
        p = tree / m
        files = [p] if p.is_file() else sorted(p.rglob("*.py"))
        out.update(f.relative_to(tree).as_posix() for f in files if f.name != "__init__.py")
    return sorted(out)


def _operators() -> list[tuple[str, Any]]:
    import cosmic_ray.plugins

    ops = []
    for name in sorted(cosmic_ray.plugins.operator_names()):
        cls = cosmic_ray.plugins.get_operator(name)
        if not cls.arguments():
            ops.append((name, cls()))
    return ops


def sites(tree: Path, modules: tuple[str, ...] | list[str]) -> list[OperatorSite]:
    """Every operator site in ``modules`` (files or directories under ``tree``), in a fixed order."""
    from cosmic_ray.ast import ast_nodes, get_ast

    ops = _operators()
    out: list[OperatorSite] = []
    for rel in _modules(tree, modules):
        module_ast = get_ast((tree / rel).read_text())
        nodes = list(ast_nodes(module_ast))
        for name, op in ops:
            count = sum(len(list(op.mutation_positions(node))) for node in nodes)
            out.extend(OperatorSite(rel, name, i) for i in range(count))
    return out


def draw(all_sites: list[OperatorSite], n: int, seed: int) -> list[OperatorSite]:
    """``n`` sites drawn by ``seed`` (all of them if fewer), in the order drawn."""
    return random.Random(seed).sample(all_sites, min(n, len(all_sites)))


def edit_for(tree: Path, site: OperatorSite) -> Edit | None:
    """The whole-file edit that applies ``site``'s mutation; None if cosmic-ray makes none."""
    import cosmic_ray.plugins
    from cosmic_ray.mutating import mutate_code

    source = (tree / site.file).read_text()
    mutated = mutate_code(source, cosmic_ray.plugins.get_operator(site.operator)(), site.occurrence)
    if mutated is None or mutated == source:
        return None
    return Edit(site.file, source, mutated)
