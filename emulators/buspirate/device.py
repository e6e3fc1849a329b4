"""Bus Pirate v3 (firmware v6.1) on port ``adc``: terminal, BBIO1 and SPI1, MCP3204 behind.

The firmware reads its UART one byte at a time, so does this model: commands may arrive
pipelined in one write or split across writes; a multi-byte command keeps a continuation
(``_cont``) that eats the following bytes, and a bulk transfer counts the data bytes it
still expects (``_bulk_left``). Replies go out as the firmware sends them: the 0x01 of a
bulk transfer at once, each MISO byte as its MOSI byte arrives; write-then-read answers only
after all its write bytes (and 0x00 at once if a length is out of range, after which the
firmware reads the would-be data bytes as commands, as here).

Speed: the data bytes of a bulk transfer that arrive together go to the MCP3204 in one
``exchange`` (the same edges at the same sim time as one byte at a time), and a whole
``02 1n <data> 03`` in one write is handled as one unit. ``BusPirate(..., fast_path=False)``
handles every byte on its own: the reference these are tested against
(tests/unit/adc/test_fastpath_equivalence.py).

Lines: in SPI mode the outputs start open-drain (HiZ); they can drive the MCP3204 only when
push-pull is configured (0x8x with w = 1), the pull-ups are on (0x4x with x = 1), or the
target board has its own pull-ups (params). Undriven, the part sees no edges and MISO reads
the floating level (0 without pull-ups). CKP/CKE select the SPI mode of the exchange; SMP
(sample at the end of the bit) changes nothing here: the MCP3204's DOUT still holds the old
bit at that edge.
"""

from __future__ import annotations

import re
from collections.abc import Callable

from emulators.buspirate.defs import (
    BBIO_VERSION,
    ERROR,
    MODE_VERSION,
    OK,
    PIN_DIR_FLAG,
    PIN_SET_FLAG,
    SPI_CON1_V61,
    SPI_CON1_V62,
    BbioCmd,
    Mode,
    SpiCmd,
    SpiGroup,
)
from emulators.buspirate.defs import (
    sck_Hz as con1_sck_Hz,
)
from emulators.buspirate.events import BusPirateUartRate
from emulators.buspirate.params import BusPirateParams
from emulators.buspirate.pins import Pins
from emulators.buspirate.spi import SpiMode
from emulators.buspirate.terminal import Terminal
from emulators.mcp3204 import Mcp3204

_SPI = Mode.SPI
_LAST_BULK = (SpiGroup.BULK << 4) | 0x0F
_MCP_PREFIX = "mcp3204_"


def _firmware_version(firmware: str) -> tuple[int, int]:
    """(major, minor) from e.g. ``"v6.1 r1676"``, as flashrom reads it; (0, 0) if unknown."""
    m = re.match(r"v(\d+)\D*(\d*)", firmware)
    return (int(m.group(1)), int(m.group(2) or 0)) if m else (0, 0)


