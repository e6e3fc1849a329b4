"""The bus lets time pass lazily (only models with an event due are stepped; look-aheads are
cached until a model's state changes): a hypothesis property test against the same bus driven
eagerly (every model stepped to the cycle, every cache dropped and every interrupt line
recomputed before each access, as a bus without the bookkeeping does). Every read, every
request line into the VIC, nIRQ/nFIQ, the idle state, the next event and the outputs must
agree; no request line changes before ``next_irq_cycle()``; and an access that does not set
``schedule_changed`` never brings ``next_irq_cycle()`` earlier (a running core keeps its
slice's deadline then). Also: a match counter advanced in chunks against one stepped through
every match."""

from __future__ import annotations

from typing import Any

from hypothesis import example, given, settings
from hypothesis import strategies as st

from emulators.lpc2148 import Lpc2148
from emulators.lpc2148.counter import MatchCounter

SCB, VIC = 0xE01F_C000, 0xFFFF_F000
T0, T1, U0, U1, PWM, SPI = 0xE000_4000, 0xE000_8000, 0xE000_C000, 0xE001_0000, 0xE001_4000, 0xE002_0000


def configure(b: Lpc2148) -> None:
    """PCLK = CCLK = 12 MHz; UART0 at 107 kbit/s (FIFO, trigger 4, RDA and RLS), UART1 too;
    Timer0 interrupting every 30,000 cycles, Timer1 counting with MAT1.2 toggling every 60,000
    and CAP1.0 on both edges; the PWM; SPI0 master; VIC slots for all of them. (Events far
    apart: a model whose next event the bus missed is not rescued by another's.)"""
    w = b.write
    w(SCB + 0x100, 1, 4, 0)
    w(0xE002_C000, 0b0101 | (0b0101 << 16) | (0b10 << 20), 4, 0)  # UART0, UART1, P0.10 = CAP1.0
    for base, fcr, ier in ((U0, 0x47, 0x05), (U1, 0x07, 0x02)):
        w(base + 0x0C, 0x83, 1, 0)
        w(base + 0x00, 7, 1, 0)  # 12 MHz / (16 x 7) = 107 kbit/s
        w(base + 0x0C, 0x03, 1, 0)
        w(base + 0x08, fcr, 1, 0)
        w(base + 0x04, ier, 1, 0)
    w(T0 + 0x18, 29_999, 4, 0)
    w(T0 + 0x14, 0b011, 4, 0)
    w(T1 + 0x0C, 11, 4, 0)
    w(T1 + 0x20, 5000, 4, 0)
    w(T1 + 0x14, 0b010 << 6, 4, 0)
    w(T1 + 0x3C, 0b11 << 8, 4, 0)
    w(T1 + 0x28, 0b111, 4, 0)
    w(PWM + 0x18, 4999, 4, 0)
    w(PWM + 0x1C, 1000, 4, 0)
    w(PWM + 0x14, 0b010, 4, 0)
    w(PWM + 0x4C, 1 << 9, 4, 0)
    w(PWM + 0x04, 0b1010, 4, 0)
    w(PWM + 0x04, 0b1001, 4, 0)
    w(SPI + 0x0C, 8, 4, 0)
    w(SPI + 0x00, 0xA0, 4, 0)  # master, interrupt
    for slot, channel in enumerate((4, 5, 6, 7, 8, 10)):
        w(VIC + 0x100 + 4 * slot, 0x100 * (slot + 1), 4, 0)
        w(VIC + 0x200 + 4 * slot, 0x20 | channel, 4, 0)
    w(VIC + 0x010, 0x5F0, 4, 0)
    w(T0 + 0x04, 1, 4, 0)
    w(T1 + 0x04, 1, 4, 0)


def force(b: Lpc2148) -> None:
    """Drive ``b`` eagerly: every look-ahead forgotten, every model stepped to the bus's cycle,
    every line recomputed."""
    pclk = b.time.pclk_at(b.cycle)
    for slot in b._slots:
        model: Any = slot.model
        if hasattr(model, "counter"):
            model.counter.changed()
        if hasattr(model, "_changed"):
            model._changed()
        if slot.frozen_at is None:
            model.advance_to(pclk - slot.offset)
        slot.stale = True
    b._update_lines()
    b._due = b._next_due()


READS = [U0 + 0x00, U0 + 0x14, U0 + 0x08, U1 + 0x14, U1 + 0x08, T0 + 0x08, T0 + 0x00, T1 + 0x08, T1 + 0x2C,
         T1 + 0x3C, PWM + 0x00, PWM + 0x50, SPI + 0x04, SPI + 0x08, VIC + 0x030, VIC + 0x000, 0xE002_8000]
