"""XSENS MTi device model (sans-I/O): Xbus in, Xbus out, on sim time.

State machine (mtidocs "States", MT0100P §5.3), as the tables below:

* WAKEUP: after power-up or Reset the device sends WakeUp (0x3E) ``wakeup_delay_ns``
  after the event. WakeUpAck (0x3F) within ``wakeup_window_ns`` (500 ms) -> CONFIG.
  Otherwise -> MEASUREMENT with the stored configuration; an mk4 first sends its
  Configuration (0x0D) and eMTS (0x91) messages, a legacy MTi does not. Other messages
  are ignored (counted) while waking up.
* CONFIG: requests are answered (commands.py); GoToMeasurement starts streaming.
* MEASUREMENT: data messages on the output grid; only GoToConfig, Reset and ReqData are
  valid; every other known message gets Error 0x04 (docs/protocols.md §1.6).

Every state: unknown/unsupported MIDs -> Error 0x04; bad checksums are dropped silently;
frames for another bus id are ignored. Nothing but data goes out unsolicited while
measuring, except Error 0x29 on an overrun in error modes 2 and 3.

Time: ``advance(t_ns)`` emits a data message for every instant in (last t, t_ns] with
``t % output_period_ns == 0`` and ``t >= 0`` (negative sim time is boot). ``receive``
first advances to its ``t_ns``. SampleTimeFine = ((t + power_on_offset_ns) // 100 us) mod
2^32; the packet counter (legacy: sample counter) is u16 and wraps.

Line model: the device's rate is ``baud_bps`` (SetBaudrate takes effect at the next Reset
or power cycle). When the host's rate differs, output reaches the host as a UART at the
wrong rate receives it (uart.py) and input is lost (counted). Each message occupies the
line for 10 bits per byte; a data message that does not fit in ``tx_buffer_bytes`` behind
the bytes still queued is an overrun, handled per error mode (defs.ErrorMode). A
configuration that needs more than ``baud_bps / 10`` bytes per second is reported when
measurement starts (LineOverload event, counter ``line_overload``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import fields

import numpy as np

from emulators import vibration
from emulators.xsens.codec import Frame, FrameParser, encode_frame
from emulators.xsens.commands import Commands, Settings, factory_settings
from emulators.xsens.defs import (
    BAUD_BPS_BY_CODE,
    BID_FIRST,
    BID_MASTER,
    MID,
    BaudCode,
    ErrorCode,
    baud_code_for,
)
from emulators.xsens.errors import ErrorModel
from emulators.xsens.events import (
    BaudChanged,
    CommandHandled,
    ProtocolError,
    State,
    StateChanged,
)
from emulators.xsens.frames import Quat, Vec3, quat_normalize
from emulators.xsens.params import Identity, PowerUp, XsensParams
from emulators.xsens.sample import Planned, SampleBuilder
from emulators.xsens.streaming import MtiOutput

#: Message-driven transitions: state -> {MID: next state}. Each is acknowledged with MID + 1
#: except WakeUpAck. Timed transition: WAKEUP -> MEASUREMENT when the window elapses.
TRANSITIONS: dict[State, dict[MID, State]] = {
    State.WAKEUP: {MID.WAKEUP_ACK: State.CONFIG},
    State.CONFIG: {MID.GOTO_CONFIG: State.CONFIG, MID.GOTO_MEASUREMENT: State.MEASUREMENT, MID.RESET: State.WAKEUP},
    State.MEASUREMENT: {MID.GOTO_CONFIG: State.CONFIG, MID.RESET: State.WAKEUP},
}
#: Requests answered in MEASUREMENT besides the transitions (polled data).
MEASUREMENT_REQUESTS = frozenset({MID.REQ_DATA})
_PARSER_COUNTERS = tuple(f.name for f in fields(FrameParser().stats))


class MtiDevice(MtiOutput):
    """An XSENS MTi on the ``imu`` port. See the module docstring for the behaviour."""

    name = "imu"

    def __init__(self, params: XsensParams, rng: np.random.Generator) -> None:
        super().__init__()
        self.params = params
        self._identity = Identity(params.identity)
        self._ident = params.resolved()
        self._commands = Commands(params, self._ident)
        self._settings: Settings = factory_settings(params, self._ident, baud_code_for(params.baud_bps))
        self._baud_bps = params.baud_bps
        self._parser = FrameParser(max_payload=params.rx_max_payload_bytes, timeout_ns=params.rx_timeout_ns)
        self._errors = ErrorModel(params, rng)
        self._response = params.sensor_response()
        self._builder = SampleBuilder(params)
        self._builder.alignment = self._settings.alignment
        g = params.gravity_mps2
        self._motion: tuple[Quat, Vec3, Vec3] = ((1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, -g))
        self._state = State.MEASUREMENT
        self._t_ns: int | None = None  # last time seen; None before the first call
        self._stream_after_ns = -1  # data instants must be later than this
        self._plan: tuple[Planned, ...] = ()
        self._schedule = self._make_schedule()
        self._counter = 0  # packet counter (mk4) / sample counter (legacy), u16
        self._silenced = False
        self._tx_free_ns = -(1 << 62)  # when the line has sent everything queued
        self._wakeup_at_ns: int | None = None  # WakeUp pending at this time
        self._wakeup_deadline_ns: int | None = None  # end of the WakeUpAck window
        self._boot_pending = PowerUp(params.power_up) is PowerUp.WAKEUP

    # -- properties -------------------------------------------------------------------------
    @property
    def state(self) -> State:
        return self._state

    @property
    def measuring(self) -> bool:
        return self._state is State.MEASUREMENT

    @property
    def output_period_ns(self) -> int | None:
        """Data message period while measuring and streaming, else None."""
        return self._schedule.period_ns if self._state is State.MEASUREMENT else None

    @property
    def baud_bps(self) -> int:
        """The device's own line rate, bit/s."""
        return self._baud_bps

    @property
    def settings(self) -> Settings:
        """Stored (non-volatile) configuration, for inspection."""
        return self._settings

    # -- bench inputs -----------------------------------------------------------------------
    def set_motion(self, q_NS: Sequence[float], omega_S_radps: Sequence[float], f_S_mps2: Sequence[float]) -> None:
        """Motion at the sensor: ``q_NS`` (w, x, y, z) rotates S (FRD) vectors into NED;
        ``omega_S_radps`` body rates in S, rad/s; ``f_S_mps2`` specific force in S, m/s^2."""
        q = quat_normalize((float(q_NS[0]), float(q_NS[1]), float(q_NS[2]), float(q_NS[3])))
        w = (float(omega_S_radps[0]), float(omega_S_radps[1]), float(omega_S_radps[2]))
        f = (float(f_S_mps2[0]), float(f_S_mps2[1]), float(f_S_mps2[2]))
        self._motion = (q, w, f)

    def set_ambient(self, p_Pa: float, temperature_degC: float) -> None:
        """Static pressure (Pa) and sensor temperature (degC) for BaroPressure/Temperature."""
        self._builder.pressure_Pa = float(p_Pa)
        self._builder.temperature_degC = float(temperature_degC)

    def vibration_S(
        self, f_tones: Sequence[vibration.Tone], omega_tones: Sequence[vibration.Tone], dt_s: float
    ) -> tuple[Vec3, Vec3]:
        """What this device's sensors make of vibration tones ``dt_s`` after the tones'
        reference time: ``(f_S_mps2, omega_S_radps)`` to add to the rigid-body motion given
        to :meth:`set_motion` (sensor frame S). Each tone passes the sensor's bandwidth
        low-pass and, on an mk4, the mean over the output interval (strapdown integration);
        its value at a sample instant is what that sample carries (aliasing included)."""
        if not f_tones and not omega_tones:
            return vibration.ZERO3, vibration.ZERO3
        r = self._response
        order = self.params.bandwidth_order
        window_s = 0.0
        if r.averaging:
            period = self._schedule.period_ns or 1_000_000_000 // self.params.sample_rate_hz
            window_s = period * 1e-9

        return (vibration.sensed_tones(f_tones, r.acc_bandwidth_Hz, order, window_s, dt_s),
                vibration.sensed_tones(omega_tones, r.gyro_bandwidth_Hz, order, window_s, dt_s))

    # -- fault hooks ------------------------------------------------------------------------
    def set_silenced(self, on: bool) -> None:
        """Stop (True) or resume streaming. Like a cut line: the device keeps counting, so
        the host sees a packet-counter jump when data returns."""
        self._silenced = bool(on)

    def power_cycle(self, t_ns: int) -> None:
        """Power off and on at ``t_ns``: new turn-on errors, counters reset, WakeUp again."""
        t = self._clock(t_ns)
        self._errors.power_on()
        self._tx_free_ns = t  # whatever was queued on the line is lost
        self._restart(t)

    def jump_packet_counter(self, delta: int) -> None:
        """Add ``delta`` (mod 2^16) to the packet/sample counter."""
        self._counter = (self._counter + delta) & 0xFFFF

    # -- host side --------------------------------------------------------------------------
    def line_settings_changed(self, baud: int, t_ns: int) -> None:
        previous = self.host_baud
        super().line_settings_changed(baud, t_ns)
        self._parser.reset()  # a partial frame does not survive a reopen
        self._sync_parser_counters()
        if baud != self._baud_bps and baud != previous:
            self.counters["host_baud_mismatch"] += 1  # counts episodes, not notifications

    def receive(self, data: bytes, t_ns: int) -> None:
        t = self._clock(t_ns)
        self.advance(t)
        self.counters["rx_bytes"] += len(data)
        if not self._line_matches():
            self.counters["rx_wrong_baud_bytes"] += len(data)
            self._event(ProtocolError(t, f"{len(data)} byte(s) at {self.host_baud} bit/s, device at {self._baud_bps}"))
            return
        frames = self._parser.feed(bytes(data), t)
        before = self.counters["checksum_errors"] + self.counters["oversize_frames"] + self.counters["timeouts"]
        self._sync_parser_counters()
        bad = self.counters["checksum_errors"] + self.counters["oversize_frames"] + self.counters["timeouts"] - before
        if bad:
            self._event(ProtocolError(t, f"{bad} malformed frame(s) dropped (checksum, length or timeout)"))
        for frame in frames:
            self._dispatch(frame, t)

    def advance(self, t_ns: int) -> None:
        t = self._clock(t_ns)
        if self._wakeup_at_ns is not None and self._wakeup_at_ns <= t:
            at, self._wakeup_at_ns = self._wakeup_at_ns, None
            self._transmit(at, encode_frame(MID.WAKEUP))
            self._wakeup_deadline_ns = at + self.params.wakeup_window_ns
        if self._wakeup_deadline_ns is not None and self._wakeup_deadline_ns <= t:
            self._auto_measurement(self._wakeup_deadline_ns)
        if self._state is State.MEASUREMENT and self._schedule.period_ns is not None:
            self._stream_until(t)

    # -- time -------------------------------------------------------------------------------
    def _clock(self, t_ns: int) -> int:
        """Monotonic device time; the first call powers a WAKEUP-configured device up."""
        t = t_ns if self._t_ns is None else max(t_ns, self._t_ns)
        first = self._t_ns is None
        self._t_ns = t
        if first and self._boot_pending:
            self._boot_pending = False
            self._restart(t)
        return t

    def _restart(self, t: int) -> None:
        """Boot: stored baud takes effect, counter cleared, WakeUp after the boot delay."""
        self._parser.reset()
        self._sync_parser_counters()
        self._counter = 0
        new_baud = BAUD_BPS_BY_CODE[BaudCode(self._settings.baud_code)]
        if new_baud != self._baud_bps:
            self._baud_bps = new_baud
            self._event(BaudChanged(t, new_baud))
        self._set_state(State.WAKEUP, t)
        self._wakeup_deadline_ns = None
        self._wakeup_at_ns = t + self.params.wakeup_delay_ns
        self.advance(t)

    def _set_state(self, new: State, t: int) -> None:
        old, self._state = self._state, new
        if new is not old:
            self._event(StateChanged(t, old, new))
        if new is State.MEASUREMENT:
            self._stream_after_ns = t
            self._schedule = self._make_schedule()
            self._check_line_capacity(t)

    def _auto_measurement(self, t: int) -> None:
        self._wakeup_deadline_ns = None
        if self._identity is Identity.MK4:
            self._transmit(t, encode_frame(MID.CONFIGURATION, self._commands.configuration(self._settings).pack()))
            self._transmit(t, encode_frame(MID.EMTS_DATA, self._commands.emts()))
        self._set_state(State.MEASUREMENT, t)
        # Sampling starts once Configuration and eMTS have left the line (they come "first").
        self._stream_after_ns = max(self._stream_after_ns, self._tx_free_ns - 1)

    # -- dispatch ---------------------------------------------------------------------------
    def _dispatch(self, frame: Frame, t: int) -> None:
        if frame.bid not in (BID_MASTER, BID_FIRST):
            self.counters["ignored_frames"] += 1  # addressed to another device on the bus
            return
        mid, state = frame.mid, self._state
        if state is State.WAKEUP and (self._wakeup_at_ns is not None or mid != MID.WAKEUP_ACK):
            self.counters["ignored_frames"] += 1  # still booting, or not the WakeUpAck
            return
        if mid == MID.WAKEUP_ACK and state is not State.WAKEUP:
            self.counters["ignored_frames"] += 1  # a late WakeUpAck changes nothing
            return
        self.counters["commands"] += 1
        target = TRANSITIONS[state].get(MID(mid)) if mid in MID._value2member_map_ else None
        if target is not None:
            self._transition(MID(mid), target, t)
        elif state is State.MEASUREMENT and mid in MEASUREMENT_REQUESTS:
            self._polled(t)
        elif state is State.CONFIG and self._commands.supports(mid):
            self._request(mid, frame.payload, t)
        elif mid in TRANSITIONS[State.CONFIG] or self._commands.supports(mid) or mid in MEASUREMENT_REQUESTS:
            self.counters["wrong_state"] += 1
            self._error(mid, ErrorCode.INVALID_MESSAGE, t, f"MID {mid:#04x} not valid in {state.name}")
        else:
            self.counters["unknown_mids"] += 1
            self._error(mid, ErrorCode.INVALID_MESSAGE, t, f"unknown or unsupported MID {mid:#04x}")

    def _transition(self, mid: MID, target: State, t: int) -> None:
        if mid == MID.WAKEUP_ACK:
            self._wakeup_deadline_ns = None
            self._event(CommandHandled(t, mid, None))
            self._set_state(target, t)
            return
        self._reply(mid, mid + 1, b"", t)
        if mid == MID.RESET:
            self._restart(t)
        elif target is not self._state:
            self._set_state(target, t)

    def _request(self, mid: int, payload: bytes, t: int) -> None:
        reply = self._commands.handle(mid, payload, self._settings)
        if reply.settings is not None:
            self._settings = reply.settings
            self._builder.alignment = reply.settings.alignment
        if reply.error is not None:
            self.counters["bad_parameters"] += 1
            self._error(mid, reply.error, t, f"MID {mid:#04x} refused with {reply.error.name}")
        elif reply.mid is not None:
            self._reply(mid, reply.mid, reply.payload, t)

    def _reply(self, mid: int, reply_mid: int, payload: bytes, t: int) -> None:
        self._transmit(t, encode_frame(reply_mid, payload))
        self._event(CommandHandled(t, mid, reply_mid))

    def _error(self, mid: int, code: ErrorCode, t: int, reason: str) -> None:
        self.counters["errors_sent"] += 1
        self._transmit(t, encode_frame(MID.ERROR, bytes((code,))))
        self._event(ProtocolError(t, reason))
        self._event(CommandHandled(t, mid, MID.ERROR, int(code)))

    def _sync_parser_counters(self) -> None:
        stats = self._parser.stats
        for name in _PARSER_COUNTERS:
            self.counters[name] = getattr(stats, name)
