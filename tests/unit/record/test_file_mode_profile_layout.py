"""Log files are 0640 (narrowed by the umask), carry the project's MCAP profile, and the
shipped Foxglove layout only names topics and fields the logs have."""

from __future__ import annotations

import json
import os
import stat
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from mcap.reader import make_reader

from hil.record import Recorder, recover
from hil.record.topics import TOPICS
from hil.record.writer import PROFILE
from tests.unit.record.support import RUN_START_NS

REPO = Path(__file__).resolve().parents[3]
LAYOUT = REPO / "docs" / "foxglove-layout.json"


@pytest.fixture
def umask() -> Iterator[Callable[[int], int]]:
    old = os.umask(0o022)
    try:
        yield os.umask
    finally:
        os.umask(old)


def _record(path: Path) -> Path:
    rec = Recorder(path, run_start_unix_ns=RUN_START_NS, metadata={"rig": "test"})
    rec.start()
    rec.log("/hil/events", 0, {"t_ns": 0, "kind": "run", "name": "x", "detail": {}}, 0)
    rec.close({"passed": "true"})
    return path


@pytest.mark.parametrize(("mask", "mode"), [(0o022, 0o640), (0o002, 0o640), (0o077, 0o600), (0o027, 0o640)])
def test_log_and_recovered_file_modes(tmp_path: Path, umask, mask: int, mode: int) -> None:
    umask(mask)
    log = _record(tmp_path / "run.mcap")
    assert stat.S_IMODE(log.stat().st_mode) == mode
    out = tmp_path / "run.recovered.mcap"
    recover(log, out)
    assert stat.S_IMODE(out.stat().st_mode) == mode


def test_part_file_is_never_world_readable(tmp_path: Path, umask) -> None:
    umask(0o000)
    rec = Recorder(tmp_path / "r.mcap", run_start_unix_ns=RUN_START_NS, metadata={"rig": "test"})
    rec.start()
    try:
        assert stat.S_IMODE(rec.part_path.stat().st_mode) == 0o640
    finally:
        rec.close({})


def test_header_profile_is_set_and_kept_by_recover(tmp_path: Path) -> None:
    log = _record(tmp_path / "run.mcap")
    out = tmp_path / "rec.mcap"
    recover(log, out)
    for path in (log, out):
        with path.open("rb") as f:
            assert make_reader(f).get_header().profile == PROFILE == "mav-hil"


def _layout_panels(node: object) -> list[str]:
    if isinstance(node, str):
        return [node]
    assert isinstance(node, dict) and node["direction"] in ("row", "column")
    return _layout_panels(node["first"]) + _layout_panels(node["second"])


def _field_known(schema: dict, path: str) -> bool:
    node: dict = schema
    for part in path.split("."):
        name = part.split("[", 1)[0]
        props = node.get("properties", {})
        if name not in props:
            return bool(node.get("additionalProperties"))
        node = props[name]
        if "[" in part:
            node = node.get("items", {})
    return True


def test_foxglove_layout_names_real_topics_and_fields() -> None:
    layout = json.loads(LAYOUT.read_text())
    panels = _layout_panels(layout["layout"])
    assert sorted(panels) == sorted(layout["configById"])
    kinds = {p.split("!", 1)[0] for p in panels}
    assert kinds == {"3D", "Plot", "Log"}
    by_topic = dict(TOPICS)
    seen = 0
    for pid, cfg in layout["configById"].items():
        if pid.startswith("Plot!"):
            for entry in cfg["paths"]:
                topic, field = entry["value"].split(".", 1)
                assert topic in by_topic, entry
                assert _field_known(dict(by_topic[topic].schema), field), entry
                seen += 1
        elif pid.startswith("Log!"):
            assert cfg["topicToRender"] == "/fc/log" and by_topic["/fc/log"].schema_name == "foxglove.Log"
        else:
            assert cfg["followTf"] == "base_link"
            assert all(t in by_topic for t in cfg["topics"])
    assert seen >= 10
    assert any("targets_us[3]" in e["value"] for e in layout["configById"]["Plot!motors"]["paths"])
