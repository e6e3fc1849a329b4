"""Edits applied to a copy of a source tree: never to the tree itself.

A tree travels to a worker as a snapshot (relative path -> bytes), so workers need no shared
filesystem; :func:`materialize` writes it, with the edits applied, under a directory.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from pathlib import Path

from hil.config import ConfigError

#: build products and caches (a C tree's ``build/`` too: a mutant is built from its sources)
_SKIP_DIRS = {"__pycache__", ".mypy_cache", ".pytest_cache", "build"}
_SKIP_SUFFIXES = {".pyc", ".pyo", ".so", ".pyd", ".o"}


@dataclass(frozen=True)
class Edit:
    """Replace the single occurrence of ``old`` in ``file`` (relative to the tree) by ``new``."""

    file: str
    old: str
    new: str


def apply_edit(text: str, edit: Edit, *, where: str = "") -> str:
    """``text`` with ``edit`` applied; ConfigError unless ``old`` occurs exactly once."""
    n = text.count(edit.old)
    if n != 1:
        raise ConfigError(f"{where or edit.file}: the edit's old text occurs {n} times (must be exactly once)")
    return text.replace(edit.old, edit.new, 1)


def snapshot(tree: Path) -> dict[str, bytes]:
    """Every source file of ``tree`` (no caches, no build products): relative path -> bytes."""
    if not tree.is_dir():
        raise ConfigError(f"{tree}: the source tree does not exist")
    out: dict[str, bytes] = {}
    for p in sorted(tree.rglob("*")):
        rel = p.relative_to(tree)
        if p.is_file() and not (set(rel.parts) & _SKIP_DIRS) and p.suffix not in _SKIP_SUFFIXES:
            out[rel.as_posix()] = p.read_bytes()
    return out


def context(root: Path, paths: tuple[str, ...], *, what: str = "") -> dict[str, bytes]:
    """Files outside the tree that building it needs (``[target] context``), unmutated:
    path relative to ``root`` -> bytes; ConfigError naming a missing one."""
    out: dict[str, bytes] = {}
    for rel in paths:
        p = root / rel
        if not p.is_file():
            raise ConfigError(f"{what}: target.context: no such file {p}")
        out[rel] = p.read_bytes()
    return out


def edited(files: dict[str, bytes], edits: list[Edit], *, what: str = "") -> dict[str, bytes]:
    """The snapshot with the edits applied (a new dict; the input is left alone)."""
    out = dict(files)
    for e in edits:
        if e.file not in out:
            raise ConfigError(f"{what}: file {e.file!r} is not in the source tree")
        out[e.file] = apply_edit(out[e.file].decode(), e, where=f"{what}: {e.file}").encode()
    return out


def materialize(files: dict[str, bytes], dst: Path) -> None:
    """Write a snapshot under ``dst`` (created)."""
    for rel, data in files.items():
        p = dst / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)


def diff(files: dict[str, bytes], edits: list[Edit], tree_name: str) -> str:
    """The unified diff of the edits against the snapshot."""
    after = edited(files, edits)
    chunks: list[str] = []
    for rel in sorted({e.file for e in edits}):
        a, b = files[rel].decode().splitlines(True), after[rel].decode().splitlines(True)
        chunks.extend(difflib.unified_diff(a, b, f"a/{tree_name}/{rel}", f"b/{tree_name}/{rel}", n=1))
    return "".join(chunks)
