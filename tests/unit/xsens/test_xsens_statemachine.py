"""Hypothesis RuleBasedStateMachine over the device: any sequence of host input and time.

Invariants after every step:
* everything the device sent parses as valid Xbus frames (no garbage, nothing partial);
* no data message leaves the device unless it was measuring during that step;
* MEASUREMENT is entered only by an acknowledged GoToMeasurement or when the WakeUpAck
  window of the last WakeUp runs out;
* counters agree with what the host saw: frames = commands + ignored, one Error frame per
  ``errors_sent``, one data frame per ``samples_sent``, every byte in ``tx_bytes``.
"""

from __future__ import annotations

import struct

import numpy as np
from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, rule

from emulators.base import DeviceEvent
from emulators.xsens.codec import FrameParser, encode_frame
from emulators.xsens.defs import MID
from emulators.xsens.device import MtiDevice
from emulators.xsens.events import CommandHandled, State, StateChanged
from emulators.xsens.params import Identity, XsensParams

_CFG = b"".join(struct.pack(">HH", x, f) for x, f in ((0x1020, 0xFFFF), (0x2034, 400), (0x4020, 100)))
COMMANDS: list[tuple[int, bytes]] = [
    (MID.GOTO_CONFIG, b""), (MID.GOTO_CONFIG, b""), (MID.GOTO_MEASUREMENT, b""), (MID.GOTO_MEASUREMENT, b""),
    (MID.RESET, b""), (MID.WAKEUP_ACK, b""), (MID.REQ_DID, b""), (MID.REQ_CONFIGURATION, b""),
    (MID.SET_OUTPUT_CONFIGURATION, _CFG), (MID.SET_OUTPUT_CONFIGURATION, b""), (MID.REQ_DATA, b""),
    (MID.SET_PERIOD, struct.pack(">H", 288)), (MID.SET_OUTPUT_MODE, b"\x00\x06"), (MID.SET_OUTPUT_MODE, b"\x00\x00"),
    (MID.SET_OUTPUT_SKIP_FACTOR, b"\xff\xff"), (MID.SET_OUTPUT_SKIP_FACTOR, b"\x00\x00"),
    (MID.SET_ERROR_MODE, b"\x00\x03"), (MID.SET_BAUDRATE, b"\x80"), (MID.REQ_EMTS, b"\x00\xff"),
    (0x06, b""), (0x77, b"\x01\x02"),
]
DATA = (MID.MTDATA, MID.MTDATA2)
MS = 1_000_000


