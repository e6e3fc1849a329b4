"""MCP3204 12-bit ADC (Microchip DS21298E) read through an SPI bridge, four channels a tick.

Framing: the datasheet's 3-byte transaction (Fig. 6-1, SPI mode 0,0; docs/protocols.md 2):

=====  ============================  =================================
byte   MOSI                          MISO
=====  ============================  =================================
0      ``0000 01 S D2`` (S=1 single)  ignored (hi-Z)
1      ``D1 D0 xxxxxx``               ``? ? ? 0 B11 B10 B9 B8`` (bit 4 = null bit)
2      ``xxxx xxxx``                  ``B7 .. B0``
=====  ============================  =================================

so CH0..CH3 single-ended are ``06 00 00``, ``06 40 00``, ``06 80 00``, ``06 C0 00``.

:class:`Mcp3204Reader` sends all channels in one pipelined bridge write per sample. A sample
whose reply is late, malformed or has a null bit set has no reading (None); the bridge
collects late replies and re-enters SPI mode itself (:class:`BusPirateSpi`), so a bad
exchange costs the samples it takes to put right, never a misread code.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

from flightcode.drivers.buspirate_protocol import encode_transfers
from flightcode.drivers.buspirate_spi import BusPirateSpi

RESOLUTION_CODES = 4096
START_BIT = 0x04
SINGLE_ENDED = 0x02
NULL_BIT = 0x10


def request(channel: int, single_ended: bool = True) -> bytes:
    """The 3 MOSI bytes converting ``channel`` (0..3)."""
    if not 0 <= channel <= 3:
        raise ValueError(f"MCP3204 channel {channel} (0..3)")
    return bytes((START_BIT | (SINGLE_ENDED if single_ended else 0), (channel & 0x3) << 6, 0x00))


def decode(miso: bytes) -> int | None:
    """The 12-bit code from the 3 MISO bytes; None if the null bit is not 0 or length wrong."""
    if len(miso) != 3 or miso[1] & NULL_BIT:
        return None
    return ((miso[1] & 0x0F) << 8) | miso[2]


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
        #: null_bit_errors, no_transfer (the bridge was busy: late reply owed or re-entering).
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
            codes.append(code)
        self.counters["reads"] += 1
        return tuple(codes)
