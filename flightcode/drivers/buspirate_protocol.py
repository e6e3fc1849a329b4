"""Bus Pirate v3 binary-mode SPI (BBIO1 / SPI1), sans-I/O: the commands, the entry sequence,
the encoding and checking of transfers. The serial part is :mod:`flightcode.drivers.buspirate_spi`.

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
"""

from __future__ import annotations

from collections.abc import Sequence
from enum import Enum, IntEnum, unique

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
