"""SPIDriver on port ``adc-spidriver``, the MCP3204 on its SPI pins.

Byte-at-a-time like the firmware's ``service`` loop (firmware/main.fs): a transfer command
reads all its n MOSI bytes first, then clocks them and sends the n MISO bytes; a write
clocks each byte as it arrives. Every SPI byte (MOSI, then MISO for transfers) feeds the
CCITT CRC that the status line reports. ``x`` floats the outputs; the next ``s``, ``u``,
``a``, ``b`` or transfer drives them again. Unknown bytes are ignored.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from emulators.base import ByteDevice, DeviceEvent
from emulators.mcp3204 import Mcp3204
from emulators.spidriver.defs import CRC_INIT, STATUS_LEN, TRANSFER_BASE, WRITE_BASE, Cmd, crc16_ccitt
from emulators.spidriver.params import SpiDriverParams

#: SPI0CKR = SYSCLK / 500 kHz / 2 = 24 at SYSCLK 24.5 MHz: SCK = SYSCLK / (2 * 25).
SCK_HZ = 24_500_000 / 50


@dataclass(frozen=True, init=False)
class SpiDriverSpi(DeviceEvent):
    """One transfer (``miso`` filled) or write (``miso`` empty) command."""

    mosi: bytes
    miso: bytes

    def __init__(self, t_ns: int, mosi: bytes, miso: bytes) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "mosi", mosi)
        object.__setattr__(self, "miso", miso)


class SpiDriver(ByteDevice):
    """The SPIDriver bridge. ``adc`` is the MCP3204 on its SPI pins (may be shared)."""

    name = "adc-spidriver"

    def __init__(self, params: SpiDriverParams, adc: Mcp3204) -> None:
        super().__init__()
        self.params = params
        self.adc = adc
        self.crc = CRC_INIT
        self.mode = params.spi_mode & 3
        self.attached = True
        self.pin_a = 1  # 8051 port latches reset high
        self.pin_b = 1
        self.cs = 1  # /spi: unsel
        self._cont: Callable[[int, int], None] | None = None

    # -- ByteDevice --------------------------------------------------------------------
    def receive(self, data: bytes, t_ns: int) -> None:
        if self.host_baud is not None and self.host_baud != self.params.baud_bps:
            self.counters["bytes_at_wrong_baud"] += len(data)
            return
        self.counters["bytes_rx"] += len(data)
        for byte in data:
            if self._cont is not None:
                self._cont(byte, t_ns)
            else:
                self._dispatch(byte, t_ns)
        self._events.extend(self.adc.take_events())
        for key, value in self.adc.counters.items():  # the part's counters, under this port
            self.counters["mcp3204_" + key] = value

    # -- commands ----------------------------------------------------------------------
    def _dispatch(self, byte: int, t_ns: int) -> None:
        if byte >= TRANSFER_BASE:
            self._connect(t_ns)
            n = (byte & 0x3F) + 1
            if byte >= WRITE_BASE:
                self._write(n)
            else:
                self._transfer(n)
        elif byte == Cmd.STATUS:
            self._send(self.status_line(t_ns))
        elif byte == Cmd.ECHO:
            self._cont = self._echo
        elif byte in (Cmd.SELECT, Cmd.UNSELECT):
            self._connect(t_ns)
            self.cs = 0 if byte == Cmd.SELECT else 1
            self._drive_cs(t_ns)
        elif byte in (Cmd.SET_A, Cmd.SET_B):
            self._cont = lambda value, t: self._set_pin(byte, value, t)
        elif byte == Cmd.SET_MODE and self.params.product == "spidriver2":
            self._cont = self._set_mode
        elif byte == Cmd.DETACH:
            self.attached = False
            self.counters["detach"] += 1
        elif byte != Cmd.FLUSH:
            self.counters["ignored_bytes"] += 1

    def _echo(self, byte: int, t_ns: int) -> None:
        self._cont = None
        self._send(bytes([byte]))

    def _set_pin(self, which: int, value: int, t_ns: int) -> None:
        self._cont = None
        self._connect(t_ns)
        if which == Cmd.SET_A:
            self.pin_a = value & 1  # the firmware takes the LSB
        else:
            self.pin_b = value & 1

    def _set_mode(self, value: int, t_ns: int) -> None:
        self._cont = None
        if value > 3:
            self.counters["bad_mode_values"] += 1
        self.mode = value & 3
        if self.attached:
            self.adc.set_sck(self.mode >> 1, t_ns)

    def _transfer(self, n: int) -> None:
        mosi = bytearray()

        def cont(byte: int, t_ns: int) -> None:
            mosi.append(byte)
            if len(mosi) < n:
                return
            self._cont = None
            miso = self._xfer(bytes(mosi), t_ns)
            self.crc = crc16_ccitt(miso, crc16_ccitt(bytes(mosi), self.crc))
            self._send(miso)
            self.counters["transfers"] += 1
            self._event(SpiDriverSpi(t_ns, bytes(mosi), miso))

        self._cont = cont

    def _write(self, n: int) -> None:
        mosi = bytearray()

        def cont(byte: int, t_ns: int) -> None:
            mosi.append(byte)
            self.crc = crc16_ccitt(bytes([byte]), self.crc)
            self._xfer(bytes([byte]), t_ns)
            if len(mosi) == n:
                self._cont = None
                self.counters["writes"] += 1
                self._event(SpiDriverSpi(t_ns, bytes(mosi), b""))

        self._cont = cont

    # -- lines -------------------------------------------------------------------------
    def _connect(self, t_ns: int) -> None:
        """Drive the outputs (after ``x``); the part sees the CS latch and idle clock."""
        if self.attached:
            return
        self.attached = True
        self.adc.set_sck(self.mode >> 1, t_ns)
        self._drive_cs(t_ns)

    def _drive_cs(self, t_ns: int) -> None:
        if self.cs:
            self.adc.deselect(t_ns)
        else:
            self.adc.select(t_ns)

    def _xfer(self, mosi: bytes, t_ns: int) -> bytes:
        return self.adc.exchange(mosi, t_ns, self.mode, hiz_bit=0, f_sck_Hz=SCK_HZ)

    # -- status ------------------------------------------------------------------------
    def status_line(self, t_ns: int) -> bytes:
        """The 80-byte ``?`` reply, formatted like the firmware's ``info`` word."""
        p = self.params
        uptime_s = p.uptime_at_t0_s + max(t_ns, 0) // 1_000_000_000
        fields = [
            p.product,
            p.serial,
            f"{uptime_s % 1_000_000_000:09d}",
            f"{p.usb_voltage_V:.3f}",
            str(max(0, min(p.current_mA, 999))),
            f"{p.temperature_C:04.1f}",
            str(self.pin_a),
            str(self.pin_b),
            str(self.cs),
            f"{self.crc:04x}",
        ]
        if p.product == "spidriver2":
            fields.append(str(self.mode))
        body = "[" + " ".join(fields)
        return (body[: STATUS_LEN - 1].ljust(STATUS_LEN - 1) + "]").encode("ascii")
