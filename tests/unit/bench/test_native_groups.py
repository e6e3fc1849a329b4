"""``hil build --groups``: the mypyc groups computed from the sources, the choice recorded in
the manifest and shown by describe(), the command's parsing, and the progress of a long
single-file compile. Nothing here compiles or times anything."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from rich.console import Console
from typer.testing import CliRunner

from hil import native
from hil.cli import app
from hil.native import build as native_build
from hil.native import compile as native_compile
from hil.native import manifest as m
from hil.native.loader import LoadState, Why, _decide
from hil.native.progress import LINE_EVERY_S, BuildProgress
from hil.native.sources import GROUPINGS, ONE_GROUP, OPT_LEVELS, compiled_sources, groups, project_root

ROOT = project_root()


def test_modules_is_one_group_per_source() -> None:
    sources = compiled_sources(ROOT)
    assert groups(sources, "modules") == [([s], None) for s in sources]


def test_one_is_every_source_in_one_named_group_at_o3() -> None:
    sources = compiled_sources(ROOT)
    assert groups(sources, "one") == [(sources, ONE_GROUP)]
    assert OPT_LEVELS == {"modules": "2", "one": "3"} and set(GROUPINGS) == set(OPT_LEVELS)


@pytest.mark.parametrize("grouping", GROUPINGS)
def test_every_source_is_in_exactly_one_group(grouping: str) -> None:
    sources = compiled_sources(ROOT)
    placed = [s for files, _name in groups(sources, grouping) for s in files]
    assert sorted(placed) == sorted(sources) and len(placed) == len(set(placed))


def test_an_unknown_grouping_is_refused() -> None:
    with pytest.raises(ValueError, match="expected one of modules, one"):
        groups(["a.py"], "two")


def test_the_manifest_records_the_grouping() -> None:
    one = m.Manifest(root="/r", interpreter="i", opt_level="3", built_ns=1, groups="one")
    assert m.Manifest.from_json(one.to_json()).groups == "one"
    # a build from before the option: one extension per module
    old = one.to_json().replace('"groups": "one",', "")
    assert '"groups"' not in old and m.Manifest.from_json(old).groups == "modules"


def _one_group_build(tmp_path: Path) -> tuple[Path, Path]:
    root = tmp_path / "checkout"
    (root / "emulators").mkdir(parents=True)
    src = root / "emulators" / "base.py"
    src.write_text("X = 1\n")
    build = tmp_path / "build"
    build.mkdir()
    m.Manifest(root=str(root), interpreter=m.interpreter_tag(), opt_level="3", built_ns=1, groups="one",
               modules={}, sources={"emulators/base.py": m.SourceStamp.of(src)}).write(build)
    return root, build


def test_a_fresh_one_group_build_is_used_and_says_so(tmp_path: Path) -> None:
    root, build = _one_group_build(tmp_path)
    state, manifest = _decide(build, root)
    assert state.why is Why.COMPILED and state.groups == "one" and state.opt_level == "3" and manifest is not None


def test_an_edited_source_makes_a_one_group_build_stale(tmp_path: Path) -> None:
    root, build = _one_group_build(tmp_path)
    (root / "emulators" / "base.py").write_text("X = 2\n")
    state, manifest = _decide(build, root)
    assert state.why is Why.STALE and state.changed == ("emulators/base.py",) and manifest is None


@pytest.mark.parametrize("grouping, shown", [("one", "compiled (mypyc -O3, --groups one, built "),
                                             ("modules", "compiled (mypyc -O2, one extension per module, built ")])
def test_describe_names_the_grouping(monkeypatch: pytest.MonkeyPatch, grouping: str, shown: str) -> None:
    state = LoadState(Path("/b"), Why.COMPILED, opt_level=OPT_LEVELS[grouping], groups=grouping, built_ns=10**18)
    monkeypatch.setattr(native, "state", lambda: state)
    assert native.describe().startswith(shown)


def _fake_build(calls: list[dict[str, Any]]) -> Any:
    def build(**kw: Any) -> m.Manifest:
        calls.append(kw)
        return m.Manifest(root="/r", interpreter="i", opt_level=OPT_LEVELS[kw["groups"]], built_ns=1,
                          groups=kw["groups"], modules={"a": "a.so"})
    return build


@pytest.mark.parametrize("args, grouping", [([], "modules"), (["--groups", "one"], "one"),
                                            (["--groups", "modules"], "modules")])
def test_the_command_passes_the_grouping(monkeypatch: pytest.MonkeyPatch, args: list[str], grouping: str) -> None:
    calls: list[dict[str, Any]] = []
    monkeypatch.setattr(native_build, "build", _fake_build(calls))
    res = CliRunner().invoke(app, ["build", *args], env={"COLUMNS": "400"})
    assert res.exit_code == 0, res.output
    assert [c["groups"] for c in calls] == [grouping]
    assert f"compiled 1 extension modules (--groups {grouping})" in res.output


def test_the_command_refuses_an_unknown_grouping(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[dict[str, Any]] = []
    monkeypatch.setattr(native_build, "build", _fake_build(calls))
    res = CliRunner().invoke(app, ["build", "--groups", "two"], env={"COLUMNS": "400"})
    assert res.exit_code == 2 and calls == []


def test_the_compiler_process_refuses_an_unknown_grouping() -> None:
    with pytest.raises(SystemExit) as exc:
        native_compile.main(["out", "--groups", "two"])
    assert exc.value.code == 2


def test_the_note_of_a_large_group_says_what_and_how_long() -> None:
    assert native_build.largest_note(1, 539_281, "3") == "compiling 1 C file of 539,281 lines at -O3, about 5-9 min on one core"
    assert native_build.largest_note(3, 100, "2").startswith("compiling 3 C files of 100 lines at -O2, about 1-2 min")


class _Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def test_a_silent_compile_still_prints_a_line_every_10_s_on_a_pipe() -> None:
    console = Console(force_terminal=False, width=60, record=True)
    clock = _Clock()
    with BuildProgress(console, now=clock, heartbeat=False) as progress:
        progress.update(0, 95)
        progress.note("compiling 1 C file of 9 lines at -O3, about 1-2 min on one core")
        progress.update(95, 95)
        clock.t = LINE_EVERY_S / 2
        progress.tick()  # a line was printed less than 10 s ago: nothing
        for _ in range(3):
            clock.t += LINE_EVERY_S
            progress.tick()
    lines = [line.split("] ", 1)[1] for line in console.export_text().splitlines()]
    assert lines == ["type-checking and generating C (mypyc)", "compiling C: 0/95 extension modules started",
                     "compiling 1 C file of 9 lines at -O3, about 1-2 min on one core: 0/95 extension modules started",
                     "compiling 1 C file of 9 lines at -O3, about 1-2 min on one core: 95/95 extension modules started",
                     *["compiling 1 C file of 9 lines at -O3, about 1-2 min on one core: 95/95 extension modules "
                       "started, still working"] * 3]


def test_the_type_check_alone_still_prints_a_line_every_10_s() -> None:
    console = Console(force_terminal=False, width=60, record=True)
    clock = _Clock()
    with BuildProgress(console, now=clock, heartbeat=False) as progress:
        clock.t = LINE_EVERY_S
        progress.tick()
    assert console.export_text().splitlines()[-1].endswith("type-checking and generating C (mypyc), still working")


@pytest.mark.parametrize("grouping", GROUPINGS)
def test_build_runs_the_compiler_with_the_grouping_and_records_it(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                                                                  grouping: str) -> None:
    seen: list[tuple[str, str]] = []

    def fake_compiler(tmp: Path, root: Path, groups: str, opt_level: str, jobs: int, progress: Any,
                      note: Any) -> None:
        seen.append((groups, opt_level))
        (tmp / "lib" / "emulators").mkdir(parents=True)
        (tmp / "lib" / "emulators" / "base.cpython-311-x86_64-linux-gnu.so").write_bytes(b"")

    monkeypatch.setattr(native_build, "preflight", lambda: None)
    monkeypatch.setattr(native_build, "_run_compiler", fake_compiler)
    built = native_build.build(groups=grouping, directory=tmp_path / "native")
    assert seen == [(grouping, OPT_LEVELS[grouping])]
    assert built.groups == grouping and built.opt_level == OPT_LEVELS[grouping]
    assert m.read(tmp_path / "native") == built and built.modules == {
        "emulators.base": "emulators/base.cpython-311-x86_64-linux-gnu.so"}


def test_a_stale_one_group_build_names_the_command_that_rebuilds_it(tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    root, build = _one_group_build(tmp_path)
    (root / "emulators" / "base.py").write_text("X = 2\n")
    state, _ = _decide(build, root)
    assert native.stale_message(state.changed, state.groups).endswith("`hil build --groups one` recompiles")
    assert native.stale_message(state.changed).endswith("`hil build` recompiles")
    monkeypatch.setattr(native, "state", lambda: state)
    assert native.describe() == "interpreted (the compiled build is stale (1 sources changed): `hil build --groups one`)"


def test_on_a_terminal_a_long_note_wraps_and_leaves_the_elapsed_time_shown() -> None:
    console = Console(force_terminal=True, width=80, color_system=None, record=True)
    with BuildProgress(console) as progress:
        progress.update(95, 95)
        progress.note("compiling 1 C file of 539,281 lines at -O3, about 5-9 min on one core")
        assert progress._bar is not None
        console.print(progress._bar.get_renderable())
    lines = console.export_text().splitlines()
    row = next(i for i, line in enumerate(lines) if "95/95" in line)
    assert "0:00:0" in lines[row] and "about 5-9 min on one core" in " ".join(lines[row:row + 2])
