"""The firmware's stacks' high-water marks, from the paint its startup code puts on them.

firmware/hal/lpc2148/startup.S fills the stack region (``__stack_bottom`` to
``__stack_region_end``) with ``STACK_PAINT`` before it gives each mode its stack; the linker
script places the modes' stacks in that region, each growing down from its ``__<mode>_stack_top``.
A stack's high-water mark is the distance from its top to the lowest word that no longer holds
the paint.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from hil.board.elf import FirmwareImage

STACK_PAINT = 0xDEAD_BEEF
#: the modes' stacks from the bottom of the region up (lpc2148.ld)
MODES = ("abt", "und", "fiq", "irq", "svc")


@dataclass(frozen=True)
class StackUse:
    """A mode's stack: ``size_B`` reserved, ``used_B`` the deepest it was written."""

    mode: str
    size_B: int
    used_B: int

    @property
    def overflowed(self) -> bool:
        """Written down to its last word: it may have run into the stack below."""
        return self.used_B >= self.size_B


def stack_use(image: FirmwareImage, read: Callable[[int, int], bytes]) -> list[StackUse]:
    """Each mode's stack use; ``read(address, size)`` reads the board's memory. An image
    without the region's symbols gives an empty list."""
    if "__stack_bottom" not in image.symbols:
        return []
    out = []
    bottom = image.symbol("__stack_bottom")
    paint = STACK_PAINT.to_bytes(4, "little")
    for mode in MODES:
        top = image.symbol(f"__{mode}_stack_top")
        memory = read(bottom, top - bottom)
        lowest = next((i for i in range(0, len(memory), 4) if memory[i:i + 4] != paint), len(memory))
        out.append(StackUse(mode, top - bottom, top - bottom - lowest))
        bottom = top
    return out
