"""The emulated LPC2148's CPU: an ARM7TDMI-S on Unicorn (ARMv4T), timed in CCLK cycles by the
ARM7TDMI TRM's instruction timings and the MAM's flash timing, with its peripherals on the
sans-I/O models of :mod:`emulators.lpc2148` (docs/board.md).

- :mod:`hil.board.core`: the core, its memory map, the run loop (slices between peripheral
  events, interrupt entry, idle);
- :mod:`hil.board.isa`, :mod:`hil.board.blocks`: the instruction timings and a basic block's
  cycle facts;
- :mod:`hil.board.native`, ``cyclehook.c``: the cycle counter in C (Unicorn hooks);
- :mod:`hil.board.mmio`: peripheral accesses to the bus; :mod:`hil.board.poll`: polling
  loops skipped to the next event;
- :mod:`hil.board.elf`: the firmware image; :mod:`hil.board.semihost`: the firmware's
  console; :mod:`hil.board.stacks`: the stacks' high-water marks.
"""
