"""Register-level, sans-I/O models of the NXP LPC2148's peripherals (UM10139, the LPC214x user
manual, cited per module), for running the flight firmware's ARM build on an emulated core.

The API, in one place::

    from emulators.lpc2148 import Lpc2148
    board = Lpc2148()                      # reset state; ScbParams: crystal, PLL lock time, MEMMAP

    # the core, on an MMIO access (address, width in bytes, its CCLK cycle count):
    value = board.read(0xE000C014, 1, cycle)
    board.write(0xE01FC08C, 0xAA, 4, cycle)

    # the core, between instruction slices:
    board.advance_to(cycle)                # let peripheral time pass
    board.irq_request, board.fiq_request   # nIRQ / nFIQ asserted by the VIC
    board.sleeping                         # PCON.IDL: nothing to run until an interrupt
    board.next_event_cycle()               # the next change a read could see (None: nothing scheduled)
    board.next_irq_cycle()                 # the next cycle an interrupt request may change: run or idle to here
    board.schedule_changed                 # an access or input moved the above: ask again (the core clears it)
    board.cclk_hz, board.t_ns              # the clock the PLL gives, nanoseconds since reset
    board.scb.memmap, board.scb.mamcr, board.scb.mamtim   # for the core's memory and cycle model

    # the bench, at the pins (CCLK cycles):
    board.uart_line_in(0, b"...", cycle, baud=115200)   # device bytes into RXD0, paced
    board.take_uart_tx(1)                  # bytes out of TXD1 with their line times
    board.pin_edge(0, 10, True, cycle)     # e.g. the PPM line on CAP1.0 (P0.10)
    board.attach_spi_slave(fn)             # fn(mosi, SpiTransfer) -> miso, the MCP3204
    board.watch_gpio(0, 20, fn)            # fn(level, cycle): a chip select on P0.20
    board.take_pwm(), board.pwm_outputs_us()   # pulse widths for the ESC models
    board.take_spi()                       # SPI words for recording

Models, each usable alone with ``read(offset, tick)`` / ``write(offset, value, tick)`` /
``advance_to(tick)`` / ``next_event()`` / ``next_irq_event()`` / ``irq`` (regs.py): :class:`Vic`, :class:`Timer`,
:class:`Pwm`, :class:`Uart`, :class:`Spi`, :class:`Gpio`, :class:`PinSelect`,
:class:`SystemControl`. The serial line sampler (:mod:`~emulators.lpc2148.line`) is shared with
the bench for the device side of a UART.

Every access outside the models is an error: :class:`UnmodelledRegister` (an address no
model has), :class:`RegisterAccessError` (a write-only register read, a read-only one written,
a powered-off peripheral, a reserved pin function, a sub-word write at a byte lane),
:class:`NotModelled` (a mode the models do not implement). What is and is not modelled:
docs/board.md, Peripherals.
"""

from emulators.lpc2148.board import Lpc2148, PwmPulse, SpiWord, UartTx
from emulators.lpc2148.bus import Lpc2148Bus
from emulators.lpc2148.errors import Lpc2148Error, NotModelled, RegisterAccessError, UnmodelledRegister
from emulators.lpc2148.gpio import Gpio, PinChange
from emulators.lpc2148.line import FORMAT_8N1, FrameFormat, LineFrame, LineReceiver, Parity
from emulators.lpc2148.pinsel import PinSelect
from emulators.lpc2148.pwm import Pwm, PwmOutput
from emulators.lpc2148.regs import VicChannel
from emulators.lpc2148.scb import ScbParams, SystemControl
from emulators.lpc2148.spi import Spi, SpiTransfer
from emulators.lpc2148.timer import Timer
from emulators.lpc2148.uart import Uart
from emulators.lpc2148.vic import Vic

__all__ = [
    "FORMAT_8N1", "FrameFormat", "Gpio", "LineFrame", "LineReceiver", "Lpc2148", "Lpc2148Bus", "Lpc2148Error",
    "NotModelled", "Parity", "PinChange", "PinSelect", "Pwm", "PwmOutput", "PwmPulse", "RegisterAccessError",
    "ScbParams", "Spi", "SpiTransfer", "SpiWord", "SystemControl", "Timer", "Uart", "UartTx", "UnmodelledRegister",
    "Vic", "VicChannel",
]