WRITES = [(T0 + 0x00, 0xF), (T0 + 0x18, 1499), (T0 + 0x14, 0b001), (T0 + 0x14, 0b111), (T0 + 0x04, 1),
          (T0 + 0x04, 2), (T1 + 0x20, 300), (T1 + 0x3C, 0b10 << 8), (T1 + 0x00, 0xFF), (U0 + 0x04, 0x05),
          (U0 + 0x04, 0x01), (U0 + 0x04, 0x07), (U0 + 0x08, 0x87), (U0 + 0x08, 0x07), (U0 + 0x08, 0xC7),
          (U0 + 0x08, 0x00), (U0 + 0x00, 0x55), (U1 + 0x00, 0x41), (U1 + 0x00, 0x42), (U1 + 0x04, 0x00),
          (U1 + 0x04, 0x02), (PWM + 0x1C, 2000), (PWM + 0x50, 0b10), (PWM + 0x00, 0x7FF), (PWM + 0x14, 0b011),
          (SPI + 0x08, 0x3C),
          (VIC + 0x030, 0), (VIC + 0x014, 1 << 6), (VIC + 0x010, 1 << 6), (VIC + 0x00C, 1 << 5),
          (VIC + 0x00C, 0), (SCB + 0xC0, 1), (SCB + 0xC4, 0x0018_17BE & ~(1 << 3)), (SCB + 0xC4, 0x0018_17BE),
          (SCB + 0xC4, 0x0018_17BE & ~(1 << 1))]

op = st.one_of(
    st.tuples(st.just("adv"), st.integers(1, 20_000)),
    st.tuples(st.just("step"), st.booleans()),  # to the next event exactly (True: the next interrupt-relevant one)
    st.tuples(st.just("read"), st.sampled_from(READS)),
    st.tuples(st.just("write"), st.sampled_from(WRITES)),
    st.tuples(st.just("rx"), st.tuples(st.binary(min_size=1, max_size=40), st.sampled_from([107_143, 109_000,
                                                                                            54_000]))),
    st.tuples(st.just("edge"), st.booleans()),
    st.tuples(st.just("ne"), st.just(0)),
    st.tuples(st.just("take"), st.just(0)),
)


def outputs(b: Lpc2148) -> tuple[object, ...]:
    return (b.take_uart_tx(0), b.take_uart_tx(1), b.take_pwm(), b.take_spi(), b.timer1.take_match_outputs(),
            b.timer1.take_captures(), b.uart0.counters, b.uart1.counters)


@settings(max_examples=100, deadline=None)
@given(ops=st.lists(st.tuples(op, st.integers(0, 3000)), min_size=1, max_size=60))
# the time-out restarted by an RBR read, with no other event near: the bus must learn of it
@example(ops=[(("rx", (b"ab", 107_143)), 100), (("adv", 12_000), 0), (("read", U0), 10), (("adv", 6000), 0)])
# the time-out between two characters more than four character times apart
@example(ops=[(("rx", (b"ab", 107_143)), 100), (("rx", (b"c", 107_143)), 5900), (("adv", 3000), 0)])
# THRE when the transmitter takes the last byte
@example(ops=[(("write", (U1 + 0x00, 0x41)), 100), (("adv", 5000), 0)])
# an IIR read that ends THRE while characters come: RDA matters again
@example(ops=[(("write", (U0 + 0x04, 0x07)), 100), (("rx", (b"abcdefgh", 107_143)), 0), (("read", U0 + 0x08), 10),
              (("adv", 9000), 0)])
# an LSR read that ends RLS (framing errors at the wrong rate) while characters come
@example(ops=[(("rx", (bytes(range(40)), 54_000)), 100), (("adv", 6000), 0), (("read", U0 + 0x14), 10),
              (("adv", 9000), 0)])
