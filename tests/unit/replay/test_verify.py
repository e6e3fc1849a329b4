"""hil.fleet.verify.verify: a real short lockstep run re-run from its own attachments is identical;
a copy with one IMU byte changed is caught at that byte and sim time."""

from __future__ import annotations

import base64
from pathlib import Path
from typing import Any

import pytest

from hil.flight.tickloop import Mode
from hil.record import iter_messages, read_attachments, read_metadata
from hil.fleet.replay_error import ReplayError
from hil.fleet.verify import verify
from hil.flight.run import run_flight
from hil.flight.run_result import RunResult
from tests.unit.replay.support import copy_log, synthetic_chunks, write_synthetic

pytestmark = [pytest.mark.system, pytest.mark.pty]
SCENARIO = Path(__file__).with_name("data") / "hover-3s.toml"
TAMPER_T_NS = 1_000_000_000  # the IMU chunk sent at sim time 1 s
TAMPER_INDEX = 7  # byte within that chunk


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> RunResult:
    result = run_flight(None, SCENARIO, mode=Mode.LOCKSTEP, out_dir=tmp_path_factory.mktemp("rec"))
    assert result.end_reason.value == "completed", (result.message, result.flight_stderr_tail)
    assert result.log_path is not None
    return result


def test_the_log_carries_what_a_rerun_needs(recorded: RunResult) -> None:
    assert recorded.log_path is not None
    run = read_metadata(recorded.log_path)["run"]
    assert (run["scenario"], run["seed"], run["mode"], run["duration_s"]) == ("hover-3s", "1", "lockstep", "3")
    assert set(read_attachments(recorded.log_path)) == {"paper-quad.toml", "flightcode-paper-quad.toml", "hover-3s.toml"}


def test_a_rerun_of_a_lockstep_run_is_identical(recorded: RunResult, tmp_path: Path) -> None:
    assert recorded.log_path is not None
    result = verify(recorded.log_path, tmp_path)
    assert result.ok, result.report()
    assert result.first is None
    assert result.rerun_log is not None and result.rerun_log.parent == tmp_path
    assert set(result.compared) == {"imu/tx", "adc/tx", "adc/rx", "rc/tx", "esc/rx", "truth"}
    assert all(n > 0 for n in result.compared.values()), result.compared
    assert result.compared["truth"] == 301  # 100 Hz (the rig's truth_divider 4) over [0, 3] s
    assert result.report().startswith("IDENTICAL")


def test_a_tampered_imu_byte_is_the_first_divergence(recorded: RunResult, tmp_path: Path) -> None:
    assert recorded.log_path is not None
    where: dict[str, int] = {}
    offset = [0]

    def flip(topic: str, t_ns: int, msg: dict[str, Any]) -> dict[str, Any]:
        if topic == "/hil/wire/imu/tx":
            data = msg["data"]
            if t_ns >= TAMPER_T_NS and not where:
                where.update(t_ns=t_ns, offset=offset[0] + TAMPER_INDEX, was=data[TAMPER_INDEX])
                data = data[:TAMPER_INDEX] + bytes([data[TAMPER_INDEX] ^ 0x10]) + data[TAMPER_INDEX + 1:]
                msg = {**msg, "data": data}
            offset[0] += len(msg["data"])
        return msg

    tampered = copy_log(recorded.log_path, tmp_path / "tampered.mcap", flip)
    assert where["t_ns"] == TAMPER_T_NS
    # the copy differs from the original in that one byte only
    orig = b"".join(m["data"] for _, _, m in iter_messages(recorded.log_path, ["/hil/wire/imu/tx"]))
    copy = b"".join(m["data"] for _, _, m in iter_messages(tampered, ["/hil/wire/imu/tx"]))
    assert [i for i in range(len(orig)) if orig[i] != copy[i]] == [where["offset"]]

    result = verify(tampered, tmp_path / "rerun")
    assert not result.ok
    first = result.first
    assert first is not None, result.report()
    assert (first.stream, first.offset, first.t_ns) == ("imu/tx", where["offset"], TAMPER_T_NS), result.report()
    assert first.detail == f"recorded 0x{where['was'] ^ 0x10:02x}, re-run 0x{where['was']:02x}"
    assert [d.stream for d in result.divergences] == ["imu/tx"], result.report()
    report = result.report()
    assert report.startswith("DIVERGED")
    assert f"imu/tx: first divergence at byte {where['offset']} at t = 1.000000 s" in report


def test_a_log_that_is_not_a_bench_run_is_refused(tmp_path: Path) -> None:
    log = write_synthetic(tmp_path / "s.mcap", synthetic_chunks(span_s=0.01))
    with pytest.raises(ReplayError, match="run metadata lacks"):
        verify(log, tmp_path)


def test_base64_is_what_the_copier_writes(tmp_path: Path) -> None:
    # the tamper helper must round-trip the bytes exactly, or the test above proves nothing
    chunks = synthetic_chunks(span_s=0.02)
    src = write_synthetic(tmp_path / "a.mcap", chunks)
    dst = copy_log(src, tmp_path / "b.mcap")
    a = [m["data"] for _, _, m in iter_messages(src, ["/hil/wire/imu/tx"])]
    b = [m["data"] for _, _, m in iter_messages(dst, ["/hil/wire/imu/tx"])]
    assert a == b and base64.b64encode(b"".join(a))
