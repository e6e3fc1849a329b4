"""XSENS MTi driver: bring-up (config state, identify, output configuration) and the sample stream.

Bring-up, each step waiting for its ack (MID + 1) and failing with a :class:`DeviceError`
that names the port and the step:

1. GoToConfig, resent until 0x31 arrives (a streaming device keeps sending MTData2 until it
   has read the command; those frames are skipped);
2. identify: ReqDID (required), ReqProductCode, ReqFWRev (an Error reply is logged, silence
   is a failure);
3. configure: mk4 SetOutputConfiguration (PacketCounter, SampleTimeFine, EulerAngles NED,
   RateOfTurn, Acceleration at ``rate_hz``, StatusWord), the ack's list must equal the
   request; legacy MTi SetOutputMode (calibrated + orientation), SetOutputSettings (sample
   counter, Euler, NED bit 31), SetPeriod (units of 1/115200 s, 288 at 400 Hz);
4. :meth:`XsensDriver.start` (GoToMeasurement) is called last by the loop, after the other
   devices are up, so the first sample is the loop's first tick.

Sensor time: ``t_ns`` of each sample is the unwrapped SampleTimeFine (10 kHz, u32) since
the first sample; a legacy device has no SampleTimeFine, so its u16 sample counter times the
configured period is used. Gaps in the packet counter are counted (``gap_samples``).

A sample whose SampleTimeFine step disagrees with its packet-counter step by more than
``MAX_TIME_SLIP_PERIODS`` sample periods is rejected (``rejected_time_jumps``): a frame
corrupted on the wire whose checksum still matches would otherwise move the loop's clock by
hours (a u32 of 10 kHz ticks wraps at 119 h) and fire every timer. After
``REBASE_AFTER_REJECTS`` rejections in a row the device's clock is believed again as it
reads (a packet counter that jumped or stalled on the device: ``time_rebases``).

A sample whose values cannot be true (flightcode/drivers/imu_checks.py: not finite, beyond
any MTi's range, or a jump the airframe cannot make since the last accepted sample) is
rejected too (``rejected_values``), and after ``REBASE_AFTER_REJECTS`` in a row believed
again (``value_rebases``): the vehicle really did move that fast.
"""

from __future__ import annotations

import math
import time
from collections import Counter, deque
from dataclasses import dataclass
from typing import Literal

from flightcode.drivers import imu_checks, mtdata, xbus
from flightcode.drivers.base import DeviceError, SerialLike
from flightcode.drivers.mtdata import XsensData
from flightcode.drivers.xbus import Mid, XbusMessage
from flightcode.log import Logger

_DEG = math.pi / 180.0
#: SampleTimeFine may differ from packet counter x period by at most this many periods
MAX_TIME_SLIP_PERIODS = 4
#: consecutive time-jump rejections after which the device's clock is believed again
REBASE_AFTER_REJECTS = 3
#: Xbus error codes worth a name in messages (docs/protocols.md 1.6).
_ERROR_NAMES = {0x03: "period invalid", 0x04: "message invalid or not implemented", 0x20: "baud rate out of range",
                0x21: "invalid parameter", 0x35: "output configuration error"}


@dataclass(frozen=True)
class ImuParams:
    """``[imu]`` of the flight-code config.

    Fields:
        identity: "mk4" (MTData2, SetOutputConfiguration) or "legacy" (2012 MTi: MTData,
            SetOutputMode/Settings/Period).
        rate_hz: sample rate = loop rate, Hz (400 in the paper).
        goto_config_attempts: GoToConfig sends before giving up at boot.
        reply_timeout_s: wait for each boot reply, s (wall clock; boot only).
    """

    __pydantic_config__ = {"extra": "forbid"}

    identity: Literal["mk4", "legacy"] = "mk4"
    rate_hz: int = 400
    goto_config_attempts: int = 10
    reply_timeout_s: float = 0.25


@dataclass(frozen=True)
class DeviceInfo:
    """What the IMU said about itself at boot."""

    device_id: int
    product_code: str
    firmware: str