class BusPirate(SpiMode):
    """The Bus Pirate bridge. ``adc`` is the MCP3204 on its SPI pins (may be shared)."""

    name = "adc"

    def __init__(self, params: BusPirateParams, adc: Mcp3204, *, fast_path: bool = True) -> None:
        super().__init__()
        self.params = params
        self.adc = adc
        #: False: every received byte is handled on its own (the reference for batching).
        self.fast_path = fast_path
        self.terminal = Terminal(params)
        self.mode = Mode.TERMINAL
        self._fw = _firmware_version(params.firmware)
        self._cont: Callable[[int, int], None] | None = None
        self._args = bytearray()
        self._need = 0
        self._spi_log: tuple[bytearray, bytearray] | None = None
        self._bulk_left = 0  # data bytes the current bulk transfer still expects
        self._adc_keys: dict[str, str] = {}  # MCP3204 counter -> its name under this port
        table = SPI_CON1_V62 if self._fw >= (6, 2) else SPI_CON1_V61
        self._sck_Hz_by_code = tuple(con1_sck_Hz(con1) for con1 in table)
        self._other_version = b""
        self._stream_t0_ns = 0
        self._stream_sent = 0
        self.pins = Pins(params.target_pullups)
        #: the PC-side UART's rate in bit/s: the power-up rate until the ``b`` menu changes it
        self.uart_baud_bps = params.baud_bps
        self._reset_spi()
        self._send(self.terminal.reset())  # power-up banner (flushed by the host's open)
        self.terminal.take_baud_change()

    # -- ByteDevice --------------------------------------------------------------------
    def receive(self, data: bytes, t_ns: int) -> None:
        if self.host_baud is not None and self.host_baud != self.uart_baud_bps:
            # Wrong line rate: the PIC's UART sees framing errors and drops the bytes.
            self.counters["bytes_at_wrong_baud"] += len(data)
            return
        self.counters["bytes_rx"] += len(data)
        i, n = 0, len(data)
        while i < n:
            left = self._bulk_left
            if left:  # bulk data: every byte of it that arrived together, or just one
                chunk = data[i : i + left] if self.fast_path else data[i : i + 1]
                i += len(chunk)
                self._bulk_data(chunk, t_ns)
                continue
            byte = data[i]
            i += 1
            if self._cont is not None:
                self._cont(byte, t_ns)
            elif self.mode is _SPI and self.fast_path and byte <= _LAST_BULK:
                if byte == SpiCmd.CS_LOW:
                    end = self._pipelined_transfer(data, i, t_ns)
                    if end:
                        i = end
                        continue
                self._spi_transaction_byte(byte, t_ns)
            else:
                self._dispatch(byte, t_ns)
        events = self.adc.take_events()
        if events:
            self._events.extend(events)
        counters, names = self.counters, self._adc_keys
        for key, value in self.adc.counters.items():  # the part's counters, under this port
            name = names.get(key)
            if name is None:
                name = names[key] = _MCP_PREFIX + key
            counters[name] = value

    def advance(self, t_ns: int) -> None:
        if self.mode is Mode.ADC_STREAM:  # two bytes per reading, as fast as the UART goes
            byte_ns = 10 * 1_000_000_000 // self.uart_baud_bps  # 8N1
            due = (t_ns - self._stream_t0_ns) // (2 * byte_ns)
            n = max(0, min(due - self._stream_sent, 2048))
            self._send(b"\x00\x00" * n)  # the probe input is not connected: 0 counts
            self._stream_sent += n

    # -- dispatch ----------------------------------------------------------------------
    def _dispatch(self, byte: int, t_ns: int) -> None:
        mode = self.mode
        if mode is Mode.TERMINAL:
            out, binary = self.terminal.feed(byte)
            self._send(out)
            self._follow_terminal_baud(t_ns)
            if binary:
                self._enter_bbio(t_ns)
        elif mode is Mode.BBIO:
            self._bbio(byte, t_ns)
        elif mode is Mode.SPI:
            self._spi(byte, t_ns)
        elif mode is Mode.OTHER:
            self._other(byte, t_ns)
        elif mode is Mode.SELFTEST:
            self._selftest(byte, t_ns)
        elif mode is Mode.ADC_STREAM:
            self._set_mode(Mode.BBIO, t_ns)  # any byte ends the stream (and is consumed)
        elif mode is Mode.SNIFF:
            self._set_mode(Mode.SPI, t_ns)  # any byte ends the sniffer (and is consumed)

    def _follow_terminal_baud(self, t_ns: int) -> None:
        """Switch the UART after the terminal's confirmation went out at the old rate: from
        now on the host must talk at the new rate (it changes its termios; the pty tells
        us through ``line_settings_changed``), else its bytes are framing errors."""
        baud = self.terminal.take_baud_change()
        if baud is not None and baud != self.uart_baud_bps:
            self.uart_baud_bps = baud
            self.counters["uart_rate_changes"] += 1
            self._event(BusPirateUartRate(t_ns, baud))

    # -- bitbang mode (binIO.c binBB) -----------------------------------------------------
    def _enter_bbio(self, t_ns: int) -> None:
        self.pins.reset()
        self._set_mode(Mode.BBIO, t_ns)
        self._send(BBIO_VERSION)

    def _bbio(self, byte: int, t_ns: int) -> None:
        if byte & PIN_SET_FLAG:
            self._send(bytes([self.pins.set_levels(byte, self.adc, t_ns)]))
            return
        if byte == BbioCmd.RESET_BBIO:
            self._send(BBIO_VERSION)
        elif byte == BbioCmd.SPI:
            self.pins.reset()
            self._set_mode(Mode.SPI, t_ns)
            self._reset_spi()
            self._apply_lines(t_ns)
            self._send(MODE_VERSION[BbioCmd.SPI])
        elif byte in MODE_VERSION:
            self.pins.reset()
            self._other_version = MODE_VERSION[BbioCmd(byte)]
            self.counters["unemulated_mode_entries"] += 1
            self._set_mode(Mode.OTHER, t_ns)
            self._send(self._other_version)
        elif byte == BbioCmd.RESET_TO_TERMINAL:
            self._send(bytes([OK]))
            self.pins.reset()
            self._set_mode(Mode.TERMINAL, t_ns)
            self._send(self.terminal.reset())
            self._follow_terminal_baud(t_ns)
        elif byte in (BbioCmd.SELFTEST_SHORT, BbioCmd.SELFTEST_FULL):
            self._set_mode(Mode.SELFTEST, t_ns)
            self._send(bytes([self.params.selftest_errors & 0xFF]))
        elif byte == BbioCmd.PWM_SETUP:
            self._collect(5, lambda args, t: self._send(bytes([OK])))
        elif byte == BbioCmd.PWM_CLEAR:
            self._send(bytes([OK]))
        elif byte == BbioCmd.ADC_MEASURE:
            self._send(b"\x00\x00")  # nothing on the ADC probe pin
        elif byte == BbioCmd.ADC_CONTINUOUS:
            self._stream_t0_ns, self._stream_sent = t_ns, 0
            self._set_mode(Mode.ADC_STREAM, t_ns)
        elif byte == BbioCmd.FREQ_MEASURE:
            self._send(b"\x00\x00\x00\x00")  # no signal on AUX
        elif byte & PIN_DIR_FLAG:
            self._send(bytes([self.pins.set_direction(byte, self.adc, t_ns)]))
        else:
            self._send(bytes([ERROR]))
            self._error(t_ns, "unknown_bbio_command", byte)

    def _selftest(self, byte: int, t_ns: int) -> None:
        if byte == 0xFF:
            self._send(bytes([OK]))
            self._set_mode(Mode.BBIO, t_ns)
        else:
            self._send(bytes([(byte + self.params.selftest_errors) & 0xFF]))

    def _other(self, byte: int, t_ns: int) -> None:
        if byte == 0x00:
            self.pins.reset()
            self._set_mode(Mode.BBIO, t_ns)
            self._send(BBIO_VERSION)
        elif byte == 0x01:
            self._send(self._other_version)
        else:
            self.counters["unemulated_mode_bytes"] += 1
