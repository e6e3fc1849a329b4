"""The XSENS MTi model's output, the base of :class:`emulators.xsens.device.MtiDevice`: the
output schedule, data messages (streamed on the output grid or polled), overruns per error
mode, and the line (10 bits per byte at ``baud_bps``, the transmit buffer, a host at the
wrong rate). The state machine, the commands and the host's input are the subclass's.
Times are sim ns.
"""

from __future__ import annotations

from emulators.base import ByteDevice
from emulators.xsens import legacy
from emulators.xsens.codec import FrameParser, encode_frame
from emulators.xsens.commands import Settings, legacy_active
from emulators.xsens.defs import MID, ErrorCode, ErrorMode, LegacyMode, LegacyOrientation
from emulators.xsens.errors import ErrorModel
from emulators.xsens.events import CommandHandled, LineOverload, SampleDropped, SampleSent, State
from emulators.xsens.frames import Quat, Vec3, quat_to_euler_deg
from emulators.xsens.output_config import (
    Schedule,
    frame_size,
    legacy_schedule,
    mk4_schedule,
    mtdata2_payload_size,
)
from emulators.xsens.params import Identity, XsensParams
from emulators.xsens.sample import Ctx, Planned, SampleBuilder, plan
from emulators.xsens.uart import receive_at_wrong_baud

_TICK_STF_NS = 100_000  # SampleTimeFine resolution (10 kHz)


class MtiOutput(ByteDevice):
    """What an MTi sends and when; the state below is set up by the subclass."""

    params: XsensParams
    _identity: Identity
    _settings: Settings
    _baud_bps: int
    _parser: FrameParser
    _errors: ErrorModel
    _builder: SampleBuilder
    _motion: tuple[Quat, Vec3, Vec3]
    _state: State
    _stream_after_ns: int
    _plan: tuple[Planned, ...]
    _schedule: Schedule
    _counter: int
    _silenced: bool
    _tx_free_ns: int

    def _set_state(self, new: State, t: int) -> None:
        raise NotImplementedError

    # -- streaming --------------------------------------------------------------------------
    def _make_schedule(self) -> Schedule:
        s = self._settings
        if legacy_active(self._identity, s):
            schedule = legacy_schedule(s.period, s.skip_factor)
        else:
            schedule = mk4_schedule(s.output_configuration, self.params.sample_rate_hz)
        self._plan = plan(schedule.items, schedule.period_ns or 1_000_000_000 // self.params.sample_rate_hz)
        return schedule

    def _stream_until(self, t: int) -> None:
        period = self._schedule.period_ns
        assert period is not None
        k = max(self._stream_after_ns // period + 1, 0)
        while k * period <= t and self._state is State.MEASUREMENT:
            self._sample(k * period, polled=False)
            k += 1
        self._stream_after_ns = max(self._stream_after_ns, t)

    def _polled(self, t: int) -> None:
        self._event(CommandHandled(t, MID.REQ_DATA, MID.MTDATA if self._legacy_active() else MID.MTDATA2))
        self._sample(t, polled=True)

    def _legacy_active(self) -> bool:
        return legacy_active(self._identity, self._settings)

    def _message(self, t: int) -> tuple[bytes, SampleSent]:
        """Build the data frame for instant ``t`` (draws the sample's errors)."""
        measured = self._errors.measure(t, *self._motion)
        m, status = self._builder.saturate(measured)
        s = self._settings
        if self._legacy_active():
            ls = self._builder.legacy_sample(s.output_settings, m, status, self._counter)
            frame = encode_frame(MID.MTDATA, legacy.encode(s.output_mode, s.output_settings, ls))
            euler = acc = rate = None
            if s.output_mode & LegacyMode.ORIENTATION and legacy.orientation_of(s.output_settings) == LegacyOrientation.EULER:
                euler = quat_to_euler_deg(ls.q)  # Euler mode: the angles as sent
            if s.output_mode & LegacyMode.CALIBRATED:
                acc, rate = ls.acc_mps2, ls.rate_radps
            return frame, SampleSent(t, self._counter, None, euler, rate, acc, len(frame))
        stf = ((t + self.params.power_on_offset_ns) // _TICK_STF_NS) & 0xFFFF_FFFF
        due = [it for it in self._plan if it.period_ns is None or t % it.period_ns == 0]
        built = self._builder.mtdata2(due, Ctx(m, status, self._counter, stf, t + self.params.power_on_offset_ns))
        frame = encode_frame(MID.MTDATA2, built.payload)
        return frame, SampleSent(t, self._counter, stf, built.euler_deg, built.rate_radps, built.acc_mps2, len(frame))

    def _sample(self, t: int, polled: bool) -> None:
        frame, sent = self._message(t)
        if self._silenced and not polled:
            self.counters["silenced_samples"] += 1
            self._counter = (self._counter + 1) & 0xFFFF
            return
        if not polled and not self._fits(t, len(frame)):
            self._overrun(t)
            return
        self._transmit(t, frame)
        self._counter = (self._counter + 1) & 0xFFFF
        self.counters["samples_sent"] += 1
        self._event(sent)

    def _overrun(self, t: int) -> None:
        mode = ErrorMode(self._settings.error_mode)
        self.counters["overruns"] += 1
        self._event(SampleDropped(t, "overrun", int(mode)))
        if mode is not ErrorMode.IGNORE:
            self._counter = (self._counter + 1) & 0xFFFF
        if mode in (ErrorMode.INCREASE_COUNTER_SEND_ERROR, ErrorMode.SEND_ERROR_GO_CONFIG):
            self.counters["errors_sent"] += 1
            self._transmit(t, encode_frame(MID.ERROR, bytes((ErrorCode.DATA_OVERFLOW,))))
        if mode is ErrorMode.SEND_ERROR_GO_CONFIG:
            self._set_state(State.CONFIG, t)

    def _check_line_capacity(self, t: int) -> None:
        if self._schedule.period_ns is None:
            return
        probe = self._message_size
        need = self._schedule.bytes_per_second(probe)
        capacity = self._baud_bps // 10
        if need > capacity:
            self.counters["line_overload"] += 1
            self._event(LineOverload(t, need, capacity, self._baud_bps))

    def _message_size(self, t: int) -> int:
        s = self._settings
        if self._legacy_active():
            return frame_size(legacy.mtdata_length(s.output_mode, s.output_settings))
        return frame_size(mtdata2_payload_size(self._schedule.due(t)))

    # -- the line ---------------------------------------------------------------------------
    def _line_ns(self, nbytes: int) -> int:
        return -(-nbytes * 10 * 1_000_000_000 // self._baud_bps)

    def _fits(self, t: int, nbytes: int) -> bool:
        backlog_ns = self._tx_free_ns - t
        backlog = 0 if backlog_ns <= 0 else -(-backlog_ns * self._baud_bps // 10_000_000_000)
        return backlog + nbytes <= self.params.tx_buffer_bytes

    def _transmit(self, t: int, frame: bytes) -> None:
        self._tx_free_ns = max(self._tx_free_ns, t) + self._line_ns(len(frame))
        self.counters["tx_bytes"] += len(frame)
        if not self._line_matches():
            assert self.host_baud is not None
            self.counters["tx_garbled_bytes"] += len(frame)
            frame = receive_at_wrong_baud(frame, self._baud_bps, self.host_baud)
        self._send(frame)

    def _line_matches(self) -> bool:
        return self.host_baud is None or self.host_baud == self._baud_bps
