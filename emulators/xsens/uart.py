"""What a UART at the wrong baud rate receives (8N1, deterministic, bit-exact).

The transmitter sends ``data`` back to back at ``tx_baud`` (start bit 0, 8 data bits LSB
first, stop bit 1, line idle high before and after). The receiver runs at ``rx_baud``:
it waits for a falling edge, samples the start bit half a bit later (a high sample is a
glitch: it goes back to waiting), the data bits at 1.5 .. 8.5 bit times and the stop bit at
9.5; a low stop bit is a framing error, and Linux (termios without IGNPAR/PARMRK, as
pyserial sets it) delivers such a character as 0x00. After the stop sample it waits for
the next falling edge. A faster receiver sees more characters, a slower one fewer.

Times are integers in units of 1 / (tx_baud * rx_baud) s, so no rounding drifts.
"""

from __future__ import annotations

#: Value the Linux tty layer delivers for a character with a framing error.
FRAMING_ERROR_CHAR = 0x00


def _line_bits(data: bytes) -> bytearray:
    bits = bytearray()
    for byte in data:
        bits.append(0)
        bits.extend((byte >> i) & 1 for i in range(8))
        bits.append(1)
    return bits


def receive_at_wrong_baud(data: bytes, tx_baud: int, rx_baud: int) -> bytes:
    """Characters a receiver at ``rx_baud`` reads from ``data`` sent at ``tx_baud``."""
    if tx_baud == rx_baud or not data:
        return bytes(data)
    bits = _line_bits(data)
    n = len(bits)
    t_tx = rx_baud  # one transmitted bit, in time units
    t_rx = tx_baud  # one received bit, in time units

    def level(t: int) -> int:
        i = t // t_tx
        return bits[i] if i < n else 1

    out = bytearray()
    # Candidate falling edges are starts of 0 bits that follow a 1 bit (or idle).
    edges = [i for i in range(n) if bits[i] == 0 and (i == 0 or bits[i - 1] == 1)]
    earliest = 0
    for i in edges:
        t0 = i * t_tx
        if t0 < earliest:
            continue
        if level(t0 + t_rx // 2) != 0:  # glitch shorter than half a bit
            continue
        value = 0
        for k in range(8):
            value |= level(t0 + (2 * k + 3) * t_rx // 2) << k
        stop_ok = level(t0 + 19 * t_rx // 2) == 1
        out.append(value if stop_ok else FRAMING_ERROR_CHAR)
        earliest = t0 + 19 * t_rx // 2
    return bytes(out)
