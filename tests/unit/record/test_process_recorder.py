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


def test_a_stalled_child_backs_up_locally_then_everything_arrives(tmp_path: Path) -> None:
    """The tick path never waits on a busy child: what the full pipe cannot take waits in the
    backlog (sent first by the next write), and at close every batch reaches the file."""
    import os
    import signal

    path = tmp_path / "stall.mcap"
    rec = ProcessRecorder(path, run_start_unix_ns=0, metadata={})
    rec.start()
    assert rec._pid is not None
    os.kill(rec._pid, signal.SIGSTOP)  # the child reads nothing until SIGCONT
    try:
        batch = rec.batch()
        blob = bytes(range(256)) * 16  # 4 KiB a batch: 2 MiB is beyond any pipe's capacity
        for k in range(512):
            batch.log_wire("imu", "tx", k * 2_500_000, 0, blob)
            batch.flush()
        assert rec.backlog_peak > 0
    finally:
        os.kill(rec._pid, signal.SIGCONT)
    stats = rec.close()
    assert stats.dropped == 0 and rec.dropped == 0
    assert read_wire(path, "imu", "tx") == blob * 512


def test_a_backlog_past_its_bound_blocks_instead_of_growing(tmp_path: Path) -> None:
    path = tmp_path / "bound.mcap"
    rec = ProcessRecorder(path, run_start_unix_ns=0, metadata={}, backlog_max=256 << 10)
    rec.start()
    batch = rec.batch()
    blob = b"\xa5" * 8192
    for k in range(400):  # 3.2 MB through a 256 KiB bound
        batch.log_wire("esc", "rx", k * 2_500_000, 0, blob)
        batch.flush()
        assert len(rec._backlog) <= rec.backlog_max
    stats = rec.close()
    assert stats.dropped == 0
    assert read_wire(path, "esc", "rx") == blob * 400


def test_a_dead_child_counts_what_it_lost(tmp_path: Path) -> None:
    import os
    import signal

    rec = ProcessRecorder(tmp_path / "dead.mcap", run_start_unix_ns=0, metadata={})
    rec.start()
    assert rec._pid is not None
    os.kill(rec._pid, signal.SIGKILL)
    os.waitpid(rec._pid, 0)
    rec._pid = None  # reaped here
    batch = rec.batch()
    for k in range(3):
        batch.log("/hil/events", k, {"t_ns": k, "kind": "test", "name": "x", "detail": {}}, 0)
        batch.flush()
    assert rec.dropped == 3
    os.close(rec._cmd_fd)
    os.close(rec._result_fd)


def _items() -> list[tuple[str | None, int, int, object]]:
    out: list[tuple[str | None, int, int, object]] = []
    for k in range(300):
        t = k * 2_500_000
        out.append((None, t, t + 7, ("imu", "tx", bytes([k % 256]) * 5)))
        out.append(("/hil/esc/command", t, t + 9, {"t_ns": t, "targets_us": [1100.0 + k, 1100.0, 1100.0, 1100.0]}))
        if k % 4 == 0:
            out.append(("/sim/truth", t, t, partial(_truth, t, 0.01 * k)))
        out.append((None, t, t + 11, ("adc", "rx", b"\x10\x20")))
    return out


def test_write_now_writes_what_log_and_log_wire_write(tmp_path: Path) -> None:
    """The recorder child's batch path (``Recorder.write_now``) gives the same file, byte for
    byte, as the same items through ``log``/``log_wire``; an unknown topic raises as there."""
    from hil.record.writer import Recorder

    files = []
    for way in ("items", "calls"):
        rec = Recorder(tmp_path / f"{way}.mcap", run_start_unix_ns=5, metadata={"m": "1"}, writer_thread=False)
        rec.start()
        if way == "items":
            rec.write_now(_items())
        else:
            for topic, t, h, p in _items():
                if topic is None:
                    rec.log_wire(p[0], p[1], t, h, p[2])  # type: ignore[index]
                else:
                    rec.log(topic, t, p, h)  # type: ignore[arg-type]
        rec.close({})
        files.append((tmp_path / f"{way}.mcap").read_bytes())
    assert files[0] == files[1]
    rec = Recorder(tmp_path / "bad.mcap", run_start_unix_ns=5, metadata={}, writer_thread=False)
    rec.start()
    with pytest.raises(UnknownTopicError):
        rec.write_now([("/no/such", 0, 0, {})])
    with pytest.raises(UnknownTopicError):
        rec.write_now([(None, 0, 0, ("nope", "tx", b"x"))])
    rec.close({})
