"""The MCP3204 quantiser and its inverse.

DS21298E §6: digital output code = 4096 * VIN / VREF, truncated: code n covers
[n, n+1) LSB and full scale (4095) is reached at VREF - 1 LSB (the same transfer function
the sister part's datasheet, MCP3302 DS21697F §6.1, states in words). Inputs beyond the
range clip to 0 and 4095; in pseudo-differential mode IN+ < IN- reads 0.
"""

from __future__ import annotations

import math

from emulators.mcp3204.defs import FULL_SCALE_CODES, MAX_CODE


def quantize(vin_V: float, vref_V: float, offset_error_lsb: float = 0.0, gain_error_lsb: float = 0.0) -> int:
    """Code for an input of ``vin_V`` volts (IN+ - IN-) with reference ``vref_V``.

    A reference at or below 0 V leaves the SAR DAC at 0: every comparison says "above",
    so any positive input reads full scale.
    """
    if math.isnan(vin_V):
        return 0
    if vref_V <= 0.0:
        return MAX_CODE if vin_V > 0.0 else 0
    x = vin_V * FULL_SCALE_CODES / vref_V
    x = x * (1.0 + gain_error_lsb / FULL_SCALE_CODES) + offset_error_lsb
    if x <= 0.0:
        return 0
    if x >= MAX_CODE:
        return MAX_CODE
    return int(math.floor(x))


def code_center_V(code: int, vref_V: float) -> float:
    """Inverse of :func:`quantize` for an ideal part: the middle of code ``code``'s bin."""
    return (code + 0.5) * vref_V / FULL_SCALE_CODES


def lsb_V(vref_V: float) -> float:
    """One LSB in volts."""
    return vref_V / FULL_SCALE_CODES
