"""Bus Pirate v3 binary-mode SPI (BBIO1 / SPI1) as the flight code's SPI bridge.

Protocol (docs/protocols.md 7.1; DP wiki "SPI (binary)", pyBusPirateLite, flashrom):

* 20 x ``00`` from any mode -> ``BBIO1`` (every further ``00`` in BBIO answers ``BBIO1`` again);
  ``01`` -> ``SPI1``;
* in SPI mode each of these answers ``01``: ``02``/``03`` CS low/high, ``1n`` + n+1 bytes bulk
  transfer (then one byte read per byte sent), ``4x`` peripherals (power, pull-ups, AUX, CS),
  ``6x`` speed, ``8x`` config (``8A``: 3.3 V push-pull outputs, clock idle low, CKE = 1,
  sample in the middle = SPI mode 0).

Entry (:class:`EntrySequence`, sans-I/O; as flashrom's ``buspirate_spi_init``): send the 20
zeros, then discard everything until the line has been quiet for ``quiet_s`` (a bridge left in
SPI mode answers ``BBIO1`` to each zero, and replies to earlier commands may still be on their
way), flush, and then one command at a time, each answered by exactly its reply: ``00`` ->
``BBIO1``, ``01`` -> ``SPI1``, ``8A``, ``6x``, ``49``, ``03`` -> ``01`` each. A byte more, a
byte less or a different byte fails the attempt; nothing stale can pass for a reply.

Transfers: every command's reply has a fixed length, so a whole sample's conversions go out
in one write and come back in one read of exactly that length: ``02 12 a b c 03`` per 3-byte
transfer answers ``01 01 x y z 01``. The driver counts the bytes it is still owed: a reply
that misses the read timeout is *late*, not lost; its remaining bytes are collected (and their
ack pattern checked) before the next write, so a late reply costs one sample's data and is
never read as the next sample's. Only a reply of the wrong shape, or one that does not arrive
within ``reply_timeout_s``, starts a re-entry, which in flight runs one non-blocking step per
sample (:meth:`BusPirateSpi.transfer_encoded`) instead of stalling the loop. After a garbled
reply (how much of it is still to come is unknown) the re-entry waits ``reply_timeout_s``
first: a reply later than that counts as lost, so none can be mistaken for a later sample's.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable, Sequence
from enum import Enum, IntEnum, unique

from flightcode.drivers.base import DeviceError, SerialLike, read_waiting
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


def entry_script(speed_hz: int) -> tuple[tuple[bytes, bytes], ...]:
    """(command, exact reply) pairs sent one at a time after the zeros have been drained."""
    acked = tuple((bytes((cmd,)), bytes((ACK,))) for cmd in setup_commands(speed_hz))
    return ((bytes((SpiCmd.EXIT_TO_BBIO,)), BBIO_REPLY), (bytes((SpiCmd.ENTER_SPI,)), SPI_REPLY), *acked)


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


def acks_ok(reply: bytes, lengths: Sequence[int]) -> bool:
    """True if every ack position that ``reply`` (possibly a prefix) reaches holds ``01``.

    Per transfer of n bytes the reply is ``01`` (CS low), ``01`` (bulk), n MISO bytes, ``01``
    (CS high).
    """
    i, end = 0, len(reply)
    for n in lengths:
        for pos in (i, i + 1, i + 2 + n):
            if pos >= end:
                return True
            if reply[pos] != ACK:
                return False
        i += n + 3
    return end <= i


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


# -- entry: sans-I/O ---------------------------------------------------------------------------
@unique
class EntryState(Enum):
    """Where an :class:`EntrySequence` is."""

    DRAIN = "drain"  # zeros sent: discarding everything until the line is quiet
    EXCHANGE = "exchange"  # one command sent: exactly its reply expected
    DONE = "done"
    FAILED = "failed"


class EntrySequence:
    """One attempt at BBIO1/SPI1 entry and SPI setup, as a byte-in/byte-out state machine.

    Drive it with :meth:`start` (bytes to write) and then :meth:`step` with whatever was read
    (possibly nothing) and the current time; each returns ``(flush_input, bytes_to_write)``.
    It never waits itself. Times are seconds on one monotonic clock.

    Args:
        script: (command, exact reply) pairs, :func:`entry_script`.
        quiet_s: the line must be silent this long after the zeros before the first command.
        reply_timeout_s: longest wait for each reply, and for the line to go quiet.
    """

    NOTHING: tuple[bool, bytes] = (False, b"")

    def __init__(self, script: Sequence[tuple[bytes, bytes]], quiet_s: float, reply_timeout_s: float) -> None:
        self.script = tuple(script)
        self.quiet_s = quiet_s
        self.reply_timeout_s = reply_timeout_s
        self.state = EntryState.DRAIN
        self.reason = ""
        #: Bytes discarded while draining (junk, BBIO1s, late replies).
        self.drained = 0
        self._i = 0
        self._buf = bytearray()
        self._t_start = self._t_last_rx = self._t_sent = 0.0

    def start(self, now_s: float) -> bytes:
        """Begin: the 20 zeros to write (after flushing the input)."""
        self.state = EntryState.DRAIN
        self._t_start = self._t_last_rx = now_s
        return bytes(RESET_ZEROS)

    def _fail(self, reason: str) -> tuple[bool, bytes]:
        self.state = EntryState.FAILED
        self.reason = reason
        return self.NOTHING

    def _send(self, i: int, now_s: float) -> bytes:
        self._i = i
        self._buf.clear()
        self._t_sent = now_s
        return self.script[i][0]

    def step(self, data: bytes, now_s: float) -> tuple[bool, bytes]:
        """Feed what was read since the last call; returns (flush input first, bytes to write)."""
        if self.state is EntryState.DRAIN:
            if data:
                self.drained += len(data)
                self._t_last_rx = now_s
            if now_s - self._t_last_rx >= self.quiet_s:
                self.state = EntryState.EXCHANGE
                return True, self._send(0, now_s)
            if now_s - self._t_start >= self.quiet_s + self.reply_timeout_s:
                return self._fail(f"line not quiet {self.reply_timeout_s:g} s after {RESET_ZEROS} zeros "
                                  f"({self.drained} bytes)")
            return self.NOTHING
        if self.state is not EntryState.EXCHANGE:
            return self.NOTHING
        cmd, expected = self.script[self._i]
        self._buf += data
        got = bytes(self._buf)
        if not expected.startswith(got):  # a wrong byte, or one too many
            return self._fail(f"{cmd.hex()} answered {got.hex(' ')} (expected {_show(expected)})")
        if got == expected:
            if self._i + 1 == len(self.script):
                self.state = EntryState.DONE
                return self.NOTHING
            return False, self._send(self._i + 1, now_s)
        if now_s - self._t_sent >= self.reply_timeout_s:
            return self._fail(f"no {_show(expected)} after {cmd.hex()} (got {got.hex(' ') or 'nothing'})")
        return self.NOTHING


def _show(reply: bytes) -> str:
    """``BBIO1`` for text replies, ``01`` for single bytes."""
    return reply.decode("ascii") if len(reply) > 1 and reply.isalnum() else reply.hex(" ")


# -- the serial part ----------------------------------------------------------------------------
@unique
class LinkState(Enum):
    """Where the bridge is, seen from the flight code."""

    READY = "ready"  # in SPI mode, no reply outstanding
    REPLY_PENDING = "reply_pending"  # a reply missed the read timeout: its remaining bytes are owed
    ENTERING = "entering"  # a re-entry is in progress (one non-blocking step per sample)
    WAITING = "waiting"  # a re-entry failed: the next one starts after the resync interval


class BusPirateSpi:
    """The Bus Pirate on ``port`` (115200 8N1, port read timeout = the per-sample reply wait).

    Args:
        speed_hz: SPI clock, one of :data:`SPEED_CODES` (MCP3204: <= 2 MHz at 5 V).
        entry_attempts: full entry sequences tried at boot before giving up.
        reply_timeout_s: longest wait for each entry reply (boot and in flight) and for the
            rest of a late transfer reply, s (wall clock).
        quiet_s: the line must be quiet this long after the entry zeros, s (wall clock).
        resync_interval_ns: after a failed in-flight re-entry, the next starts this much sensor
            time later, ns.
        clock: monotonic seconds (``time.monotonic``; tests pass a fake).

    Counters: ``requests`` (transfer writes), ``transfers`` (good replies), ``short``/``bad_ack``
    (malformed replies), ``late_replies`` (missed the read timeout) and
    ``late_replies_discarded`` (collected later and thrown away), ``replies_lost`` (owed bytes
    that never came), ``unexpected_input`` (unowed bytes flushed before a write),
    ``sync_lost_<reason>``, ``resyncs`` (in-flight re-entries started), ``resync_failures``.
    """

    name = "adc"

    def __init__(self, port: SerialLike, *, speed_hz: int, entry_attempts: int, reply_timeout_s: float,
                 quiet_s: float, resync_interval_ns: int, log: Logger,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if speed_hz not in SPEED_CODES:
            raise ValueError(f"SPI speed {speed_hz} Hz is not one of {sorted(SPEED_CODES)}")
        self.port = port
        self.speed_hz = speed_hz
        self.entry_attempts = entry_attempts
        self.reply_timeout_s = reply_timeout_s
        self.quiet_s = quiet_s
        self.resync_interval_ns = resync_interval_ns
        self.log = log
        self.clock = clock
        self.counters: Counter[str] = Counter()
        self.state = LinkState.WAITING  # until :meth:`enter_spi` (or the first transfer) enters
        self._script = entry_script(speed_hz)
        self._entry: EntrySequence | None = None
        self._retry_ns: int | None = None  # WAITING: sensor time of the next attempt (None: at once)
        self._partial = bytearray()  # REPLY_PENDING: what came of the late reply so far
        self._owed = 0
        self._lengths: tuple[int, ...] = ()
        self._pending_since = 0.0
        self._stale_until = 0.0  # no re-entry before this (clock): a garbled reply's rest may come

    @property
    def in_sync(self) -> bool:
        """True when a transfer can go out now."""
        return self.state is LinkState.READY

    # -- entry ------------------------------------------------------------------------------
    def _begin_entry(self) -> EntrySequence:
        seq = EntrySequence(self._script, self.quiet_s, self.reply_timeout_s)
        self.port.reset_input_buffer()
        self.port.write(seq.start(self.clock()))
        self._entry = seq
        self.state = LinkState.ENTERING
        return seq

    def _entry_step(self, seq: EntrySequence, data: bytes) -> None:
        flush, out = seq.step(data, self.clock())
        if flush:
            self.port.reset_input_buffer()
        if out:
            self.port.write(out)

    def enter_spi(self) -> None:
        """Boot: entry with retries, blocking; DeviceError naming the adc on failure."""
        reason = "not tried"
        port = self.port
        for attempt in range(1, self.entry_attempts + 1):
            seq = self._begin_entry()
            while seq.state in (EntryState.DRAIN, EntryState.EXCHANGE):
                n = port.in_waiting
                self._entry_step(seq, port.read(n if n else 1))  # in silence waits the port timeout
            if seq.state is EntryState.DONE:
                self.state = LinkState.READY
                self._entry = None
                self.log.info("adc.spi_mode", attempts=attempt, speed_hz=self.speed_hz, drained=seq.drained)
                return
            reason = seq.reason
            self.log.warning("adc.entry_retry", attempt=attempt, reason=reason)
        raise DeviceError(self.name, f"Bus Pirate did not enter binary SPI mode after "
                                     f"{self.entry_attempts} attempt(s): {reason}")

    def lose_sync(self, reason: str, *, reply_in_flight: bool = False) -> None:
        """The data are wrong (a bad reply, a lost one, the MCP3204's null bit): re-enter;
        counted as ``sync_lost_<reason>``.

        ``reply_in_flight``: part of a transfer reply may still be on its way (the reply was
        garbled, so how much of it came is unknown). A late reply has the shape of a good one
        and would be read as the data of a later sample, so the re-entry waits until
        ``reply_timeout_s`` after this moment (a reply later than that is lost by definition)
        and then drains the line as usual.
        """
        self.counters["sync_lost_" + reason] += 1
        self.state = LinkState.WAITING
        self._retry_ns = None
        if reply_in_flight:
            self._stale_until = self.clock() + self.reply_timeout_s

    def _poll_entry(self, t_ns: int) -> bool:
        """One non-blocking step of the in-flight re-entry; True once the bridge is ready."""
        if self.state is LinkState.WAITING:
            if self._retry_ns is not None and t_ns < self._retry_ns:
                return False
            if self.clock() < self._stale_until:
                self.counters["samples_waiting_stale"] += 1
                return False
            self.counters["resyncs"] += 1
            self._begin_entry()
            return False  # replies come later: the next samples poll them
        seq = self._entry
        assert seq is not None
        self._entry_step(seq, read_waiting(self.port))
        if seq.state is EntryState.DONE:
            self.state = LinkState.READY
            self._entry = None
            self.log.info("adc.resynced", resyncs=self.counters["resyncs"], drained=seq.drained)
            return True
        if seq.state is EntryState.FAILED:
            self.counters["resync_failures"] += 1
            n_fail = self.counters["resync_failures"]
            if n_fail & (n_fail - 1) == 0:  # 1st, 2nd, 4th, ...: a dead bridge must not flood the log
                self.log.warning("adc.resync_failed", failures=n_fail, reason=seq.reason)
            self.state = LinkState.WAITING
            self._retry_ns = t_ns + self.resync_interval_ns
            self._entry = None
        return False

    # -- transfers --------------------------------------------------------------------------
    def _collect_late(self) -> bool:
        """REPLY_PENDING: take the owed bytes that have arrived; True once the line is clear."""
        port = self.port
        n = port.in_waiting
        if n:
            got = port.read(min(n, self._owed))
            self._partial += got
            self._owed -= len(got)
        if self._owed:
            if self.clock() - self._pending_since >= self.reply_timeout_s:
                self.counters["replies_lost"] += 1
                self.lose_sync("reply_lost")
            return False
        if decode_transfers(bytes(self._partial), self._lengths) == "bad_ack":
            self.counters["bad_ack"] += 1
            self.lose_sync("bad_late_reply", reply_in_flight=True)
            return False
        self.counters["late_replies_discarded"] += 1
        self.state = LinkState.READY
        return True

    def transfer(self, frames: Sequence[bytes], t_ns: int = 0) -> list[bytes] | None:
        """All ``frames`` as CS-framed bulk transfers: one write, one read; None this sample.

        See :meth:`transfer_encoded`.
        """
        return self.transfer_encoded(encode_transfers(frames), tuple(len(f) for f in frames), t_ns)

    def transfer_encoded(self, wire: bytes, lengths: tuple[int, ...], t_ns: int) -> list[bytes] | None:
        """:meth:`transfer` with the write already built by :func:`encode_transfers` (the
        per-sample path: the same four conversions every sample). ``t_ns`` is sensor time.

        Returns the MISO bytes of each transfer, or None when this sample has no data: the
        previous reply is still owed, a re-entry is in progress, the request went out short
        (the port does not block on writes; counted ``short_writes``: the bridge is
        re-entered), or this reply was short (counted ``late_replies``: its rest is collected
        at the next sample) or malformed (counted ``bad_ack``: the bridge is re-entered).
        Blocks at most the port's read timeout.
        """
        state = self.state
        if state is LinkState.REPLY_PENDING and not self._collect_late():
            return None
        if state in (LinkState.ENTERING, LinkState.WAITING) and not self._poll_entry(t_ns):
            return None
        port = self.port
        if port.in_waiting:  # nothing is owed, so these bytes are junk: never let them shift a reply
            self.counters["unexpected_input"] += 1
            port.reset_input_buffer()
        written = port.write(wire)
        self.counters["requests"] += 1
        if written is not None and written < len(wire):  # the port is non-blocking
            self.counters["short_writes"] += 1
            self.lose_sync("short_write", reply_in_flight=True)  # the bridge holds a torn request
            return None
        size = sum(n + 3 for n in lengths)
        reply = port.read(size)
        if len(reply) == size:
            result = decode_transfers(reply, lengths)
            if not isinstance(result, str):
                self.counters["transfers"] += 1
                return result
            self.counters[result] += 1
            self.lose_sync("bad_reply", reply_in_flight=True)
            return None
        if not acks_ok(reply, lengths):
            self.counters["bad_ack"] += 1
            self.lose_sync("bad_reply", reply_in_flight=True)
            return None
        # Late, not lost: the rest is owed and collected before the next write.
        self.counters["late_replies"] += 1
        self.state = LinkState.REPLY_PENDING
        self._partial = bytearray(reply)
        self._owed = size - len(reply)
        self._lengths = lengths
        self._pending_since = self.clock()
        return None
