"""Bus Pirate v3 binary-mode SPI (BBIO1 / SPI1) as the flight code's SPI bridge.

Protocol (research/protocols.md 7.1; DP wiki "SPI (binary)", pyBusPirateLite, flashrom):

* 20 x ``00`` from any mode -> ``BBIO1`` (every further ``00`` in BBIO answers ``BBIO1`` again);
  ``01`` -> ``SPI1``;
* in SPI mode each of these answers ``01``: ``02``/``03`` CS low/high, ``1n`` + n+1 bytes bulk
  transfer (then one byte read per byte sent), ``4x`` peripherals (power, pull-ups, AUX, CS),
  ``6x`` speed, ``8x`` config (``8A``: 3.3 V push-pull outputs, clock idle low, CKE = 1,
  sample in the middle = SPI mode 0).

Pipelining: every command's reply has a fixed length, so a whole tick's transactions go out
in one write and come back in one read: ``02 12 a b c 03`` per 3-byte transfer answers
``01 01 x y z 01``.

Entry never waits for silence: the stream after the 20 zeros is ``[terminal junk] BBIO1*k``
and the ``01`` sent next is answered after all of them, so reading until the buffer ends in
``SPI1`` is both the drain and the check.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable, Sequence
from enum import IntEnum, unique

from flightcode.drivers.base import DeviceError, SerialLike
from flightcode.log import Logger

ACK = 0x01
BBIO_REPLY = b"BBIO1"
SPI_REPLY = b"SPI1"
RESET_ZEROS = 20


@unique
class SpiCmd(IntEnum):
    """SPI-mode command bytes (low bits carry arguments where noted)."""

    EXIT_TO_BBIO = 0x00  # also the BBIO entry byte
    ENTER_SPI = 0x01  # in BBIO; in SPI mode re-sends "SPI1"
    CS_LOW = 0x02
    CS_HIGH = 0x03
    BULK = 0x10  # | (n - 1), n = 1..16
    PERIPHERALS = 0x40  # | power<<3 | pullups<<2 | aux<<1 | cs
    SPEED = 0x60  # | speed code
    CONFIG = 0x80  # | hiz_off<<3 | ckp<<2 | cke<<1 | smp


#: SPI clock (Hz) -> speed code of the ``6x`` command.
SPEED_CODES: dict[int, int] = {
    30_000: 0, 125_000: 1, 250_000: 2, 1_000_000: 3, 2_000_000: 4, 2_600_000: 5, 4_000_000: 6, 8_000_000: 7,
}
#: 3.3 V push-pull, idle low, CKE active->idle, sample middle: SPI mode 0 (MCP3204 mode 0,0).
CONFIG_MODE0_3V3 = SpiCmd.CONFIG | 0x0A
#: Power supplies on, pull-ups off, AUX low, CS high (inactive).
PERIPHERALS_POWER_CS_HIGH = SpiCmd.PERIPHERALS | 0x08 | 0x01


def setup_commands(speed_hz: int) -> bytes:
    """The SPI setup after entry: config 0x8A, speed, peripherals, CS high (each acks 01)."""
    return bytes((CONFIG_MODE0_3V3, SpiCmd.SPEED | SPEED_CODES[speed_hz], PERIPHERALS_POWER_CS_HIGH, SpiCmd.CS_HIGH))


def encode_transfers(frames: Sequence[bytes]) -> bytes:
    """One pipelined write: ``02, 1n, data, 03`` per frame (each frame 1..16 bytes)."""
    out = bytearray()
    for frame in frames:
        if not 1 <= len(frame) <= 16:
            raise ValueError(f"bulk transfer of {len(frame)} bytes (1..16 allowed)")
        out += bytes((SpiCmd.CS_LOW, SpiCmd.BULK | (len(frame) - 1)))
        out += frame
        out.append(SpiCmd.CS_HIGH)
    return bytes(out)


def reply_length(frames: Sequence[bytes]) -> int:
    """Bytes the Bus Pirate answers to :func:`encode_transfers` of ``frames``."""
    return sum(len(f) + 3 for f in frames)


def decode_transfers(reply: bytes, lengths: Sequence[int]) -> list[bytes] | str:
    """Split a pipelined reply into the MISO bytes of each transfer, checking every ack.

    Returns the list, or a short reason string (``short``, ``bad_ack``) when the reply
    does not have the expected shape.
    """
    if len(reply) != sum(n + 3 for n in lengths):
        return "short"
    out: list[bytes] = []
    i = 0
    for n in lengths:
        if reply[i] != ACK or reply[i + 1] != ACK or reply[i + 2 + n] != ACK:
            return "bad_ack"
        out.append(reply[i + 2 : i + 2 + n])
        i += n + 3
    return out


def entry_reply_ok(buf: bytes) -> bool:
    """True if ``buf`` is ``[junk] BBIO1 (BBIO1)* SPI1``: the device is in SPI mode."""
    if not buf.endswith(SPI_REPLY):
        return False
    head = buf[: -len(SPI_REPLY)]
    first = head.find(BBIO_REPLY)
    if first < 0:
        return False
    rest = head[first:]
    return rest == BBIO_REPLY * (len(rest) // len(BBIO_REPLY))


class BusPirateSpi:
    """The Bus Pirate on ``port`` (115200 8N1; port read timeout short, e.g. 10 ms).

    Args:
        speed_hz: SPI clock, one of :data:`SPEED_CODES` (MCP3204: <= 2 MHz at 5 V).
        entry_attempts: full entry sequences tried at boot before giving up.
        reply_timeout_s: wait for each entry/setup reply at boot, s (wall clock).
    """

    name = "adc"

    def __init__(self, port: SerialLike, *, speed_hz: int, entry_attempts: int, reply_timeout_s: float,
                 log: Logger) -> None:
        if speed_hz not in SPEED_CODES:
            raise ValueError(f"SPI speed {speed_hz} Hz is not one of {sorted(SPEED_CODES)}")
        self.port = port
        self.speed_hz = speed_hz
        self.entry_attempts = entry_attempts
        self.reply_timeout_s = reply_timeout_s
        self.log = log
        self.counters: Counter[str] = Counter()
        #: False after a failed transaction until :meth:`resync` succeeds.
        self.in_sync = False

    def _read_until(self, done: Callable[[bytes], bool], deadline: float) -> bytes:
        buf = bytearray()
        while not done(bytes(buf)) and time.monotonic() < deadline:
            buf += self.port.read(max(1, self.port.in_waiting))
        return bytes(buf)

    def _enter_once(self, timeout_s: float) -> str | None:
        """One entry + setup sequence; None on success, else the reason."""
        port = self.port
        port.reset_input_buffer()
        port.write(bytes(RESET_ZEROS))
        deadline = time.monotonic() + timeout_s
        got = self._read_until(lambda b: BBIO_REPLY in b, deadline)
        if BBIO_REPLY not in got:
            return f"no BBIO1 after {RESET_ZEROS} zeros (got {got[:16].hex(' ') or 'nothing'})"
        port.write(bytes((SpiCmd.ENTER_SPI,)))
        got += self._read_until(lambda b: entry_reply_ok(got + b), deadline)
        if not entry_reply_ok(got):
            return f"no SPI1 after 01 (got ...{got[-16:].hex(' ')})"
        setup = setup_commands(self.speed_hz)
        port.write(setup)
        acks = self._read_until(lambda b: len(b) >= len(setup), deadline)
        if acks != bytes((ACK,)) * len(setup):
            return f"setup {setup.hex(' ')} answered {acks.hex(' ') or 'nothing'}"
        self.in_sync = True
        return None

    def enter_spi(self) -> None:
        """Boot: BBIO1 entry with retries, SPI1, config/speed/peripherals/CS; DeviceError on failure."""
        reason = "not tried"
        for attempt in range(1, self.entry_attempts + 1):
            reason = self._enter_once(self.reply_timeout_s) or ""
            if not reason:
                self.log.info("adc.spi_mode", attempts=attempt, speed_hz=self.speed_hz)
                return
            self.log.warning("adc.entry_retry", attempt=attempt, reason=reason)
        raise DeviceError(self.name, f"Bus Pirate did not enter binary SPI mode after "
                                     f"{self.entry_attempts} attempt(s): {reason}")

    def resync(self, timeout_s: float) -> bool:
        """In flight: flush and re-enter SPI mode once (bounded by ``timeout_s``); counted."""
        self.counters["resyncs"] += 1
        reason = self._enter_once(timeout_s)
        if reason:
            self.counters["resync_failures"] += 1
            n = self.counters["resync_failures"]
            if n & (n - 1) == 0:  # 1st, 2nd, 4th, ...: a dead bridge must not flood the log
                self.log.warning("adc.resync_failed", failures=n, reason=reason)
            return False
        self.log.info("adc.resynced", resyncs=self.counters["resyncs"])
        return True

    def transfer(self, frames: Sequence[bytes]) -> list[bytes] | None:
        """All ``frames`` as CS-framed bulk transfers: one write, one read; None on failure.

        A short or malformed reply is counted (``short``/``bad_ack``), the input flushed
        and the bridge marked out of sync (the caller decides when to :meth:`resync`).
        """
        return self.transfer_encoded(encode_transfers(frames), [len(f) for f in frames])

    def transfer_encoded(self, wire: bytes, lengths: Sequence[int]) -> list[bytes] | None:
        """:meth:`transfer` with the write already built by :func:`encode_transfers` (the
        per-tick path: the same four conversions every sample)."""
        self.port.write(wire)
        reply = self.port.read(sum(n + 3 for n in lengths))
        result = decode_transfers(reply, lengths)
        if isinstance(result, str):
            self.counters[result] += 1
            self.in_sync = False
            self.port.reset_input_buffer()
            return None
        self.counters["transfers"] += 1
        return result
