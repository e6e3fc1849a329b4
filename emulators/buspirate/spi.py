"""The Bus Pirate's binary SPI mode (firmware SPI.c binSPI), the base of
:class:`emulators.buspirate.device.BusPirate`: the SPI settings and lines, bulk transfers,
write-then-read, and the binary modes' argument collection and errors. The UART, the
terminal, bitbang mode and the dispatch between modes are the subclass's.
"""

from __future__ import annotations

from collections.abc import Callable

from emulators.base import ByteDevice
from emulators.buspirate.defs import (
    BBIO_VERSION,
    ERROR,
    MODE_VERSION,
    OK,
    BbioCmd,
    Mode,
    PeripheralBit,
    SpiCmd,
    SpiConfigBit,
    SpiGroup,
    spi_mode_number,
)
from emulators.buspirate.events import BusPirateModeChanged, BusPirateProtocolError, BusPirateSpi
from emulators.buspirate.params import BusPirateParams
from emulators.buspirate.pins import Pins
from emulators.mcp3204 import Mcp3204

_OK_BYTE = bytes([OK])
_OK_OK = _OK_BYTE * 2


class SpiMode(ByteDevice):
    """Binary SPI mode on the MCP3204 ``adc``; the state below is set up by the subclass."""

    params: BusPirateParams
    adc: Mcp3204
    pins: Pins
    mode: Mode
    _cont: Callable[[int, int], None] | None
    _args: bytearray
    _need: int
    _spi_log: tuple[bytearray, bytearray] | None
    _bulk_left: int
    _sck_Hz_by_code: tuple[float, ...]

    # -- the binary modes' plumbing ------------------------------------------------------
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
