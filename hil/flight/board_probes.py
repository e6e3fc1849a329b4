"""Where the firmware's loop is, in target cycles: what a board run's timing verdicts measure.

Code hooks on three functions of the firmware's public interfaces (one Python call each time
the function is entered, about 1,200 a second of flight, never one per instruction):

* ``loop_step`` (firmware/src/loop.h): one iteration of the flight loop starts. An
  iteration's **busy cycles** are the cycles from its start to the next one's, less the
  cycles the core slept in PCON idle meanwhile: the loop's own work, the interrupt handlers
  that ran during it, the polling loops (SPI) it waited in;
* ``loop_tick``: the iteration has a sample to process (it is not the IMU watchdog's); the
  bench reads which one from the sample's ``counter`` (``imu_sample_t``, firmware/src/drivers/
  xsens.h: the XSENS packet counter; its offset from the ELF's DWARF), so an answer is matched
  to its sample even when the loop falls behind;
* ``hal_esc_write`` (firmware/include/hal.h): the ESC command, the answer to a sample.

The interrupt entries come from the core (``Core.on_interrupt``): the latency is the cycles
from the VIC's request to the ARM exception entry.

Cycles are taken at the first cycle of the basic block that enters the function (the core
counts per block: hil/board/core.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from elftools.elf.elffile import ELFFile
from unicorn import UC_HOOK_CODE
from unicorn import arm_const as A

from hil.board.core import Core
from hil.board.elf import FirmwareImage
from hil.board.errors import FirmwareError

ITERATION_SYMBOL = "loop_step"
SAMPLE_SYMBOL = "loop_tick"
COMMAND_SYMBOL = "hal_esc_write"


SAMPLE_TYPE, COUNTER_MEMBER = "imu_sample_t", "counter"


def member_offset(image: FirmwareImage, typedef: str, member: str) -> int:
    """The byte offset of ``member`` in the struct ``typedef`` names, from the ELF's DWARF;
    :class:`FirmwareError` if the image has no such type (built without -g, or another ABI)."""
    with image.path.open("rb") as f:
        elf = ELFFile(f)
        if elf.has_dwarf_info():
            for cu in elf.get_dwarf_info().iter_CUs():
                for die in cu.iter_DIEs():
                    name = die.attributes.get("DW_AT_name")
                    if die.tag != "DW_TAG_typedef" or name is None or name.value != typedef.encode():
                        continue
                    struct = die.get_DIE_from_attribute("DW_AT_type")
                    for m in struct.iter_children():
                        n = m.attributes.get("DW_AT_name")
                        if n is not None and n.value == member.encode():
                            return int(m.attributes["DW_AT_data_member_location"].value)
    raise FirmwareError(f"{image.path}: no {typedef}.{member} in the debug information: the board reads each "
                        f"sample's counter at {SAMPLE_SYMBOL} to match answers to samples (build with -g)")


@dataclass(frozen=True)
class Answer:
    """A sample the loop processed: ``counter`` (the XSENS packet counter) at ``tick_cycle``."""

    counter: int
    tick_cycle: int


@dataclass(frozen=True)
class Iteration:
    """One loop iteration: it began at ``start_cycle`` and kept the core busy ``busy_cycles``
    of the ``cycles`` until the next began; ``sample``: it processed a sample."""

    start_cycle: int
    cycles: int
    busy_cycles: int
    sample: bool


@dataclass
class FirmwareProbes:
    """The probes on one core; the lists fill as the firmware runs and are taken by the run."""

    core: Core
    image: FirmwareImage
    iterations: list[Iteration] = field(default_factory=list)
    commands: list[int] = field(default_factory=list)  #: cycles of hal_esc_write entries
    samples: int = 0  #: loop_tick entries: samples the loop processed
    answers: list[Answer] = field(default_factory=list)  #: each loop_tick entry, in order
    counter_offset: int = 0
    #: (kind, requested cycle, entry cycle) of every interrupt taken
    interrupts: list[tuple[str, int, int]] = field(default_factory=list)
    _start: tuple[int, int] | None = None  #: the current iteration's (cycle, idle cycles then)
    _sample: bool = False
    _hooks: list[int] = field(default_factory=list)

    def __post_init__(self) -> None:
        missing = [s for s in (ITERATION_SYMBOL, SAMPLE_SYMBOL, COMMAND_SYMBOL) if s not in self.image.symbols]
        if missing:
            raise FirmwareError(f"{self.image.path}: no function {', '.join(missing)}: the board times the flight "
                                f"loop at {ITERATION_SYMBOL}, {SAMPLE_SYMBOL} and {COMMAND_SYMBOL} (firmware/src/loop.h, "
                                "firmware/include/hal.h)")
        self.counter_offset = member_offset(self.image, SAMPLE_TYPE, COUNTER_MEMBER)
        uc = self.core.uc
        for name, cb in ((ITERATION_SYMBOL, self._iteration), (SAMPLE_SYMBOL, self._sampled),
                         (COMMAND_SYMBOL, self._command)):
            address = self.image.symbol(name) & ~1
            self._hooks.append(uc.hook_add(UC_HOOK_CODE, cb, begin=address, end=address))
        self.core.on_interrupt = self._interrupt

    def _now(self) -> int:
        return int(self.core.counter.state.block_start)

    def _iteration(self, *_: object) -> None:
        now, idle = self._now(), self.core.idle_cycles
        if self._start is not None:
            start, idle0 = self._start
            self.iterations.append(Iteration(start, now - start, now - start - (idle - idle0), self._sample))
        self._start = (now, idle)
        self._sample = False

    def _sampled(self, *_: object) -> None:
        self._sample = True
        self.samples += 1
        sample = self.core.reg(A.UC_ARM_REG_R1)  # loop_tick(L, sample)
        counter = int.from_bytes(self.core.read_memory(sample + self.counter_offset, 2), "little")
        self.answers.append(Answer(counter, self._now()))

    def _command(self, *_: object) -> None:
        self.commands.append(self._now())

    def _interrupt(self, kind: str, requested: int, entry: int) -> None:
        self.interrupts.append((kind, requested, entry))

    def running_since(self) -> int | None:
        """The cycle the iteration in progress began (None before the first)."""
        return None if self._start is None else self._start[0]

    def restart(self) -> None:
        """Forget what was measured (boot is not a sample's work): the next iteration starts
        the count."""
        self.iterations.clear()
        self.commands.clear()
        self.interrupts.clear()
        self.answers.clear()
        self.samples = 0
        self._start = None
        self._sample = False
