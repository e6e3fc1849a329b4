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
from dataclasses import dataclass

from emulators.base import ByteDevice, DeviceEvent
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
    PeripheralBit,
    SpiCmd,
    SpiConfigBit,
    SpiGroup,
    spi_mode_number,
)
from emulators.buspirate.defs import (
    sck_Hz as con1_sck_Hz,
)
from emulators.buspirate.params import BusPirateParams
from emulators.buspirate.pins import Pins
from emulators.buspirate.terminal import Terminal
from emulators.mcp3204 import Mcp3204

_OK_BYTE = bytes([OK])
_OK_OK = _OK_BYTE * 2
_SPI = Mode.SPI
_LAST_BULK = (SpiGroup.BULK << 4) | 0x0F
_MCP_PREFIX = "mcp3204_"


@dataclass(frozen=True)
class BusPirateModeChanged(DeviceEvent):
    mode: str


@dataclass(frozen=True)
class BusPirateProtocolError(DeviceEvent):
    """A command the firmware rejects or tolerates; ``byte`` is the offending byte."""

    what: str
    byte: int


@dataclass(frozen=True)
class BusPirateUartRate(DeviceEvent):
    """The PC-side UART changed its rate (terminal ``b`` menu, or back after a reset)."""

    baud_bps: int


@dataclass(frozen=True, init=False)
class BusPirateSpi(DeviceEvent):
    """One bulk transfer or write-then-read on the SPI pins."""

    mosi: bytes
    miso: bytes

    def __init__(self, t_ns: int, mosi: bytes, miso: bytes) -> None:
        # written out: compiled, unlike the one @dataclass generates (docs/performance.md, eighth round)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "mosi", mosi)
        object.__setattr__(self, "miso", miso)


def _firmware_version(firmware: str) -> tuple[int, int]:
    """(major, minor) from e.g. ``"v6.1 r1676"``, as flashrom reads it; (0, 0) if unknown."""
    m = re.match(r"v(\d+)\D*(\d*)", firmware)
    return (int(m.group(1)), int(m.group(2) or 0)) if m else (0, 0)


