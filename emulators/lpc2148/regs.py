"""Register-level plumbing shared by the LPC2148 models: the access protocol every peripheral
model follows, the VIC channel numbers, and helpers for bit fields.

Every peripheral model (UM10139's register descriptions, cited in each module) has:

* ``base``: its APB/AHB base address, used only to name addresses in errors;
* ``read(offset, tick) -> int`` and ``write(offset, value, tick)``: a 32-bit register access
  at a word-aligned ``offset`` from the base, at time ``tick`` (the model's clock, see below).
  The bus handles widths and byte lanes (bus.py); a model sees whole registers;
* ``advance_to(tick)``: let time pass (time-driven models; the others accept and ignore it);
* ``next_event() -> int | None``: the tick at which the model next changes an output
  (interrupt line, pin, byte out) or a register a read could see on its own, None if never
  without new input; between its events a model changes nothing but its running counters,
  so the bus steps only the models with something due;
* ``next_irq_event() -> int | None``: a tick at or before which ``irq`` may next change on
  its own (the events that cannot change it left out: a character below the FIFO's trigger
  level, a timer's match output);
* ``irq: bool``: the level of its interrupt request line into the VIC.

Ticks: the APB peripherals (timers, PWM, UARTs, SPI) count PCLK ticks since reset; the system
control block counts CCLK cycles; the VIC, GPIO and pin select have no clock.
"""

from __future__ import annotations

from enum import IntEnum, unique

from emulators.lpc2148.errors import RegisterAccessError, UnmodelledRegister

MASK32 = 0xFFFF_FFFF


@unique
class VicChannel(IntEnum):
    """VIC interrupt request inputs of the LPC2148 (UM10139, VIC chapter, table
    "Connection of interrupt sources to the VIC"). The ones marked * have a model here."""

    WDT = 0
    SOFTWARE = 1  #: reserved for software interrupts only
    ARM_CORE0 = 2  #: EmbeddedICE DbgCommRx
    ARM_CORE1 = 3  #: EmbeddedICE DbgCommTx
    TIMER0 = 4  # *
    TIMER1 = 5  # *
    UART0 = 6  # *
    UART1 = 7  # *
    PWM0 = 8  # *
    I2C0 = 9
    SPI0 = 10  # *
    SPI1 = 11  #: the SSP
    PLL = 12  # * (PLOCK)
    RTC = 13
    EINT0 = 14  # *
    EINT1 = 15  # *
    EINT2 = 16  # *
    EINT3 = 17  # *
    AD0 = 18
    I2C1 = 19
    BOD = 20
    AD1 = 21
    USB = 22


class RegisterFile:
    """Base of a peripheral model: names addresses in errors, and the default time methods."""

    #: the model's name in errors and logs
    name = "peripheral"

    def __init__(self, base: int) -> None:
        self.base = base
        #: set by a register access that changed what the model does next or, for a read, its
        #: interrupt line (a write to a timer's match registers, a byte to send; a UART's RBR
        #: read starts a new character time-out, its LSR or IIR read ends RLS or THRE); the bus
        #: clears it. A read that leaves it clear changed neither; a write, its events.
        self.rescheduled = False

    # -- registers (every model has them) ----------------------------------------------
    def read(self, offset: int, tick: int) -> int:
        """The register at ``offset`` at ``tick``."""
        raise self.unmodelled(offset, "read")

    def write(self, offset: int, value: int, tick: int) -> None:
        """Write the register at ``offset`` at ``tick``."""
        raise self.unmodelled(offset, "write")

    # -- time (models without a clock keep these) --------------------------------------
    def advance_to(self, tick: int) -> None:
        """Let time pass up to ``tick``; a model without a clock has nothing to do."""

    def next_event(self) -> int | None:
        """The tick of the next change the model makes on its own; None: none pending."""
        return None

    def next_irq_event(self) -> int | None:
        """A tick at or before which :attr:`irq` may next change on its own (None: not without
        an access); a model whose every event may change it keeps this default."""
        return self.next_event()

    @property
    def irq(self) -> bool:
        """The model's interrupt request line into the VIC (level)."""
        return False

    # -- errors ---------------------------------------------------------------------------
    def unmodelled(self, offset: int, access: str) -> UnmodelledRegister:
        return UnmodelledRegister(self.base + offset, access, self.name)

    def write_only(self, offset: int, register: str) -> RegisterAccessError:
        return RegisterAccessError(self.base + offset, f"{self.name} {register} is write-only (read)")

    def read_only(self, offset: int, register: str) -> RegisterAccessError:
        return RegisterAccessError(self.base + offset, f"{self.name} {register} is read-only (write)")


def bit(value: int, n: int) -> bool:
    """Bit ``n`` of ``value``."""
    return bool((value >> n) & 1)
