"""The core's peripheral accesses, handed to the peripheral bus (emulators/lpc2148's
:class:`~emulators.lpc2148.Lpc2148Bus`, or any object with the same methods).

An access is timed at the first cycle of the basic block that makes it (Unicorn does not keep
the PC current inside a block; the error is at most the block's own cycles). An APB access
costs two PCLK cycles in place of the core's one N cycle (the AMBA APB protocol's setup and
access phases: 2 x VPBDIV - 1 extra CCLK cycles); the VIC, on the AHB, none.

A callback never stops the emulation itself (Unicorn would re-run the access's instruction);
it asks the cycle counter to stop at the next block boundary, when an access raised an error,
put the core to sleep or asserted an interrupt line. An access may move a peripheral event (a
timer started, a byte to send, a UART's time-out restarted by an RBR read): the bus says so
(``schedule_changed``) and the slice's deadline moves to its next interrupt-relevant event,
earlier or later (never beyond the run loop's target).
An access that ends a request the run loop saw (the handler's acknowledge) ends the watch for
the CPSR to allow it: a request that comes again is a new one.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable
from typing import Protocol

from unicorn import Uc
from unicorn.unicorn_py3 import unicorn as _ucmod

from hil.board.native import CycleCounter
from hil.board.poll import PollWatch

APB_BASE, APB_SIZE = 0xE000_0000, 0x0020_0000
AHB_BASE, AHB_SIZE = 0xFFFF_F000, 0x0000_1000  # the VIC
SCB_BASE = 0xE01F_C000
SLOT_SHIFT = 14  # APB peripherals sit in 16 KB slots
CPSR_I, CPSR_F = 0x80, 0x40
#: MAMCR, MAMTIM, VPBDIV: the registers the core's memory timing follows
_MEMORY_TIMING = frozenset({SCB_BASE + 0x000, SCB_BASE + 0x004, SCB_BASE + 0x100})

ReadCb = ctypes.CFUNCTYPE(ctypes.c_uint64, ctypes.c_void_p, ctypes.c_uint64, ctypes.c_uint, ctypes.c_void_p)
WriteCb = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_uint64, ctypes.c_uint, ctypes.c_uint64, ctypes.c_void_p)


class SystemControlView(Protocol):
    """What the core's memory timing needs from the system control block."""

    mamcr: int
    mamtim: int

    @property
    def pclk_div(self) -> int: ...


class PeripheralBus(Protocol):
    """The peripheral side of the LPC2148, in CCLK cycles."""

    scb: SystemControlView

    def read(self, address: int, width: int, cycle: int) -> int: ...

    def write(self, address: int, value: int, width: int, cycle: int) -> None: ...

    def advance_to(self, cycle: int) -> None: ...

    def next_event_cycle(self) -> int | None: ...

    def next_irq_cycle(self) -> int | None: ...

    schedule_changed: bool

    @property
    def irq_request(self) -> bool: ...

    @property
    def fiq_request(self) -> bool: ...

    @property
    def sleeping(self) -> bool: ...


class MmioBridge:
    """The MMIO regions of one engine, routed to ``bus``."""

    def __init__(self, uc: Uc, counter: CycleCounter, bus: PeripheralBus) -> None:
        self.bus = bus
        self.counter = counter
        self.state = counter.state
        self.fault: BaseException | None = None
        self.apb_accesses = 0
        self.apb_wait = 1
        #: the interrupt lines as the run loop last saw them: an access that raises one stops
        #: the slice so that the run loop can take it
        self.irq_seen = self.fiq_seen = False
        #: a request the run loop saw ended at an access (the run loop's own record of it is
        #: stale: the next request is a new one)
        self.request_ended = False
        #: the cycle the run loop runs to (a slice's deadline is never later)
        self.slice_limit = 0
        #: polling loops: the run loop's judge of a block (address, size) -> skippable
        self.poll_watch = PollWatch()
        self.is_poll_loop: Callable[[int, int], bool] = lambda address, size: False
        self.poll_found = False
        self._callbacks: list[object] = []
        for base, size in ((APB_BASE, APB_SIZE), (AHB_BASE, AHB_SIZE)):
            read, write = ReadCb(self._reader(base)), WriteCb(self._writer(base))
            self._callbacks += [read, write]  # alive as long as the engine
            err = _ucmod.uclib.uc_mmio_map(uc._uch, base, size, ctypes.cast(read, ctypes.c_void_p), None,
                                           ctypes.cast(write, ctypes.c_void_p), None)
            if err:
                raise RuntimeError(f"uc_mmio_map({base:#x}) failed: error {err}")
        self.memory_timing_changed()

    def memory_timing_changed(self) -> None:
        """Take MAMCR, MAMTIM and VPBDIV from the bus into the cycle counter."""
        scb = self.bus.scb
        self.state.mam_mode = scb.mamcr if scb.mamcr in (0, 1, 2) else 0
        self.state.mam_cycles = max(scb.mamtim, 1)
        self.apb_wait = 2 * scb.pclk_div - 1

    def _reader(self, base: int):  # type: ignore[no-untyped-def]
        apb = base == APB_BASE

        def read(_uc: int, offset: int, size: int, _user: int) -> int:
            state = self.state
            try:
                value = self.bus.read(base + offset, size, state.block_start)
                if apb:
                    state.cycles += self.apb_wait
                    self.apb_accesses += 1
                if self.poll_watch.read(state.blocks, state.cur_addr, state.block_start, base + offset, value) \
                        and self.is_poll_loop(state.cur_addr, state.cur_size):
                    self.poll_found = True
                    state.stop_request = 1
                self._after_access()
                return value
            except BaseException as e:  # noqa: BLE001 - handed to the run loop, never lost in ctypes
                self._failed(e)
                return 0
        return read

    def _writer(self, base: int):  # type: ignore[no-untyped-def]
        apb = base == APB_BASE

        def write(_uc: int, offset: int, size: int, value: int, _user: int) -> None:
            state = self.state
            address = base + offset
            try:
                self.poll_watch.reset()
                self.bus.write(address, value, size, state.block_start)
                if apb:
                    state.cycles += self.apb_wait
                    self.apb_accesses += 1
                    if address in _MEMORY_TIMING:
                        self.memory_timing_changed()
                self._after_access()
            except BaseException as e:  # noqa: BLE001
                self._failed(e)
        return write

    def _after_access(self) -> None:
        bus = self.bus
        if bus.schedule_changed:
            # the next interrupt-relevant event moved (a timer started, a byte to send, a
            # time-out restarted, the FIFO read below its trigger level): the slice ends at the
            # first block boundary at or after it
            bus.schedule_changed = False
            nxt = bus.next_irq_cycle()
            limit = self.slice_limit
            self.state.deadline = limit if nxt is None or nxt > limit else nxt
        irq, fiq = bus.irq_request, bus.fiq_request
        if bus.sleeping or (irq and not self.irq_seen) or (fiq and not self.fiq_seen):
            self.state.stop_request = 1
        elif (self.irq_seen and not irq) or (self.fiq_seen and not fiq):
            # a request the run loop saw has ended (acknowledged): stop watching for the CPSR to
            # allow it (no slice ends there for nothing), and a request that comes back is new
            self.irq_seen, self.fiq_seen = irq, fiq
            state = self.state
            if state.irq_watch:
                state.irq_watch = (state.irq_watch & CPSR_F if fiq else 0) | (state.irq_watch & CPSR_I if irq else 0)
            if not (irq or fiq):
                self.request_ended = True

    def _failed(self, e: BaseException) -> None:
        if self.fault is None:
            self.fault = e
        self.state.stop_request = 1
