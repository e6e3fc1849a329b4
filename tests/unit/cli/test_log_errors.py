"""Every command that reads a log answers a bad, torn or foreign file with exit 2 and one
sentence, and ``hil recover`` never destroys its input or writes a log from a non-MCAP file."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from mcap.writer import Writer
from typer.testing import CliRunner

from hil.cli import app
from hil.record import read_metadata
from tests.unit.record.support import record_examples

READERS = ["timing", "report", "replay", "replay --verify", "recover"]


def _invoke(command: str, *args: str) -> tuple[int, str]:
    res = CliRunner().invoke(app, [*command.split(), *args], env={"COLUMNS": "400"})
    return res.exit_code, res.output


def _one_error(code: int, output: str, *words: str) -> None:
    assert code == 2, output
    assert "Traceback" not in output, output
    lines = [line for line in output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), output
    for word in words:
        assert word in output, output


@pytest.fixture(scope="module")
def good_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("good") / "run.mcap"
    record_examples(path)
    return path


@pytest.mark.parametrize("command", READERS)
def test_text_file_is_not_an_mcap(command: str, tmp_path: Path) -> None:
    bad = tmp_path / "notes.mcap"
    bad.write_text("not a log\n")
    _one_error(*_invoke(command, str(bad)), "notes.mcap", "not an MCAP file")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.mcap"]  # no empty "recovered" log


@pytest.mark.parametrize("command", READERS)
def test_empty_file(command: str, tmp_path: Path) -> None:
    bad = tmp_path / "empty.mcap"
    bad.touch()
    _one_error(*_invoke(command, str(bad)), "empty.mcap", "the file is empty")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty.mcap"]


@pytest.mark.parametrize("command", READERS)
def test_directory(command: str, tmp_path: Path) -> None:
    _one_error(*_invoke(command, str(tmp_path)), "not a regular file")


@pytest.mark.parametrize("command", [c for c in READERS if c != "recover"])
def test_torn_part_file(command: str, good_log: Path, tmp_path: Path) -> None:
    data = good_log.read_bytes()
    part = tmp_path / "run.mcap.part"
    part.write_bytes(data[: len(data) // 2])
    _one_error(*_invoke(command, str(part)), "run.mcap.part", "torn", "hil recover")


@pytest.mark.parametrize("command", [c for c in READERS if c != "recover"])
def test_foreign_mcap(command: str, tmp_path: Path) -> None:
    foreign = tmp_path / "other.mcap"
    with foreign.open("wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="another tool")
        ch = w.register_channel("/chatter", "json", w.register_schema("s", "jsonschema", b"{}"))
        w.add_message(ch, 1, b"{}", 1)
        w.finish()
    _one_error(*_invoke(command, str(foreign)), "other.mcap", "not a run log of this bench")


@pytest.mark.parametrize("command", [c for c in READERS if c != "recover"])
def test_damaged_index(command: str, good_log: Path, tmp_path: Path) -> None:
    """Both magics in place, the summary in between overwritten."""
    data = bytearray(good_log.read_bytes())
    data[-200:-8] = b"\xff" * 192
    bad = tmp_path / "damaged.mcap"
    bad.write_bytes(bytes(data))
    _one_error(*_invoke(command, str(bad)), "damaged.mcap", "damaged")


def test_recover_refuses_its_input_as_output(good_log: Path, tmp_path: Path) -> None:
    log = tmp_path / "run.mcap"
    log.write_bytes(good_log.read_bytes())
    _one_error(*_invoke("recover", str(log), "--out", str(log)), "the output is the input")
    assert log.read_bytes() == good_log.read_bytes()


@pytest.mark.parametrize("link", ["symlink", "hardlink", "dotted"])
def test_recover_refuses_the_same_file_by_another_name(link: str, good_log: Path, tmp_path: Path) -> None:
    log = tmp_path / "run.mcap"
    log.write_bytes(good_log.read_bytes())
    other = tmp_path / "other.mcap"
    if link == "symlink":
        other.symlink_to(log)
    elif link == "hardlink":
        os.link(log, other)
    else:
        other = tmp_path / "." / "sub" / ".." / "run.mcap"
        (tmp_path / "sub").mkdir()
    _one_error(*_invoke("recover", str(log), "--out", str(other)), "the output is the input")
    assert log.read_bytes() == good_log.read_bytes()


def test_recover_replaces_an_existing_output_only_when_done(good_log: Path, tmp_path: Path) -> None:
    out = tmp_path / "out.mcap"
    out.write_bytes(b"previous")
    code, output = _invoke("recover", str(good_log), "--out", str(out))
    assert code == 0, output
    assert read_metadata(out)["run"]["seed"] == "1"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.mcap"]  # no temporary file left
    assert (out.stat().st_mode & 0o777) & ~0o640 == 0


def test_recover_leaves_no_temporary_file_when_writing_fails(good_log: Path, tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    import importlib

    rec = importlib.import_module("hil.record.recover")  # the package re-exports the function by this name

    def boom(*_: object) -> int:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(rec, "_copy", boom)
    out = tmp_path / "out.mcap"
    out.write_bytes(b"previous")
    code, output = _invoke("recover", str(good_log), "--out", str(out))
    _one_error(code, output, "No space left")
    assert out.read_bytes() == b"previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.mcap"]
