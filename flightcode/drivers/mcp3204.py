"""MCP3204 12-bit ADC (Microchip DS21298E) read through an SPI bridge, four channels a tick.

Framing: four bytes a conversion (SPI mode 0,0; docs/protocols.md 2), with the start bit as
early as the second clock (as Linux's ``mcp320x`` aligns it), so that 32 clocks carry the code
MSB first and, clocked on after B0, the part's repeat of B1..B11 LSB first (DS21298E section
5.0):

=====  ==============================  ===========================================
byte   MOSI                            MISO
=====  ==============================  ===========================================
0      ``0 1 S D2 D1 D0 0 0`` (S=1)    ``? ? ? ? ? ? ? 0`` (hi-Z, then the null bit)
1      ``0000 0000``                   ``B11 .. B4``
2      ``0000 0000``                   ``B3 B2 B1 B0 B1 B2 B3 B4``
3      ``0000 0000``                   ``B5 .. B11 0``
=====  ==============================  ===========================================

so CH0..CH3 single-ended are ``60 00 00 00``, ``64 00 00 00``, ``68 00 00 00``,
``6C 00 00 00``. The repeat is the reading's only check of its own: SPI has no checksum, and a
bit flipped on MISO (noise on the line) gives a plausible wrong code. B1..B11 must read the
same both ways; B0, sent once, is unchecked (one LSB). (Datasheet Fig. 6-1's 3-byte framing,
with the start bit at the sixth clock, would need five bytes for the repeat.)

:class:`Mcp3204Reader` sends all channels in one pipelined bridge write per sample. A sample
whose reply is late, malformed, has a null bit set or a repeat that disagrees has no reading
(None); the bridge collects late replies and re-enters SPI mode itself (:class:`BusPirateSpi`;
a null bit is a framing error and re-applies the setup, a repeat that disagrees is a bit error
and does not), so a bad exchange costs the samples it takes to put right, never a misread code.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

from flightcode.drivers.buspirate_protocol import encode_transfers
from flightcode.drivers.buspirate_spi import BusPirateSpi

RESOLUTION_CODES = 4096
START_BIT = 0x40
SINGLE_ENDED = 0x20
NULL_BIT = 0x01  #: in byte 0


#: bytes of one conversion: the code MSB first, then its repeat LSB first
FRAME_BYTES = 4


def request(channel: int, single_ended: bool = True) -> bytes:
    """The 4 MOSI bytes converting ``channel`` (0..3)."""
    if not 0 <= channel <= 3:
        raise ValueError(f"MCP3204 channel {channel} (0..3)")
    return bytes((START_BIT | (SINGLE_ENDED if single_ended else 0) | (channel & 0x3) << 2, 0x00, 0x00, 0x00))


def decode(miso: bytes) -> int | None:
    """The 12-bit code from the MISO bytes (MSB first: byte 1 and the top of byte 2); None if
    the null bit is not 0 or the length is wrong."""
    if len(miso) != FRAME_BYTES or miso[0] & NULL_BIT:
        return None
    return (miso[1] << 4) | (miso[2] >> 4)


def repeat_agrees(miso: bytes, code: int) -> bool:
    """Whether the LSB-first repeat (B1..B11: the low half of byte 2, byte 3 but its last bit)
    reads ``code``'s bits B1..B11."""
    repeat = ((miso[2] & 0x0F) << 7) | (miso[3] >> 1)  # B1 first, 11 bits
    return repeat == _REVERSED_11[code >> 1]


#: the 11-bit reversal of every B11..B1: B1..B11 LSB first is the reversal of ``code >> 1``
_REVERSED_11 = tuple(int(f"{v:011b}"[::-1], 2) for v in range(1 << 11))


class Mcp3204Reader:
    """Reads ``channels`` each sample through ``bridge``.

    Args:
        bridge: the SPI bridge (entered at boot with :meth:`BusPirateSpi.enter_spi`).
        channels: MCP3204 channel numbers in the order the codes are returned.
    """

    name = "adc"

    def __init__(self, bridge: BusPirateSpi, channels: Sequence[int]) -> None:
        self.bridge = bridge
        self.channels = tuple(channels)
        self._frames = [request(ch) for ch in self.channels]
        self._wire = encode_transfers(self._frames)
        self._lengths = tuple(len(f) for f in self._frames)
        #: reads (good samples), failed_reads (a transfer went out and gave no codes),
        #: null_bit_errors, repeat_errors (the LSB-first repeat disagreed: a bit error),
        #: no_transfer (the bridge was busy: late reply owed or re-entering).
        self.counters: Counter[str] = Counter()

    def read_codes(self, t_ns: int) -> tuple[int, ...] | None:
        """Codes of all channels for the sample at sensor time ``t_ns``, or None this sample."""
        bridge = self.bridge
        sent = bridge.counters["requests"]
        replies = bridge.transfer_encoded(self._wire, self._lengths, t_ns)
        if replies is None:
            self.counters["failed_reads" if bridge.counters["requests"] != sent else "no_transfer"] += 1
            return None
        codes = []
        for miso in replies:
            code = decode(miso)
            if code is None:
                self.counters["null_bit_errors"] += 1
                self.counters["failed_reads"] += 1
                bridge.lose_sync("null_bit")  # wrong SPI mode or framing: re-apply the setup
                return None
            if not repeat_agrees(miso, code):
                self.counters["repeat_errors"] += 1  # a bit error on the line, not the framing:
                self.counters["failed_reads"] += 1  # the bridge stays in sync
                return None
            codes.append(code)
        self.counters["reads"] += 1
        return tuple(codes)
