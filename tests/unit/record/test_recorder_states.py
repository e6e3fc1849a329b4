"""The Recorder's life cycle (new -> running -> closed) against a model, with hypothesis."""

from __future__ import annotations

import shutil
import tempfile
import warnings
from pathlib import Path

import pytest
from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, precondition, rule

from hil.record import Recorder, RecordStats, iter_messages, message_counts, read_metadata
from tests.unit.record.support import RUN_START_NS

TOPICS_USED = ["/hil/events", "/hil/adc/conversion"]
PAYLOADS = {"/hil/events": {"kind": "fault", "name": "f", "detail": {"d": 1}},
            "/hil/adc/conversion": {"channel": 2, "code": 100, "volts": 0.12}}


class RecorderMachine(RuleBasedStateMachine):
    def __init__(self) -> None:
        super().__init__()
        self.dir = Path(tempfile.mkdtemp())
        self.rec = Recorder(self.dir / "m.mcap", run_start_unix_ns=RUN_START_NS, metadata={"m": "1"},
                            chunk_size=512)
        self.state = "new"
        self.logged: dict[str, list[int]] = {t: [] for t in TOPICS_USED + ["/hil/wire/adc/tx"]}
        self.late = 0
        self.stats: RecordStats | None = None

    @precondition(lambda self: self.state == "new")
    @rule()
    def start(self) -> None:
        self.rec.start()
        self.state = "running"

    @rule(topic=st.sampled_from(TOPICS_USED), t_ns=st.integers(-5, 20).map(lambda k: k * 1_000_000))
    def log(self, topic: str, t_ns: int) -> None:
        if self.state == "new":
            with pytest.raises(RuntimeError):
                self.rec.log(topic, t_ns, PAYLOADS[topic], 0)
            return
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            self.rec.log(topic, t_ns, PAYLOADS[topic], 0)
        if self.state == "running":
            self.logged[topic].append(t_ns)
        else:
            self.late += 1

    @precondition(lambda self: self.state == "running")
    @rule(data=st.binary(max_size=64), t_ns=st.integers(0, 10**10))
    def log_wire(self, data: bytes, t_ns: int) -> None:
        self.rec.log_wire("adc", "tx", t_ns, 5, data)
        self.logged["/hil/wire/adc/tx"].append(t_ns)

    @rule(verdict=st.sampled_from(["pass", "fail"]))
    def close(self, verdict: str) -> None:
        stats = self.rec.close({"verdict": verdict})
        if self.stats is not None:  # idempotent: the first result, whatever was passed later
            assert stats == self.stats
            return
        self.stats = stats
        if self.state == "new":
            assert stats.messages_by_topic == {} and not self.rec.path.exists()
            self.state = "closed"
            return
        self.state = "closed"
        assert stats.dropped == 0
        counts = message_counts(self.rec.path)
        for topic, times in self.logged.items():
            got = [m["t_ns"] for _, _, m in iter_messages(self.rec.path, [topic])]
            assert got == times  # per channel order kept (log times clamped, payload t_ns exact)
            assert counts[topic] == stats.messages_by_topic[topic]
            if topic.startswith("/hil/wire/"):  # several chunks per message; clamps are per message
                assert stats.chunks_by_topic.get(topic, 0) == len(times)
                continue
            assert counts[topic] == len(times)
            expected_clamped = 0
            running_max = None
            for t in times:
                if running_max is not None and t < running_max:
                    expected_clamped += 1
                running_max = t if running_max is None else max(running_max, t)
            assert stats.clamped_by_topic.get(topic, 0) == expected_clamped
        meta = read_metadata(self.rec.path)
        assert meta["verdict"] == {"verdict": verdict} and meta["run"]["m"] == "1"

    @invariant()
    def late_messages_are_counted(self) -> None:
        assert self.rec.dropped_after_close == self.late

    def teardown(self) -> None:
        try:
            if self.stats is None:  # every run ends with a checked close
                self.close("pass")
        finally:
            self.rec.close()
            shutil.rmtree(self.dir, ignore_errors=True)


TestRecorderStates = RecorderMachine.TestCase
TestRecorderStates.settings = settings(deadline=None, max_examples=40, stateful_step_count=25)