class XsensMachine(RuleBasedStateMachine):
    dev: MtiDevice

    @initialize(identity=st.sampled_from(list(Identity)), seed=st.integers(0, 2**16),
                baud=st.sampled_from([115_200, 921_600]))
    def start(self, identity: Identity, seed: int, baud: int) -> None:
        self.params = XsensParams(identity=identity, baud_bps=baud)
        self.dev = MtiDevice(self.params, np.random.default_rng(seed))
        self.host = FrameParser(max_payload=8192)
        self.t = -2_000 * MS
        self.frames_seen: dict[int, int] = {}
        self.bytes_seen = 0
        self.last_wakeup: int | None = None
        self.step_ok = True
        self.step_msg = ""

    # -- steps ------------------------------------------------------------------------------
    def _collect(self, measuring_before: bool) -> None:
        out = self.dev.take_output()
        events = self.dev.take_events()
        self.bytes_seen += len(out)
        frames = self.host.feed(out)
        wakeups = [self.last_wakeup] if self.last_wakeup is not None else []
        for f in frames:
            self.frames_seen[f.mid] = self.frames_seen.get(f.mid, 0) + 1
            if f.mid == MID.WAKEUP:  # sent at the restart itself (wakeup_delay_ns = 0)
                wakeups.append(self.t)
        # A step's state changes are judged against every WakeUp that may have led to them:
        # the window of the previous one can run out at the very instant a Reset of this
        # step restarts the device (time first, then the bytes received at that time).
        self._check_step(measuring_before, frames, events, wakeups)
        if wakeups:
            self.last_wakeup = wakeups[-1]

    def _check_step(self, measuring_before: bool, frames: list, events: list[DeviceEvent],
                    wakeups: list[int]) -> None:
        changes = [e for e in events if isinstance(e, StateChanged)]
        measured = measuring_before or any(e.new is State.MEASUREMENT for e in changes)
        if any(f.mid in DATA for f in frames) and not measured:
            self.step_ok, self.step_msg = False, "data sent while not measuring"
        for e in changes:
            if e.new is not State.MEASUREMENT:
                continue
            by_command = CommandHandled(e.t_ns, MID.GOTO_MEASUREMENT, MID.GOTO_MEASUREMENT_ACK) in events
            by_timeout = e.old is State.WAKEUP and any(e.t_ns == w + self.params.wakeup_window_ns for w in wakeups)
            if not (by_command or by_timeout):
                self.step_ok, self.step_msg = False, f"entered MEASUREMENT without cause: {e}"

    def _dt(self, dt_ms: int) -> int:
        self.t += dt_ms * MS
        return self.t

    @rule(cmd=st.sampled_from(COMMANDS), dt_ms=st.integers(0, 30))
    def command(self, cmd: tuple[int, bytes], dt_ms: int) -> None:
        before = self.dev.measuring
        self.dev.receive(encode_frame(cmd[0], cmd[1]), self._dt(dt_ms))
        self._collect(before)

    @rule(junk=st.binary(min_size=1, max_size=40), dt_ms=st.integers(0, 30))
    def garbage(self, junk: bytes, dt_ms: int) -> None:
        before = self.dev.measuring
        self.dev.receive(junk, self._dt(dt_ms))
        self._collect(before)

    @rule(dt_ms=st.integers(0, 30))
    def bad_checksum(self, dt_ms: int) -> None:
        before = self.dev.measuring
        frame = bytearray(encode_frame(MID.GOTO_CONFIG))
        frame[-1] ^= 0x5A
        self.dev.receive(bytes(frame), self._dt(dt_ms))
        self._collect(before)

    @rule(dt_ms=st.integers(0, 700))
    def advance(self, dt_ms: int) -> None:
        before = self.dev.measuring
        self.dev.advance(self._dt(dt_ms))
        self._collect(before)

    @rule(dt_ms=st.integers(0, 30))
    def power_cycle(self, dt_ms: int) -> None:
        before = self.dev.measuring
        self.dev.power_cycle(self._dt(dt_ms))
        self._collect(before)

    @rule(on=st.booleans())
    def silence(self, on: bool) -> None:
        self.dev.set_silenced(on)

    # -- invariants -------------------------------------------------------------------------
    @invariant()
    def step_was_lawful(self) -> None:
        assert self.step_ok, self.step_msg

    @invariant()
    def replies_are_valid_frames(self) -> None:
        s = self.host.stats
        assert s.resync_bytes == 0 and s.checksum_errors == 0 and self.host.pending == 0

    @invariant()
    def counters_are_consistent(self) -> None:
        c = self.dev.counters
        assert c["frames_ok"] == c["commands"] + c["ignored_frames"]
        assert c["errors_sent"] == self.frames_seen.get(MID.ERROR, 0)
        assert c["samples_sent"] == sum(self.frames_seen.get(m, 0) for m in DATA)
        assert c["tx_bytes"] == self.bytes_seen

    @invariant()
    def no_data_in_config(self) -> None:
        if self.dev.state is not State.MEASUREMENT:
            assert self.dev.output_period_ns is None


XsensMachine.TestCase.settings = settings(max_examples=60, stateful_step_count=40, deadline=None)
TestXsensMachine = XsensMachine.TestCase


def test_a_wakeup_window_running_out_as_a_reset_arrives_is_lawful() -> None:
    """Found by the machine above on CI: the WakeUpAck window of a power cycle runs out at the
    instant a Reset arrives. The device enters MEASUREMENT (time first), then restarts on the
    Reset and sends a new WakeUp; the harness had judged the change against that new one."""
    m = XsensMachine()
    m.start(identity=Identity.MK4, seed=0, baud=115_200)
    m.power_cycle(dt_ms=0)
    m.advance(dt_ms=480)
    m.command(cmd=(MID.RESET, b""), dt_ms=20)
    assert m.step_ok, m.step_msg
    assert m.last_wakeup == m.t  # the Reset's WakeUp is the one a later timeout refers to
