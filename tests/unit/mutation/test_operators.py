"""Operator mutants come from cosmic-ray's operators and are drawn reproducibly by seed."""

from __future__ import annotations

from pathlib import Path

import pytest

from hil.fleet.mutation import operators
from hil.fleet.mutation.runner import operator_mutants

SRC = '''import math


def gain(x, k=2.0):
    if x > 1.0 and k >= 0.0:
        return k * x + 1.0
    return -x / k
'''


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    (tmp_path / "ctl").mkdir()
    (tmp_path / "ctl" / "law.py").write_text(SRC)
    (tmp_path / "ctl" / "__init__.py").write_text("")
    (tmp_path / "other.py").write_text("y = 1 + 2\n")
    return tmp_path


def test_sites_cover_only_the_chosen_modules(tree: Path) -> None:
    sites = operators.sites(tree, ["ctl"])
    assert sites and {s.file for s in sites} == {"ctl/law.py"}
    assert all("/" in s.operator for s in sites)  # cosmic-ray's names, e.g. core/NumberReplacer


def test_draw_is_reproducible_by_seed(tree: Path) -> None:
    sites = operators.sites(tree, ["ctl"])
    a = operators.draw(sites, 5, seed=7)
    assert a == operators.draw(operators.sites(tree, ["ctl"]), 5, seed=7)
    assert a != operators.draw(sites, 5, seed=8)
    assert len(set(a)) == 5


def test_operator_mutants_change_the_source(tree: Path) -> None:
    ms = operator_mutants(tree, ("ctl",), 4, seed=3)
    assert len(ms) == 4 and len({m.id for m in ms}) == 4
    assert [m.id for m in ms] == [m.id for m in operator_mutants(tree, ("ctl",), 4, seed=3)]
    for m in ms:
        (edit,) = m.edits
        assert edit.old == SRC and edit.new != SRC
        assert m.origin == "operator" and m.layer == "ctl"
    assert (tree / "ctl" / "law.py").read_text() == SRC  # drawn on text: nothing edited in place
    assert operator_mutants(tree, ("ctl",), 0, seed=3) == []