def test_lazy_bus_equals_the_eager_bus(ops: list[tuple[tuple[str, Any], int]]) -> None:
    lazy, eager = Lpc2148(), Lpc2148()
    for b in (lazy, eager):
        b.attach_spi_slave(lambda mosi, transfer: (mosi * 5 + 1) & 0xFF)
        configure(b)
    cycle = 0
    for (kind, arg), dt in ops:
        cycle += dt
        if kind == "step":
            nxt = lazy.next_irq_cycle() if arg else lazy.next_event_cycle()
            if nxt is None:
                continue
            kind, arg = "adv", max(nxt - cycle, 0)
        if kind == "adv":
            target = cycle + arg
            horizon = lazy.next_irq_cycle()
            lines = (eager.vic.sources, eager.irq_request, eager.fiq_request)
            quiet_until = target if horizon is None else min(target, horizon - 1)
            while True:  # the eager bus from event to event up to the horizon: no line changes
                nxt = eager.next_event_cycle()
                if nxt is None or nxt > quiet_until:
                    break
                eager.advance_to(nxt)
                force(eager)
                assert (eager.vic.sources, eager.irq_request, eager.fiq_request) == lines, "a line changed early"
            cycle = target
            lazy.advance_to(cycle)
            eager.advance_to(cycle)
            force(eager)
        elif kind == "ne":
            force(eager)
            assert lazy.next_event_cycle() == eager.next_event_cycle()
            irq_at = lazy.next_irq_cycle()
            event_at = lazy.next_event_cycle()
            assert irq_at is None or (event_at is not None and irq_at >= event_at)
        elif kind == "take":
            force(eager)
            assert outputs(lazy) == outputs(eager)
        else:
            lazy.schedule_changed = False
            before = lazy.next_irq_cycle()
            results = []
            for b in (lazy, eager):
                try:
                    if b is eager:
                        b.advance_to(cycle)
                        force(b)
                    if kind == "read":
                        results.append(("value", b.read(arg, 4, cycle)))
                    elif kind == "write":
                        b.write(arg[0], arg[1], 4, cycle)
                        results.append(("ok", 0))
                    elif kind == "rx":
                        b.uart_line_in(0, arg[0], cycle, baud=arg[1])
                        results.append(("ok", 0))
                    else:
                        b.pin_edge(0, 10, arg, cycle)
                        results.append(("ok", 0))
                except Exception as e:  # a powered-off peripheral, an SPI write while busy...
                    results.append(("error", str(e)))  # type: ignore[arg-type]
            assert results[0] == results[1], (kind, arg)
            if not lazy.schedule_changed:  # a core keeps its deadline: nothing may come sooner
                after = lazy.next_irq_cycle()
                assert after is None or (before is not None and after >= before), (kind, arg, before, after)
        assert (lazy.vic.sources, lazy.irq_request, lazy.fiq_request, lazy.sleeping) == \
            (eager.vic.sources, eager.irq_request, eager.fiq_request, eager.sleeping), (kind, arg)
    cycle += 50_000
    lazy.advance_to(cycle)
    eager.advance_to(cycle)
    force(eager)
    assert outputs(lazy) == outputs(eager)
    assert lazy.next_event_cycle() == eager.next_event_cycle()


@settings(max_examples=100, deadline=None)
@given(pr=st.integers(0, 3), mr=st.lists(st.integers(0, 40), min_size=4, max_size=4), mcr=st.integers(0, 0xFFF),
       extra=st.integers(0, 15), tc=st.integers(0, 45), pc=st.integers(0, 5),
       chunks=st.lists(st.integers(1, 90), min_size=1, max_size=15))
def test_counter_in_chunks_equals_every_match_stepped(pr: int, mr: list[int], mcr: int, extra: int, tc: int, pc: int,
                                                      chunks: list[int]) -> None:
    """Arithmetic between matches and the cached look-aheads give what stepping one tick at a
    time through the same code gives: the same matches at the same ticks, the same TC and PC."""
    def make() -> tuple[MatchCounter, list[tuple[int, int]]]:
        k = MatchCounter(4)
        k.pr, k.mr, k.mcr, k.extra, k.tc, k.pc, k.enabled = pr, list(mr), mcr, extra, tc, pc, True
        k.changed()
        return k, []

    fast, fast_hits = make()
    slow, slow_hits = make()
    now = 0
    for chunk in chunks:
        predicted = fast.ticks_to_effect()
        predicted_irq = fast.ticks_to_interrupt()
        fast.advance_to(now + chunk, lambda mask, tick: fast_hits.append((mask, tick)))
        for t in range(now + 1, now + chunk + 1):
            slow.advance_to(t, lambda mask, tick: slow_hits.append((mask, tick)))
        interrupt, _, stop = slow.masks()
        effects = [t for m, t in slow_hits if t > now and m & (interrupt | stop | extra)]
        irqs = [t for m, t in slow_hits if t > now and m & interrupt]
        if effects:
            assert predicted is not None and now + predicted == effects[0]
        if irqs:
            assert predicted_irq is not None and now + predicted_irq == irqs[0]
        now += chunk
        assert fast_hits == slow_hits
        assert (fast.tc, fast.pc, fast.enabled) == (slow.tc, slow.pc, slow.enabled)
