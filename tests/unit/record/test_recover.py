"""A killed writer's ``.part`` file is salvaged by recover() into a valid, indexed MCAP."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from collections import Counter
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.records import Attachment, Header, Message, Metadata
from mcap.stream_reader import StreamReader

from hil.record import (
    TornRecordingError,
    iter_messages,
    message_counts,
    read_attachments,
    read_metadata,
    recover,
    recovered_path,
)
from hil.record.log_check import LogError
from tests.unit.record.support import RUN_START_NS, record_examples
from tests.unit.record.test_independent_read import validate_file

ROOT = Path(__file__).resolve().parents[3]

CHILD = textwrap.dedent("""
    import os, sys
    from pathlib import Path
    from hil.record import Recorder
    from hil.record.topics import TOPICS

    path = Path(sys.argv[1])
    rec = Recorder(path, run_start_unix_ns={start}, metadata={{"seed": "7", "scenario": "kill"}},
                   attachments=[("rig.toml", "application/toml", b"[vehicle]\\nmass_kg = 1.0\\n")],
                   chunk_size=8192, queue_max=5000)
    rec.start()
    truth = TOPICS["/sim/truth"].example
    k = 0
    while True:
        t_ns = k * 2_500_000
        rec.log_truth(t_ns, truth, k)
        rec.log_wire("imu", "tx", t_ns, k, bytes([k % 256]) * 40)
        rec.log("/hil/events", t_ns, {{"kind": "bench", "name": "tick", "detail": {{"k": k}}}}, k)
        k += 1
        if k % 200 == 0:
            # progress: bytes the writer thread has put into the .part file so far
            print(k, os.path.getsize(rec.part_path), flush=True)
