"""The recorder process: same file as the in-thread Recorder, fed one batch per tick."""

from __future__ import annotations

from functools import partial
from pathlib import Path

import pytest

from hil.record import UnknownTopicError, message_counts, read_metadata, read_topic, read_wire
from hil.record.process import ProcessRecorder
from hil.record.validate import validate


def _truth(t_ns: int, h: float) -> dict:
    return {
        "t_ns": t_ns, "p_N_m": [0.0, 0.0, -h], "v_N_mps": [0.0, 0.0, 0.0], "q_NB": [1.0, 0.0, 0.0, 0.0],
        "euler_deg": {"roll": 0.0, "pitch": 0.0, "yaw": 0.0}, "omega_B_radps": [0.0, 0.0, 0.0],
        "rotor_omega_radps": [0.0] * 4, "thrust_N": [0.0] * 4, "h_m": h, "battery_V": 12.0, "battery_A": 1.0,
        "battery_soc": 1.0, "on_ground": False, "wind_N_mps": [0.0, 0.0, 0.0], "mass_kg": 1.1,
    }


def test_batches_deferred_payloads_and_wire(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    rec = ProcessRecorder(path, run_start_unix_ns=1_700_000_000_000_000_000, metadata={"rig": "r", "seed": "3"},
                          attachments=[("rig.toml", "application/toml", b"[rig]\n")])
    rec.start()
    batch = rec.batch()
    for k in range(200):
        t = k * 2_500_000
        batch.log("/sim/truth", t, partial(_truth, t, 0.01 * k), t)  # built in the child
        batch.log_wire("imu", "tx", t, t, bytes([k % 256]) * 3)
        batch.flush()
    rec.log("/hil/events", 0, {"t_ns": 0, "kind": "test", "name": "single", "detail": {}}, 0)
    stats = rec.close({"passed": "true"})
    assert stats.path == path and path.exists() and not Path(str(path) + ".part").exists()
    assert stats.messages_by_topic["/sim/truth"] == 200 and stats.dropped == 0
    counts = message_counts(path)
    # 200 wire chunks over 0.5 s of sim time: 5 messages of 100 ms
    assert counts["/sim/truth"] == 200 and counts["/hil/wire/imu/tx"] == 5 and counts["/hil/events"] == 1
    assert stats.chunks_by_topic == {"/hil/wire/imu/tx": 200}
    assert read_topic(path, "/sim/truth")["h_m"][-1] == pytest.approx(1.99)
    assert read_wire(path, "imu", "tx")[:6] == b"\x00\x00\x00\x01\x01\x01"
    meta = read_metadata(path)
    assert meta["run"]["seed"] == "3" and meta["verdict"]["passed"] == "true"
    assert validate(path).ok
    assert rec.close() is stats  # idempotent


def test_unknown_topic_is_loud_on_the_tick_path(tmp_path: Path) -> None:
    rec = ProcessRecorder(tmp_path / "x.mcap", run_start_unix_ns=0, metadata={})
    rec.start()
    try:
        with pytest.raises(UnknownTopicError):
            rec.batch().log("/no/such/topic", 0, {}, 0)
        with pytest.raises(UnknownTopicError):
            rec.batch().log_wire("gps", "tx", 0, 0, b"")
    finally:
        rec.close()


def test_a_file_that_cannot_be_created_fails_start(tmp_path: Path) -> None:
    existing = tmp_path / "exists.mcap"
    existing.write_bytes(b"")
    rec = ProcessRecorder(existing, run_start_unix_ns=0, metadata={})
    with pytest.raises(OSError, match="could not start"):
        rec.start()