class BusPirate(ByteDevice):
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

    def _set_mode(self, mode: Mode, t_ns: int) -> None:
        if mode is not self.mode:
            self.mode = mode
            self._event(BusPirateModeChanged(t_ns, mode.name))

    def _error(self, t_ns: int, what: str, byte: int) -> None:
        self.counters["protocol_errors"] += 1
        self.counters[what] += 1
        self._event(BusPirateProtocolError(t_ns, what, byte))

    def _collect(self, n: int, then: Callable[[bytes, int], None]) -> None:
        """Read ``n`` argument bytes, then call ``then(args, t_ns)``."""
        self._args = bytearray()
        self._need = n

        def cont(byte: int, t_ns: int) -> None:
            self._args.append(byte)
            if len(self._args) >= self._need:
                self._cont = None
                then(bytes(self._args), t_ns)

        self._cont = cont

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

    # -- SPI mode (SPI.c binSPI) ------------------------------------------------------------
    def _reset_spi(self) -> None:
        """binSPI() defaults: 125 kHz (code 1), CKP 0, CKE 1, SMP 0, HiZ outputs, CS high."""
        self._speed = 1
        self._config: int = SpiConfigBit.CKE  # 0010: HiZ, idle low, active-to-idle, middle
        self._cs_latch = 1
        self._periph = 0

    @property
    def spi_mode(self) -> int:
        """SPI mode number the current config gives the MCP3204."""
        return spi_mode_number(self._config)

    @property
    def sck_Hz(self) -> float:
        """SCK of the current speed code (the firmware version selects the divider table)."""
        return self._sck_Hz_by_code[self._speed]

    def _lines_driven(self) -> bool:
        return bool(self._config & SpiConfigBit.PUSH_PULL) or self.pins.pulled_up

    def _apply_lines(self, t_ns: int) -> None:
        """Bring the part's CS and idle clock in line with the SPI settings."""
        if not self._lines_driven():
            return
        self.adc.set_sck(1 if self._config & SpiConfigBit.CKP else 0, t_ns)
        if self._cs_latch:
            self.adc.deselect(t_ns)
        else:
            self.adc.select(t_ns)

    def _xfer(self, mosi: bytes, t_ns: int) -> bytes:
        if not self._lines_driven():
            self.counters["spi_bytes_lines_undriven"] += len(mosi)
            return bytes(len(mosi))
        return self.adc.exchange(mosi, t_ns, spi_mode_number(self._config), hiz_bit=int(self.pins.pullups),
                                 f_sck_Hz=self._sck_Hz_by_code[self._speed])

    def _spi(self, byte: int, t_ns: int) -> None:
        group = byte >> 4
        if group == SpiGroup.SETUP:
            self._spi_setup(byte, t_ns)
        elif group == SpiGroup.BULK:
            self._out += _OK_BYTE
            self._spi_log = (bytearray(), bytearray())
            self._bulk_left = (byte & 0x0F) + 1
        elif group == SpiGroup.PERIPHERALS:
            self._periph = byte & 0x0F
            self.pins.power = bool(byte & PeripheralBit.POWER)
            self.pins.pullups = bool(byte & PeripheralBit.PULLUPS)
            self.pins.aux = 1 if byte & PeripheralBit.AUX else 0
            self._cs_latch = 1 if byte & PeripheralBit.CS else 0
            self._apply_lines(t_ns)
            self._send(bytes([OK]))
        elif group == SpiGroup.SPEED and not byte & 0x08:
            self._speed = byte & 0x07
            self._send(bytes([OK]))
        elif group == SpiGroup.CONFIG:
            self._config = byte & 0x0F
            self._apply_lines(t_ns)
            self._send(bytes([OK]))
        elif self.params.readback_commands and byte in (0x50, 0x70, 0x90):
            value = {0x50: 0x40 | self._periph, 0x70: 0x60 | self._speed, 0x90: 0x80 | self._config}[byte]
            self._send(bytes([value]))
        else:
            self._send(bytes([ERROR]))
            self._error(t_ns, "unknown_spi_command", byte)

    def _pipelined_transfer(self, data: bytes, i: int, t_ns: int) -> int:
        """``02 1n <n+1 bytes> 03`` whole at ``data[i - 1:]``: handled as one unit (the same
        effects, replies and event as its six commands one by one); returns the index after
        it, or 0 (nothing done) if ``data`` does not hold exactly that."""
        if i >= len(data) or data[i] >> 4 != SpiGroup.BULK:
            return 0
        end = i + 2 + (data[i] & 0x0F)  # index of the 03
        if end >= len(data) or data[end] != SpiCmd.CS_HIGH:
            return 0
        mosi = data[i + 1 : end]
        self._cs_latch = 0
        self._apply_lines(t_ns)
        miso = self._xfer(mosi, t_ns)
        self._cs_latch = 1
        self._apply_lines(t_ns)
        out = self._out
        out += _OK_OK
        out += miso
        out += _OK_BYTE
        self.counters["bulk_transfers"] += 1
        self._event(BusPirateSpi(t_ns, bytes(mosi), miso))
        return end + 1

    def _spi_transaction_byte(self, byte: int, t_ns: int) -> None:
        """The SPI commands of a transaction (00..1F: setup, CS, bulk), fewer calls deep
        than :meth:`_spi`: same effect."""
        if byte == SpiCmd.CS_LOW or byte == SpiCmd.CS_HIGH:
            self._cs_latch = byte & 1  # 02 -> 0 (low), 03 -> 1 (high)
            self._apply_lines(t_ns)
            self._out += _OK_BYTE
        elif byte >> 4 == SpiGroup.BULK:
            self._out += _OK_BYTE
            self._spi_log = (bytearray(), bytearray())
            self._bulk_left = (byte & 0x0F) + 1
        else:
            self._spi_setup(byte, t_ns)

    def _spi_setup(self, byte: int, t_ns: int) -> None:
        if byte == SpiCmd.EXIT:
            self.pins.reset()
            self._set_mode(Mode.BBIO, t_ns)
            self._send(BBIO_VERSION)
        elif byte == SpiCmd.VERSION:
            self._send(MODE_VERSION[BbioCmd.SPI])
        elif byte in (SpiCmd.CS_LOW, SpiCmd.CS_HIGH):
            self._cs_latch = 0 if byte == SpiCmd.CS_LOW else 1
            self._apply_lines(t_ns)
            self._send(bytes([OK]))
        elif byte in (SpiCmd.WRITE_THEN_READ, SpiCmd.WRITE_THEN_READ_NO_CS):
            self._collect(4, lambda args, t: self._wtr_lengths(byte, args, t))
        elif byte in (SpiCmd.SNIFF_ALL, SpiCmd.SNIFF_CS_LOW):
            self._send(bytes([OK]))
            self._set_mode(Mode.SNIFF, t_ns)  # no other master on this bus: nothing to show
        else:
            self._send(bytes([ERROR]))
            self._error(t_ns, "unknown_spi_command", byte)

    def _bulk_data(self, mosi: bytes, t_ns: int) -> None:
        """Data bytes of the current bulk transfer (one MISO byte answers each)."""
        miso = self._xfer(mosi, t_ns)
        self._out += miso
        log = self._spi_log
        assert log is not None
        log[0].extend(mosi)
        log[1].extend(miso)
        self._bulk_left -= len(mosi)
        if not self._bulk_left:
            self.counters["bulk_transfers"] += 1
            self._event(BusPirateSpi(t_ns, bytes(log[0]), bytes(log[1])))
            self._spi_log = None

    def _wtr_lengths(self, cmd: int, args: bytes, t_ns: int) -> None:
        n_write = args[0] << 8 | args[1]
        n_read = args[2] << 8 | args[3]
        limit = self.params.write_then_read_max_bytes
        if n_write > limit or n_read > limit:
            self._send(bytes([ERROR]))
            self._error(t_ns, "write_then_read_bad_length", cmd)
            return
        if n_write == 0:
            self._wtr_run(cmd, b"", n_read, t_ns)
        else:
            self._collect(n_write, lambda data, t: self._wtr_run(cmd, data, n_read, t))

    def _wtr_run(self, cmd: int, data: bytes, n_read: int, t_ns: int) -> None:
        with_cs = cmd == SpiCmd.WRITE_THEN_READ
        if with_cs:
            self._cs_latch = 0
            self._apply_lines(t_ns)
        self._xfer(data, t_ns)
        miso = self._xfer(b"\xff" * n_read, t_ns)  # the firmware reads by sending 0xFF
        if with_cs:
            self._cs_latch = 1
            self._apply_lines(t_ns)
        self.counters["write_then_reads"] += 1
        self._event(BusPirateSpi(t_ns, bytes(data) + b"\xff" * n_read, miso))
        self._send(bytes([OK]) + miso)
