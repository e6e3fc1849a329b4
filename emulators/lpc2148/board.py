"""The LPC2148 at its pins: what the bench connects to the peripheral bus.

:class:`Lpc2148` is the bus (bus.py) plus the outside world's side of each wire, in CCLK cycles
and nanoseconds: pin edges in (capture inputs, external interrupts, SSEL0, GPIO inputs),
device bytes into a UART's RXD at the device's baud, and what comes out: UART bytes with their
line times, SPI exchanges, PWM pulse widths, GPIO output changes.

A function reaches a pin only while PINSEL selects it there (UM10139 Rev. 4, chapter 6): bytes
sent to RXD0 while P0.1 is a GPIO are lost and counted, TX bytes while P0.0 is not TXD0 are
dropped and counted, a PWM channel's pulses reach the ESC only while one of its pins is PWMn.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

from emulators.lpc2148.bus import APB_SLOT, Lpc2148Bus
from emulators.lpc2148.gpio import PinWatcher
from emulators.lpc2148.line import FORMAT_8N1, FrameFormat
from emulators.lpc2148.pinsel import PINSEL_BASE, pins_with
from emulators.lpc2148.pwm import CHANNELS as PWM_CHANNELS
from emulators.lpc2148.scb import ScbParams
from emulators.lpc2148.uart import Uart

#: (UART, its TXD function, its RXD function)
_UART_PINS = {0: ("TXD0", "RXD0"), 1: ("TXD1", "RXD1")}


@dataclass(frozen=True)
class UartTx:
    """A byte UART``uart`` sent on its TXD pin, on the line from ``start_cycle`` to ``end_cycle``
    (``start_ns``..``end_ns``) at ``baud`` bit/s in format ``fmt``."""

    uart: int
    value: int
    start_cycle: int
    end_cycle: int
    start_ns: int
    end_ns: int
    baud: float
    fmt: FrameFormat


@dataclass(frozen=True)
class PwmPulse:
    """From ``cycle`` (``t_ns``) on, PWM channel ``channel`` (1-6) gives ``pulse_us`` high every
    ``period_us`` (0, 0: no pulses)."""

    cycle: int
    t_ns: int
    channel: int
    pulse_us: float
    period_us: float


@dataclass(frozen=True)
class SpiWord:
    """One SPI0 transfer: ``mosi`` out, ``miso`` in, from ``start_cycle`` to ``end_cycle``."""

    start_cycle: int
    end_cycle: int
    mosi: int
    miso: int


class Lpc2148(Lpc2148Bus):
    """The modelled LPC2148 with its pins."""

    def __init__(self, params: ScbParams = ScbParams()) -> None:
        super().__init__(params)
        self.counters: Counter[str] = Counter()
        self._pwm_pinned = {ch: False for ch in PWM_CHANNELS}
        self._pwm_pending: list[PwmPulse] = []

    def write(self, address: int, value: int, width: int, cycle: int) -> None:
        super().write(address, value, width, cycle)
        if address & ~(APB_SLOT - 1) == PINSEL_BASE:  # a PWM channel put on or taken off its pin
            outputs = self.pwm.outputs()
            for ch, was in self._pwm_pinned.items():
                now = bool(self.pinsel.selected(f"PWM{ch}"))
                if now != was:
                    self._pwm_pinned[ch] = now
                    high, period = outputs[ch] if now else (0, 0)
                    self._pwm_pending.append(PwmPulse(self.cycle, self.t_ns, ch, self._us(high), self._us(period)))

    # -- in -----------------------------------------------------------------------------------
    def pin_edge(self, port: int, pin: int, level: bool, cycle: int) -> None:
        """The outside drives P``port``.``pin`` to ``level`` from ``cycle`` on."""
        self.advance_to(cycle)
        self.gpio.drive(port, pin, level)
        function = self.pinsel.function(port, pin)
        if function.startswith("CAP"):
            timer = self.timer0 if function[3] == "0" else self.timer1
            timer.set_capture_input(int(function[5]), level, self.model_tick(timer))
        elif function.startswith("EINT"):
            self.scb.set_eint(int(function[4]), level)
        elif function == "SSEL0":
            self.spi0.set_ssel(level, self.model_tick(self.spi0))
        self._update_lines()
        for slot in self._slots:
            slot.stale = True
        self._due = self._next_due()
        self.schedule_changed = True

    def uart_line_in(self, uart: int, data: bytes, cycle: int, baud: float, fmt: FrameFormat = FORMAT_8N1) -> None:
        """A device starts sending ``data`` to UART``uart``'s RXD at ``cycle``, at its own
        ``baud`` and format, each byte after the previous one."""
        self.advance_to(cycle)
        model = self._uart(uart)
        rxd = _UART_PINS[uart][1]
        if not self.pinsel.selected(rxd):
            self.counters[f"uart{uart}_rx_pin_not_selected"] += len(data)
            return
        if not self.scb.powered(self.apb[model.base].pconp):
            self.counters[f"uart{uart}_rx_powered_off"] += len(data)
            return
        slot = self.apb[model.base]
        tick = self.time.pclk_exact(cycle) - slot.offset
        model.line_in(data, tick, self.time.pclk_hz / baud, fmt)
        self._update_lines()
        self._rescheduled(slot)

    def _uart(self, uart: int) -> Uart:
        return self.uart0 if uart == 0 else self.uart1

    def watch_gpio(self, port: int, pin: int, watcher: PinWatcher) -> None:
        """Call ``watcher(level, cycle)`` when GPIO output P``port``.``pin`` changes."""
        self.gpio.watchers[(port, pin)] = watcher

    # -- out ----------------------------------------------------------------------------------
    def take_uart_tx(self, uart: int) -> list[UartTx]:
        """The bytes UART``uart`` sent since the last call (those while its TXD pin was not
        selected are dropped and counted)."""
        model = self._uart(uart)
        sent = model.take_tx()
        if not sent:
            return []
        if not self.pinsel.selected(_UART_PINS[uart][0]):
            self.counters[f"uart{uart}_tx_pin_not_selected"] += len(sent)
            return []
        out = []
        for b in sent:
            start, end = self.cycle_of(model, b.start), self.cycle_of(model, b.end)
            out.append(UartTx(uart, b.value, start, end, self.time.ns_at(start), self.time.ns_at(end),
                              self.time.pclk_hz / b.bit_ticks, b.fmt))
        return out

    def take_pwm(self) -> list[PwmPulse]:
        """PWM output changes since the last call, for the channels selected on a pin."""
        out, self._pwm_pending = self._pwm_pending, []
        for change in self.pwm.take_changes():
            if not self.pinsel.selected(f"PWM{change.channel}"):
                continue
            cycle = self.cycle_of(self.pwm, change.tick)
            out.append(PwmPulse(cycle, self.time.ns_at(cycle), change.channel, self._us(change.high_ticks),
                                self._us(change.period_ticks)))
        out.sort(key=lambda p: p.cycle)
        return out

    def pwm_outputs_us(self) -> dict[int, tuple[float, float]]:
        """Channel -> (pulse us, period us) now; (0, 0) where no pin carries the channel."""
        return {ch: (self._us(high), self._us(period)) if self.pinsel.selected(f"PWM{ch}") else (0.0, 0.0)
                for ch, (high, period) in self.pwm.outputs().items()}

    def _us(self, ticks: int) -> float:
        return ticks * 1e6 / self.time.pclk_hz

    def take_spi(self) -> list[SpiWord]:
        """SPI0's finished transfers since the last call."""
        return [SpiWord(self.cycle_of(self.spi0, x.transfer.start), self.cycle_of(self.spi0, x.transfer.end),
                        x.mosi, x.miso) for x in self.spi0.take_exchanges()]


def function_pins(function: str) -> list[int]:
    """The P0 pins that can carry ``function`` (e.g. "CAP0.2" -> [6, 16, 28])."""
    return pins_with(function)