""").format(start=RUN_START_NS)


@pytest.fixture
def killed_part(tmp_path: Path) -> Path:
    """A recording whose process was SIGKILLed mid-run; returns its ``.part`` path."""
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    final = tmp_path / "run.mcap"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, str(script), str(final)], stdout=subprocess.PIPE, text=True,
                            cwd=ROOT, env=env)
    try:
        assert proc.stdout is not None
        for line in proc.stdout:  # wait for progress, not for time
            _, size = line.split()
            if int(size) > 60_000:  # dozens of complete chunks on disk
                break
        else:
            pytest.fail(f"child ended early with {proc.wait()}")
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    part = final.with_name("run.mcap.part")
    assert part.exists() and not final.exists()
    return part


def test_killed_run_is_recovered(killed_part: Path, tmp_path: Path) -> None:
    # before recovery: header, run metadata and attachment are there, but readers refuse the file
    with killed_part.open("rb") as f:
        records = StreamReader(f).records
        head = [next(records) for _ in range(3)]
    assert [type(r) for r in head] == [Header, Metadata, Attachment]
    assert head[1].metadata["seed"] == "7"
    with pytest.raises(TornRecordingError):
        read_metadata(killed_part)

    dst = recovered_path(killed_part)
    assert dst == tmp_path / "run.mcap"
    n = recover(killed_part, dst)
    assert n > 1000

    with dst.open("rb") as f:
        summary = make_reader(f, validate_crcs=True).get_summary()
    assert summary is not None and summary.statistics is not None
    assert summary.statistics.message_count == n
    counts = message_counts(dst)
    assert sum(counts.values()) == n
    assert Counter(validate_file(dst)) == Counter({t: c for t, c in counts.items() if c})

    meta = read_metadata(dst)
    assert meta["run"]["seed"] == "7" and meta["run"]["scenario"] == "kill"
    assert meta["recovery"]["messages"] == str(n) and meta["recovery"]["source"] == "run.mcap.part"
    assert "summary" not in meta  # the killed run never wrote it
    assert read_attachments(dst) == {"rig.toml": ("application/toml", b"[vehicle]\nmass_kg = 1.0\n")}

    # every complete chunk kept, in order: per-channel sequence numbers have no gaps
    with dst.open("rb") as f:
        seqs: dict[int, list[int]] = {}
        for rec in StreamReader(f).records:
            if isinstance(rec, Message):
                seqs.setdefault(rec.channel_id, []).append(rec.sequence)
    assert all(s == list(range(len(s))) for s in seqs.values())
    details = [m["detail"]["k"] for _, _, m in iter_messages(dst, ["/hil/events"])]
    assert details == sorted(details) and len(details) == counts["/hil/events"]
    # /tf and /sim/pose are derived in the same writer step as /sim/truth: a tear splits them by <= 1
    assert 0 <= counts["/sim/truth"] - counts["/sim/pose"] <= 1
    assert 0 <= counts["/sim/truth"] - counts["/tf"] <= 1


@pytest.mark.parametrize("fraction", [0.05, 0.3, 0.5, 0.77, 0.999])
def test_truncated_copies_recover_to_a_prefix(tmp_path: Path, fraction: float) -> None:
    rec = record_examples(tmp_path / "full.mcap", n_rounds=150, chunk_size=4096)
    full = list(iter_messages(rec.path))
    data = rec.path.read_bytes()
    cut = tmp_path / "cut.mcap.part"
    cut.write_bytes(data[: int(len(data) * fraction)])
    dst = tmp_path / "cut.mcap"
    n = recover(cut, dst)
    validate_file(dst)
    got = list(iter_messages(dst))
    assert len(list(iter_messages(dst, expand=False))) == n  # MCAP messages (a wire message holds many chunks)
    # what survived is exactly what was in the complete chunks: a per-topic prefix of the original
    for topic in {t for t, _, _ in full}:
        orig = [m for t, _, m in full if t == topic]
        kept = [m for t, _, m in got if t == topic]
        assert kept == orig[: len(kept)]
    assert "run" in read_metadata(dst)


def test_recovering_a_complete_file_keeps_everything(tmp_path: Path) -> None:
    rec = record_examples(tmp_path / "run.mcap", n_rounds=20)
    dst = recovered_path(rec.path)
    assert dst.name == "run.recovered.mcap"
    n = recover(rec.path, dst)
    assert n == sum(message_counts(rec.path).values())
    assert message_counts(dst) == message_counts(rec.path)
    meta = read_metadata(dst)
    assert meta["recovery"]["stopped_at"] == "footer"
    assert meta["summary"] == read_metadata(rec.path)["summary"]


def test_a_torn_header_recovers_to_an_empty_valid_log(tmp_path: Path) -> None:
    """Killed right after the magic: nothing to keep, but the result is still a valid MCAP."""
    src = tmp_path / "magic-only.mcap.part"
    src.write_bytes(b"\x89MCAP0\r\n")
    dst = tmp_path / "out.mcap"
    assert recover(src, dst) == 0
    validate_file(dst)
    assert "recovery" in read_metadata(dst)


@pytest.mark.parametrize(("name", "content"), [("empty.mcap.part", b""), ("junk.mcap.part", os.urandom(5000))])
def test_a_file_that_is_not_an_mcap_is_refused_and_nothing_written(tmp_path: Path, name: str, content: bytes) -> None:
    src = tmp_path / name
    src.write_bytes(content)
    with pytest.raises(LogError, match=name):
        recover(src, tmp_path / "out.mcap")
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


@pytest.mark.parametrize(("name", "default"), [("run.mcap.part", "run.mcap"), ("run.mcap", "run.recovered.mcap"),
                                               ("run.bin", "run.recovered.mcap"), ("run", "run.recovered.mcap")])
def test_the_default_output_is_an_mcap_beside_the_input(tmp_path: Path, name: str, default: str) -> None:
    """``hil recover LOG`` and ``recovered_path`` agree: the copy is an MCAP file, named for one."""
    assert recovered_path(tmp_path / name) == tmp_path / default
