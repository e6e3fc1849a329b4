"""The shipped catalogue: valid, >= 40 realistic edits over every layer, each applying exactly
once to today's flight code; and the validation of bad catalogues and equivalents files."""

from __future__ import annotations

import ast
import builtins
from pathlib import Path

import pytest

from hil.config import ConfigError
from hil.fleet.mutation import operators
from hil.fleet.mutation.catalogue import load_catalogue, load_equivalents
from hil.fleet.mutation.edits import Edit, edited, snapshot

ROOT = Path(__file__).resolve().parents[3]
CATALOGUE = ROOT / "rigs" / "mutation" / "flightcode.toml"
EQUIVALENTS = ROOT / "rigs" / "mutation" / "flightcode-equivalents.toml"


@pytest.fixture(scope="module")
def cat():
    return load_catalogue(CATALOGUE)


@pytest.fixture(scope="module")
def tree(cat):
    return snapshot(ROOT / cat.target.tree)


def test_at_least_40_covering_every_layer(cat) -> None:
    assert len(cat.mutant) >= 40
    assert {m.layer for m in cat.mutant} == {"drivers", "estimation", "control", "modes", "loop", "telemetry"}
    assert any(m.compute_only for m in cat.mutant)


@pytest.mark.parametrize("i", range(len(load_catalogue(CATALOGUE).mutant)))
def test_each_entry_applies_exactly_once_to_todays_flight_code(cat, tree, i: int) -> None:
    m = cat.mutant[i]
    assert m.file in tree, f"{m.id}: {m.file} is not in {cat.target.tree}/ (re-point the entry)"
    text = tree[m.file].decode()
    assert text.count(m.old) == 1, f"{m.id}: the old text occurs {text.count(m.old)} times in {m.file}"
    after = edited(tree, [Edit(m.file, m.old, m.new)], what=m.id)
    assert after[m.file] != tree[m.file]
    compile(after[m.file].decode(), m.file, "exec")  # a defect, not a syntax error
    unbound = _new_names(tree[m.file].decode(), after[m.file].decode()) - _bound_names(after[m.file].decode())
    assert not unbound, f"{m.id}: the edit reads names bound nowhere in {m.file}: {sorted(unbound)} (a NameError, not a defect)"


def _loaded(source: str) -> set[str]:
    return {n.id for n in ast.walk(ast.parse(source)) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load)}


def _new_names(before: str, after: str) -> set[str]:
    """Names the edit makes the module read that it did not read before."""
    return _loaded(after) - _loaded(before)


def _bound_names(source: str) -> set[str]:
    """Every name the module binds anywhere (imports, defs, assignments, arguments), and builtins."""
    bound = set(dir(builtins))
    for n in ast.walk(ast.parse(source)):
        if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store):
            bound.add(n.id)
        elif isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            bound.add(n.name)
        elif isinstance(n, ast.arg):
            bound.add(n.arg)
        elif isinstance(n, (ast.Import, ast.ImportFrom)):
            bound.update((a.asname or a.name).split(".")[0] for a in n.names)
    return bound


def test_the_flight_code_is_not_edited_and_has_nothing_for_mutation(cat, tree) -> None:
    before = dict(tree)
    edited(tree, [Edit(m.file, m.old, m.new) for m in cat.mutant[:1]])
    assert tree == before
    assert not any("mutat" in rel.lower() or b"MUTANT" in data for rel, data in tree.items())


def test_shipped_equivalents_name_known_mutants(cat) -> None:
    """Catalogue entries by id; operator mutants by a site a draw over today's tree can give
    (their ids number the sites of a module, so an edit before one moves it)."""
    sites = {site.id for site in operators.sites(ROOT / cat.target.tree, cat.target.operator_modules)}
    eq = load_equivalents(EQUIVALENTS, {m.id for m in cat.mutant}, lambda: sites)
    assert eq and all(k in sites or k in {m.id for m in cat.mutant} for k in eq)


def _write(tmp_path: Path, body: str) -> Path:
    p = tmp_path / "cat.toml"
    p.write_text('[target]\nname = "x"\ntree = "src"\n' + body)
    return p


_OK = '''[[mutant]]
id = "a-b"
layer = "control"
kind = "sign"
file = "m.py"
old = "x = 1"
new = "x = -1"
effect = "the vehicle does the wrong thing"
'''


@pytest.mark.parametrize(("body", "key"), [
    (_OK + _OK, "mutant"),  # duplicate id
    (_OK.replace('layer = "control"', 'layer = "cockpit"'), "mutant.0.layer"),
    (_OK.replace('effect = "the vehicle does the wrong thing"\n', ""), "mutant.0.effect"),
    (_OK.replace('file = "m.py"', 'file = "/etc/passwd"'), "mutant.0.file"),
    (_OK.replace('file = "m.py"', 'file = "../m.py"'), "mutant.0.file"),
    (_OK + 'colour = "red"\n', "mutant.0.colour"),
    (_OK.replace('old = "x = 1"', 'old = ""'), "mutant.0.old"),
    (_OK.replace('id = "a-b"', 'id = "A B"'), "mutant.0.id"),
])
def test_bad_catalogue_names_file_and_key(tmp_path: Path, body: str, key: str) -> None:
    p = _write(tmp_path, body)
    with pytest.raises(ConfigError) as err:
        load_catalogue(p)
    assert str(p) in str(err.value) and key in str(err.value)


def test_not_toml(tmp_path: Path) -> None:
    p = tmp_path / "c.toml"
    p.write_text("[target\n")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_catalogue(p)


def test_good_catalogue_loads(tmp_path: Path) -> None:
    assert load_catalogue(_write(tmp_path, _OK)).mutant[0].id == "a-b"


def test_equivalents_need_a_reason_and_a_known_mutant(tmp_path: Path) -> None:
    p = tmp_path / "eq.toml"
    p.write_text('[[equivalent]]\nid = "a-b"\nreason = "short"\n')
    with pytest.raises(ConfigError, match="equivalent.0.reason"):
        load_equivalents(p, {"a-b"})
    p.write_text('[[equivalent]]\nid = "zz"\nreason = "no flight can tell it from the original code"\n')
    with pytest.raises(ConfigError, match="no such mutant: zz"):
        load_equivalents(p, {"a-b"})
    assert load_equivalents(p, {"zz"}) == {"zz": "no flight can tell it from the original code"}
    asked: list[int] = []
    assert load_equivalents(p, {"a-b"}, lambda: asked.append(1) or {"zz"}) == {  # type: ignore[func-returns-value]
        "zz": "no flight can tell it from the original code"}
    assert asked == [1]
    assert load_equivalents(p, {"zz"}, lambda: asked.append(2) or set()) and asked == [1]  # type: ignore[func-returns-value]
    with pytest.raises(ConfigError, match="no such mutant: zz"):
        load_equivalents(p, {"a-b"}, set)
    assert load_equivalents(tmp_path / "missing.toml", {"a-b"}) == {}


@pytest.mark.parametrize("rel", ["../rigs/fc.toml", "/etc/passwd"])
def test_context_outside_the_project_names_the_key(tmp_path: Path, rel: str) -> None:
    p = tmp_path / "cat.toml"
    p.write_text(f'[target]\nname = "x"\ntree = "src"\ncontext = ["{rel}"]\n' + _OK)
    with pytest.raises(ConfigError, match=r"target\.context"):
        load_catalogue(p)
