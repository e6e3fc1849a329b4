"""hil.native: the optional compiled build is used only while it is the build of the sources.

The loader's decisions are tested on fake builds (a manifest in a temporary directory); the
compiled modules themselves are exercised by CI's compiled pass (`hil build`, then the unit
tests and tests/system/test_compiled_equivalence.py).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from rich.console import Console

import emulators.base
import hil.flight.devices
import hil.plant.plant
from hil import native
from hil.native import build as native_build
from hil.native import manifest as m
from hil.native.loader import Why, _decide
from hil.native.progress import BuildProgress
from hil.native.sources import compiled_sources, module_name, project_root, watched_sources

ROOT = project_root()


def test_compiled_matches_the_modules_files() -> None:
    state = native.compiled()
    assert state == {"emulators": not emulators.base.__file__.endswith(".py"),
                     "hil.plant": not str(hil.plant.plant.__file__).endswith(".py"),
                     "hil tick path": not str(hil.flight.devices.__file__).endswith(".py")}
    # each part whole or not at all, and as the loader decided
    assert set(state.values()) == {native.state().compiled}


def test_describe_names_the_state() -> None:
    text = native.describe()
    if native.state().compiled:
        assert text.startswith("compiled (mypyc -O")
    else:
        assert text.startswith("interpreted (") and "hil build" in text or "HIL_NATIVE" in text


def test_the_compiled_set_is_the_device_models_the_plant_and_the_tick_path() -> None:
    sources = compiled_sources(ROOT)
    assert "emulators/base.py" in sources and "hil/plant/plant.py" in sources and "hil/flight/tickloop.py" in sources
    assert "hil/plant/params.py" not in sources  # pydantic: interpreted on purpose
    assert set(sources) <= set(watched_sources(ROOT))
    assert module_name("emulators/rc/__init__.py") == "emulators.rc"
    assert module_name("hil/plant/plant.py") == "hil.plant.plant"


def _fake_build(tmp_path: Path, root: Path, sources: dict[str, m.SourceStamp], **kw: str) -> Path:
    build = tmp_path / "build"
    build.mkdir()
    manifest = m.Manifest(root=str(root), interpreter=kw.get("interpreter", m.interpreter_tag()), opt_level="2",
                          built_ns=1, modules={}, sources=sources)
    manifest.write(build)
    return build


@pytest.fixture
def tree(tmp_path: Path) -> tuple[Path, dict[str, m.SourceStamp]]:
    root = tmp_path / "checkout"
    (root / "emulators").mkdir(parents=True)
    src = root / "emulators" / "base.py"
    src.write_text("X = 1\n")
    return root, {"emulators/base.py": m.SourceStamp.of(src)}


def test_no_build_runs_interpreted(tmp_path: Path) -> None:
    state, manifest = _decide(tmp_path / "nothing", ROOT)
    assert state.why is Why.NOT_BUILT and manifest is None


def test_a_fresh_build_is_used(tmp_path: Path, tree: tuple[Path, dict[str, m.SourceStamp]]) -> None:
    root, stamps = tree
    state, manifest = _decide(_fake_build(tmp_path, root, stamps), root)
    assert state.why is Why.COMPILED and manifest is not None


def test_an_edited_source_makes_the_build_stale(tmp_path: Path, tree: tuple[Path, dict[str, m.SourceStamp]]) -> None:
    root, stamps = tree
    build = _fake_build(tmp_path, root, stamps)
    (root / "emulators" / "base.py").write_text("X = 2\n")  # same size, other content
    state, manifest = _decide(build, root)
    assert state.why is Why.STALE and state.changed == ("emulators/base.py",) and manifest is None
    assert "emulators/base.py" in native.stale_message(state.changed)


def test_a_removed_source_makes_the_build_stale(tmp_path: Path, tree: tuple[Path, dict[str, m.SourceStamp]]) -> None:
    root, stamps = tree
    build = _fake_build(tmp_path, root, stamps)
    (root / "emulators" / "base.py").unlink()
    assert _decide(build, root)[0].why is Why.STALE


def test_a_touched_but_unchanged_source_keeps_the_build(tmp_path: Path,
                                                        tree: tuple[Path, dict[str, m.SourceStamp]]) -> None:
    root, stamps = tree
    build = _fake_build(tmp_path, root, stamps)
    src = root / "emulators" / "base.py"
    os.utime(src, ns=(src.stat().st_atime_ns, src.stat().st_mtime_ns + 10_000_000_000))  # a checkout's touch
    assert _decide(build, root)[0].why is Why.COMPILED


def test_a_build_of_another_interpreter_or_checkout_is_not_used(tmp_path: Path,
                                                                tree: tuple[Path, dict[str, m.SourceStamp]]) -> None:
    root, stamps = tree
    assert _decide(_fake_build(tmp_path, root, stamps, interpreter="cpython-312-x"), root)[0].why is Why.OTHER_BUILD
    assert _decide(tmp_path / "build", tmp_path / "elsewhere")[0].why is Why.OTHER_BUILD


def test_hil_native_0_switches_the_build_off(tmp_path: Path, tree: tuple[Path, dict[str, m.SourceStamp]],
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    root, stamps = tree
    monkeypatch.setenv("HIL_NATIVE", "0")
    assert _decide(_fake_build(tmp_path, root, stamps), root)[0].why is Why.SWITCHED_OFF


def test_an_unreadable_manifest_runs_interpreted(tmp_path: Path) -> None:
    (tmp_path / m.FILE).write_text("{not json")
    assert _decide(tmp_path, ROOT)[0].why is Why.UNREADABLE


_DAMAGED = {
    "a JSON list": "[1, 2]",
    "a JSON number": "3",
    "a JSON string": '"manifest"',
    "JSON null": "null",
    "sources not an object": '{"format": 1, "root": "/", "interpreter": "x", "opt_level": "3", "built_ns": 0, '
                             '"modules": {}, "sources": [1]}',
    "a source stamp not a list": '{"format": 1, "root": "/", "interpreter": "x", "opt_level": "3", "built_ns": 0, '
                                 '"modules": {}, "sources": {"hil/clock.py": 5}}',
    "built_ns not a number": '{"format": 1, "root": "/", "interpreter": "x", "opt_level": "3", "built_ns": "soon", '
                             '"modules": {}, "sources": {}}',
    "truncated": '{"format": 1, "root": ',
    "binary": "\udcff\x00\x01",
}


@pytest.mark.parametrize("text", list(_DAMAGED.values()), ids=list(_DAMAGED))
def test_a_damaged_or_foreign_manifest_runs_interpreted_with_the_reason(tmp_path: Path, text: str) -> None:
    (tmp_path / m.FILE).write_text(text, errors="surrogateescape")
    state = _decide(tmp_path, ROOT)[0]
    assert state.why is Why.UNREADABLE
    assert str(tmp_path / m.FILE) in state.detail and len(state.detail) > len(str(tmp_path / m.FILE)) + 2


def test_a_watched_source_that_cannot_be_read_runs_interpreted(tmp_path: Path) -> None:
    # the manifest is well formed, but a watched "source" is a directory: hashing it raises
    # IsADirectoryError inside changed_sources(), which once escaped the loader's try
    stamps = {"hil": m.SourceStamp("0" * 64, (ROOT / "hil").stat().st_size, 1)}
    state = _decide(_fake_build(tmp_path, ROOT, stamps), ROOT)[0]
    assert state.why is Why.UNREADABLE and "hil" in state.detail


def test_import_hil_survives_a_damaged_manifest(tmp_path: Path) -> None:
    (tmp_path / m.FILE).write_text("[]")
    env = {**os.environ, "HIL_NATIVE_DIR": str(tmp_path)}
    env.pop("HIL_NATIVE", None)
    out = subprocess.run([sys.executable, "-c", "import hil, hil.native as n; print(n.describe())"],
                         capture_output=True, text=True, env=env, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("interpreted (the compiled build is unreadable (")
    assert "not a manifest: a JSON list" in out.stdout


def test_a_stale_build_says_so_at_import_and_runs_interpreted(tmp_path: Path) -> None:
    # a real process: the manifest names hil/clock.py with another content
    stamps = {"hil/clock.py": m.SourceStamp("0" * 64, 1, 1)}
    build = _fake_build(tmp_path, ROOT, stamps)
    env = {**os.environ, "HIL_NATIVE_DIR": str(build)}
    env.pop("HIL_NATIVE", None)
    out = subprocess.run([sys.executable, "-c", "import hil, hil.native as n; print(n.describe())"],
                         capture_output=True, text=True, env=env, check=True)
    assert "the compiled build is older than hil/clock.py" in out.stderr and "hil build" in out.stderr
    assert out.stdout.startswith("interpreted (the compiled build is stale (1 sources changed)")


def test_the_build_says_what_to_install_without_a_compiler(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CC", "/nonexistent/cc")
    with pytest.raises(native_build.BuildError, match="no C compiler .*install one"):
        native_build.preflight()


def test_the_build_says_what_to_install_without_python_headers(monkeypatch: pytest.MonkeyPatch,
                                                               tmp_path: Path) -> None:
    import sysconfig

    paths = {**sysconfig.get_paths(), "include": str(tmp_path)}
    monkeypatch.setattr(sysconfig, "get_paths", lambda: paths)
    monkeypatch.setenv("CC", sys.executable)  # any program that exists: the compiler check passes
    with pytest.raises(native_build.BuildError, match="Python.h is missing: install Python's headers"):
        native_build.preflight()


def test_the_install_without_a_compiler_stops_with_one_sentence() -> None:
    out = subprocess.run([sys.executable, "setup.py", "--name"], cwd=ROOT, capture_output=True, text=True,
                         env={**os.environ, "CC": "/nonexistent/cc"})
    assert out.returncode != 0
    assert out.stderr.strip().splitlines() == [
        "error: mav-hil-bench needs a C compiler to build its clock shim (/nonexistent/cc not found): install one "
        "(Debian/Ubuntu: apt install gcc libc6-dev), then install again"]


def test_build_progress_on_a_pipe_prints_plain_lines() -> None:
    console = Console(force_terminal=False, width=100, record=True)
    with BuildProgress(console) as progress:
        progress.update(0, 10)
        progress.update(3, 10)  # within 10 s of the last line: no new line
        progress.update(10, 10)
    lines = console.export_text().splitlines()
    assert [line.split("] ", 1)[1] for line in lines] == [
        "type-checking and generating C (mypyc)", "compiling C: 0/10 extension modules started",
        "compiling C: 10/10 extension modules started"]
