"""Byte-level layouts of the MCP3204 protocol, for whole-byte exchanges in SPI modes 0,0 and 1,1.

The clock-level model (device.py) plays every SCK edge; at 8 edges per byte that is most of
the bench's ADC time. In the two modes the part supports, a whole MOSI byte has an effect
that depends only on the command phase the part is in and the byte itself, so it is
computed once per (SPI mode, phase, byte) here, by walking the datasheet's clock rules
(DS21298E §5.0/§6.0, the rules device.py implements edge by edge):

* mode 0,0: per clock the master sets DIN, samples DOUT, then the rising edge (the part
  latches DIN) and the falling edge (the part shifts DOUT);
* mode 1,1: per clock the falling edge comes first, then DIN, the master's sample, and the
  rising edge.

The sample is taken on the falling edge in the HOLD phase; from then on DOUT carries the
null bit, B11..B0, B1..B11, then zeros: :func:`output_word` packs that sequence into an int
so the MISO bits of any clock window are one shift and mask.
"""

from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

from emulators.mcp3204.defs import RESOLUTION_BITS, RISING_NEXT, Phase, output_bits

#: Bits in the DOUT sequence after the sample: null, B11..B0, B1..B11.
OUTPUT_SEQUENCE_BITS = 1 + RESOLUTION_BITS + (RESOLUTION_BITS - 1)

#: Phases of a CS-low frame before the part drives DOUT (where a byte's effect is tabulated).
COMMAND_PHASES = (Phase.WAIT_START, Phase.SGL_DIFF, Phase.D2, Phase.D1, Phase.D0, Phase.SAMPLE, Phase.HOLD)


class CommandStep(NamedTuple):
    """What eight clocks of one MOSI byte do to a part in a command phase."""

    phase: Phase  #: phase after the byte (OUTPUT once the sample has been taken)
    sgl: int  #: SGL/DIFF latched during the byte, -1 if none
    d_count: int  #: D2/D1/D0 bits latched during the byte (0..3)
    d_bits: int  #: their values, the first latched in the highest bit
    sampled: bool  #: the sample was taken (falling edge in HOLD) during the byte
    #: DOUT bits the master read after the sample: the low ``out_bits`` bits of the MISO
    #: byte are the first ``out_bits`` bits of the output sequence, the bits above them
    #: were read while DOUT was hi-Z. The part's bit position afterwards is
    #: ``out_bits - cpol`` (mode 1,1 reads after the shifting edge).
    out_bits: int


def command_step(phase: Phase, byte: int, cpol: int) -> CommandStep:
    """Walk the eight clocks of ``byte`` (MSB first) in mode 0,0 (cpol 0) or 1,1 (cpol 1)."""
    if phase not in COMMAND_PHASES:
        raise ValueError(f"{phase} is not a command phase")
    sgl, d_count, d_bits, sampled, out_bits = -1, 0, 0, False, 0
    for i in range(7, -1, -1):
        din = (byte >> i) & 1
        if cpol and phase is Phase.HOLD:  # mode 1,1: the falling edge opens the clock
            phase, sampled = Phase.OUTPUT, True
        if sampled:
            out_bits += 1  # the master samples a driven DOUT
        # rising edge: the part latches DIN
        if phase is Phase.WAIT_START:
            if din:
                phase = Phase.SGL_DIFF
        elif phase is Phase.SGL_DIFF:
            sgl, phase = din, Phase.D2
        elif phase in (Phase.D2, Phase.D1, Phase.D0):
            d_count, d_bits, phase = d_count + 1, (d_bits << 1) | din, RISING_NEXT[phase]
        elif phase is Phase.SAMPLE:
            phase = Phase.HOLD
        # (OUTPUT: DIN is don't care; the B0 checks cannot apply before bit 12)
        if not cpol and phase is Phase.HOLD:  # mode 0,0: the falling edge closes the clock
            phase, sampled = Phase.OUTPUT, True
    return CommandStep(phase, sgl, d_count, d_bits, sampled, out_bits)


def _command_table(cpol: int) -> dict[Phase, tuple[CommandStep, ...]]:
    return {phase: tuple(command_step(phase, b, cpol) for b in range(256)) for phase in COMMAND_PHASES}


#: ``COMMAND_STEPS[cpol][phase][byte]``: every command-phase byte in modes 0,0 and 1,1.
COMMAND_STEPS: tuple[dict[Phase, tuple[CommandStep, ...]], dict[Phase, tuple[CommandStep, ...]]] = (
    _command_table(0),
    _command_table(1),
)

#: 11-bit reversal: B1..B11 LSB first is the reversal of ``code >> 1``.
_REV11 = tuple(int(f"{x:011b}"[::-1], 2) for x in range(1 << (RESOLUTION_BITS - 1)))


def output_word(code: int) -> int:
    """The DOUT sequence of ``code`` as a 24-bit int, sequence bit 0 (the null bit) at bit 23.

    Bits ``a .. a+k-1`` of the sequence are ``(word << 8) >> (32 - a - k) & (2**k - 1)``;
    past bit 23 the part shifts out zeros.
    """
    return (code << (RESOLUTION_BITS - 1)) | _REV11[code >> 1]


@lru_cache(maxsize=1 << RESOLUTION_BITS)
def output_bits_cached(code: int) -> tuple[int, ...]:
    """:func:`~emulators.mcp3204.defs.output_bits`, memoised (a pure function of 4096 codes)."""
    return output_bits(code)