@dataclass(frozen=True)
class ImuSample:
    """One IMU sample for the loop.

    Fields:
        t_ns: sensor time since the first sample, ns.
        counter: the device's u16 packet/sample counter.
        euler_rad: (roll, pitch, yaw) ZYX Euler angles of the body (FRD) in NED, rad.
        omega_B_radps: body rates (p, q, r) in FRD, rad/s.
        f_B_mps2: specific force in FRD, m/s^2 (about (0, 0, -9.81) level at rest).
        status: StatusWord (mk4) or status byte (legacy, 0 if not output).
        skipped: complete samples that arrived before this one in the same read and were
            dropped so the loop works on the newest.
    """

    t_ns: int
    counter: int
    euler_rad: tuple[float, float, float]
    omega_B_radps: tuple[float, float, float]
    f_B_mps2: tuple[float, float, float]
    status: int
    skipped: int


class XsensDriver:
    """XSENS MTi on ``port`` (115200 8N1 by default; the port is opened by the caller)."""

    name = "imu"

    def __init__(self, port: SerialLike, params: ImuParams, log: Logger) -> None:
        self.port = port
        self.params = params
        self.log = log
        self.counters: Counter[str] = Counter()
        self.parser = xbus.XbusParser()
        self._pending: deque[XbusMessage] = deque()
        self._legacy = params.identity == "legacy"
        self._period_ns = 1_000_000_000 // params.rate_hz
        if self._legacy:
            self._period_ns = mtdata.legacy_period(params.rate_hz) * 1_000_000_000 // mtdata.LEGACY_PERIOD_CLOCK_HZ
            self._frame_len = 5 + mtdata.legacy_mtdata_length(mtdata.LEGACY_OUTPUT_MODE, mtdata.LEGACY_OUTPUT_SETTINGS)
        else:
            self._frame_len = 5 + 64  # the six configured MTData2 items, 64 payload bytes
        self._time_base: int | None = None  # raw clock value of the first sample
        self._clock_ticks = 0  # unwrapped ticks since the first sample
        self._last_raw = 0
        self._last_counter: int | None = None
        self._rejects_in_row = 0
        #: the last accepted sample's (t_ns, euler_rad, omega_B_radps), for the value checks
        self._accepted: tuple[int, tuple[float, float, float], tuple[float, float, float]] | None = None
        self._value_rejects_in_row = 0

    # -- boot ----------------------------------------------------------------------------
    def _read_messages(self) -> list[XbusMessage]:
        data = self.port.read(max(1, self.port.in_waiting))
        return self.parser.feed(data)

    def _transact(self, mid: Mid, payload: bytes, ack: Mid, attempts: int = 1) -> bytes | None:
        """Send ``mid`` until ``ack`` comes back; return its payload, None on an Error reply.

        Raises DeviceError if nothing matching arrives within ``attempts`` x reply timeout.
        """
        frame = xbus.encode_frame(mid, payload)
        for _ in range(attempts):
            self.port.write(frame)
            deadline = time.monotonic() + self.params.reply_timeout_s
            while time.monotonic() < deadline:
                messages = self._read_messages()
                for i, msg in enumerate(messages):
                    if msg.mid == ack:
                        self._pending.extend(messages[i + 1 :])
                        return msg.payload
                    if msg.mid == Mid.ERROR:
                        code = msg.payload[0] if msg.payload else -1
                        self.log.warning("imu.error_reply", request=mid.name.lower(), code=code,
                                         meaning=_ERROR_NAMES.get(code, "unknown"))
                        return None
        raise DeviceError(self.name, f"no answer to {mid.name} (expected MID {ack:#04x}) after "
                                     f"{attempts} attempt(s) of {self.params.reply_timeout_s} s")

    def _require(self, mid: Mid, payload: bytes, ack: Mid) -> bytes:
        reply = self._transact(mid, payload, ack)
        if reply is None:
            hint = " (is imu.identity right?)" if mid in (Mid.SET_OUTPUT_CONFIGURATION, Mid.SET_OUTPUT_MODE) else ""
            raise DeviceError(self.name, f"device refused {mid.name} with an Error message{hint}")
        return reply

    def bring_up(self) -> DeviceInfo:
        """GoToConfig, identify and configure; leaves the device in config state."""
        self.port.reset_input_buffer()
        self._transact(Mid.GOTO_CONFIG, b"", Mid.GOTO_CONFIG_ACK, self.params.goto_config_attempts)
        did = self._require(Mid.REQ_DID, b"", Mid.DEVICE_ID)
        device_id = int.from_bytes(did, "big")
        product = self._transact(Mid.REQ_PRODUCT_CODE, b"", Mid.PRODUCT_CODE)
        fw = self._transact(Mid.REQ_FW_REV, b"", Mid.FIRMWARE_REV)
        info = DeviceInfo(
            device_id,
            product.decode("ascii", "replace").split(" ")[0].strip("\x00") if product is not None else "",
            ".".join(str(b) for b in fw[:3]) if fw is not None and len(fw) >= 3 else "",
        )
        self.log.info("imu.identified", device_id=f"{device_id:08X}", product=info.product_code,
                      firmware=info.firmware, identity=self.params.identity)
        if self._legacy:
            self._configure_legacy()
        else:
            self._configure_mk4()
        return info

    def _configure_mk4(self) -> None:
        entries = mtdata.mk4_output_configuration(self.params.rate_hz)
        request = mtdata.encode_output_configuration(entries)
        applied = self._require(Mid.SET_OUTPUT_CONFIGURATION, request, Mid.SET_OUTPUT_CONFIGURATION_ACK)
        if applied != request:
            raise DeviceError(self.name, f"SetOutputConfiguration applied {applied.hex(' ')} instead of "
                                         f"{request.hex(' ')}")
        self.log.info("imu.configured", output="mtdata2", rate_hz=self.params.rate_hz)

    def _configure_legacy(self) -> None:
        period = mtdata.legacy_period(self.params.rate_hz)
        self._require(Mid.SET_OUTPUT_MODE, int(mtdata.LEGACY_OUTPUT_MODE).to_bytes(2, "big"), Mid.SET_OUTPUT_MODE_ACK)
        self._require(Mid.SET_OUTPUT_SETTINGS, int(mtdata.LEGACY_OUTPUT_SETTINGS).to_bytes(4, "big"),
                      Mid.SET_OUTPUT_SETTINGS_ACK)
        self._require(Mid.SET_PERIOD, period.to_bytes(2, "big"), Mid.SET_PERIOD_ACK)
        self.log.info("imu.configured", output="mtdata", period=period, rate_hz=self.params.rate_hz)

    def start(self) -> None:
        """GoToMeasurement: the sample stream starts after the ack."""
        self._require(Mid.GOTO_MEASUREMENT, b"", Mid.GOTO_MEASUREMENT_ACK)
        # In measurement state only samples of the configured size are expected; a corrupted
        # length byte must not make the parser wait for kilobytes.
        self.parser.max_payload = self._frame_len - 5

    # -- measurement ---------------------------------------------------------------------
    def _decode(self, msg: XbusMessage) -> XsensData | None:
        if msg.mid == Mid.MT_DATA2 and not self._legacy:
            return mtdata.decode_mtdata2(msg.payload, self.counters)
        if msg.mid == Mid.MT_DATA and self._legacy:
            return mtdata.decode_mtdata_legacy(msg.payload, mtdata.LEGACY_OUTPUT_MODE, mtdata.LEGACY_OUTPUT_SETTINGS,
                                             self.counters)
        self.counters["unexpected_messages"] += 1
        return None

    def _to_sample(self, data: XsensData, skipped: int) -> ImuSample | None:
        """The sample on the loop's clock, or None when its time jumps (rejected)."""
        if self._legacy:
            raw, modulus, tick_ns = data.counter, 0x10000, self._period_ns
        else:
            raw, modulus, tick_ns = data.sample_time_fine or 0, 0x1_0000_0000, 1_000_000_000 // mtdata.SAMPLE_TIME_FINE_HZ
        step = None if self._last_counter is None else (data.counter - self._last_counter) & 0xFFFF
        if self._time_base is None:
            self._time_base = raw
        else:
            ticks = (raw - self._last_raw) % modulus
            if not self._legacy and step is not None:
                period_ticks = mtdata.SAMPLE_TIME_FINE_HZ // self.params.rate_hz
                if abs(ticks - step * period_ticks) > MAX_TIME_SLIP_PERIODS * period_ticks:
                    self._rejects_in_row += 1
                    if self._rejects_in_row < REBASE_AFTER_REJECTS:
                        self.counters["rejected_time_jumps"] += 1
                        return None
                    self.counters["time_rebases"] += 1  # the device's clock, as it says
            self._clock_ticks += ticks
        self._rejects_in_row = 0
        self._last_raw = raw
        if step is not None and step != 1:
            self.counters["gap_samples"] += (step - 1) if step else 0
            self.counters["gaps" if step else "duplicates"] += 1
        self._last_counter = data.counter
        roll, pitch, yaw = data.euler_deg
        sample = ImuSample(self._clock_ticks * tick_ns, data.counter, (roll * _DEG, pitch * _DEG, yaw * _DEG),
                           data.rate_of_turn_radps, data.acceleration_mps2, data.status, skipped)
        return sample if self._believable(sample) else None

    def _believable(self, s: ImuSample) -> bool:
        """The value checks of imu_checks against the last accepted sample (counted if not)."""
        acc = self._accepted
        last = None if acc is None else (acc[1], acc[2])
        dt_s = 0.0 if acc is None else max(0, s.t_ns - acc[0]) * 1e-9
        reason = imu_checks.implausible(s.euler_rad, s.omega_B_radps, s.f_B_mps2, last, dt_s)
        if reason is not None:
            self._value_rejects_in_row += 1
            # a value out of range is never true; a jump that persists is the vehicle's
            if not reason.endswith("jump") or self._value_rejects_in_row < REBASE_AFTER_REJECTS:
                self.counters["rejected_values"] += 1
                return False
            self.counters["value_rebases"] += 1
        self._value_rejects_in_row = 0
        self._accepted = (s.t_ns, s.euler_rad, s.omega_B_radps)
        return True

    def read_sample(self, timeout_s: float) -> ImuSample | None:
        """Block until the next sample (the newest one if several are queued).

        Returns None when no complete sample arrived within ``timeout_s`` (the IMU-loss
        watchdog; the port's own read timeout should be the same value). A sample rejected
        for its time (see the module's docstring) is dropped and the next one awaited.
        """
        deadline = time.monotonic() + timeout_s
        while True:
            got = self._read_newest(deadline, timeout_s)
            if got is None:
                return None
            newest, skipped = got
            if skipped:
                self.counters["skipped_samples"] += skipped
            sample = self._to_sample(newest, skipped)
            if sample is not None:
                return sample

    def _read_newest(self, deadline: float, timeout_s: float) -> tuple[XsensData, int] | None:
        """The newest decoded sample and how many older ones it replaced; None at the deadline."""
        newest: XsensData | None = None
        skipped = 0
        while self._pending:
            data = self._decode(self._pending.popleft())
            if data is not None:
                skipped += newest is not None
                newest = data
        port, parser = self.port, self.parser
        while True:
            if newest is None:
                chunk = port.read(parser.bytes_needed(self._frame_len))
            else:
                n = port.in_waiting  # anything newer already queued? take it instead
                if not n:
                    break
                chunk = port.read(n)
            for msg in parser.feed(chunk):
                data = self._decode(msg)
                if data is not None:
                    skipped += newest is not None
                    newest = data
            if newest is None:
                if not chunk:
                    return None  # the port's read timeout passed in silence
                now = time.monotonic()
                # Past the deadline, finish only what is already queued; a babbling device
                # (bytes, never a valid sample) still trips the watchdog by the hard limit.
                if now >= deadline and (now >= deadline + timeout_s or not port.in_waiting):
                    return None
        return newest, skipped
