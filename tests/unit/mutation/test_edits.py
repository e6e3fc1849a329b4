"""Edits apply to a copy, exactly once, and the snapshot carries source files only."""

from __future__ import annotations

from pathlib import Path

import pytest

from hil.config import ConfigError
from hil.fleet.mutation.edits import Edit, apply_edit, context, diff, edited, materialize, snapshot


def test_apply_edit_needs_exactly_one_occurrence() -> None:
    assert apply_edit("a = 1\n", Edit("m.py", "1", "2")) == "a = 2\n"
    with pytest.raises(ConfigError, match="occurs 0 times"):
        apply_edit("a = 1\n", Edit("m.py", "3", "2"))
    with pytest.raises(ConfigError, match="occurs 2 times"):
        apply_edit("a = 1; b = 1\n", Edit("m.py", "1", "2"))


def test_snapshot_materialize_and_diff(tmp_path: Path) -> None:
    src = tmp_path / "pkg"
    (src / "sub" / "__pycache__").mkdir(parents=True)
    (src / "m.py").write_text("x = 1\ny = 2\n")
    (src / "sub" / "n.py").write_text("z = 3\n")
    (src / "sub" / "__pycache__" / "n.cpython-311.pyc").write_bytes(b"\0")
    (src / "fast.so").write_bytes(b"\0")
    files = snapshot(src)
    assert sorted(files) == ["m.py", "sub/n.py"]
    out = edited(files, [Edit("m.py", "x = 1", "x = -1")], what="neg")
    assert files["m.py"] == b"x = 1\ny = 2\n"  # the input is left alone
    materialize(out, tmp_path / "copy" / "pkg")
    assert (tmp_path / "copy" / "pkg" / "m.py").read_text() == "x = -1\ny = 2\n"
    assert (src / "m.py").read_text() == "x = 1\ny = 2\n"
    d = diff(files, [Edit("m.py", "x = 1", "x = -1")], "pkg")
    assert "-x = 1" in d and "+x = -1" in d and "a/pkg/m.py" in d
    with pytest.raises(ConfigError, match="not in the source tree"):
        edited(files, [Edit("gone.py", "a", "b")], what="gone")


def test_snapshot_of_a_missing_tree(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="does not exist"):
        snapshot(tmp_path / "nope")


def test_a_c_trees_snapshot_has_its_sources_and_no_build(tmp_path: Path) -> None:
    """A C flight code's sources and Makefile travel; its build/ and objects do not (a mutant
    is built from its own sources)."""
    src = tmp_path / "fw"
    (src / "src").mkdir(parents=True)
    (src / "build" / "host").mkdir(parents=True)
    (src / "Makefile").write_text("all:\n")
    (src / "src" / "a.c").write_text("int a;\n")
    (src / "src" / "a.h").write_text("extern int a;\n")
    (src / "src" / "a.o").write_bytes(b"\0")
    (src / "build" / "host" / "fc").write_bytes(b"\0")
    assert sorted(snapshot(src)) == ["Makefile", "src/a.c", "src/a.h"]


def test_context_files_travel_unmutated_and_a_missing_one_is_named(tmp_path: Path) -> None:
    (tmp_path / "rigs").mkdir()
    (tmp_path / "rigs" / "fc.toml").write_text("[x]\n")
    assert context(tmp_path, ("rigs/fc.toml",)) == {"rigs/fc.toml": b"[x]\n"}
    with pytest.raises(ConfigError, match=r"cat.toml: target.context: no such file .*rigs/gone.toml"):
        context(tmp_path, ("rigs/gone.toml",), what="cat.toml")
