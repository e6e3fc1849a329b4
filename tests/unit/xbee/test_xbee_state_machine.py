"""Stateful property test of transparent mode: data, +++ with and without guard times,
command-mode lines and ATCN, in any order; what reaches the far end is exactly the data."""

from __future__ import annotations

import numpy as np
from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, rule

from emulators.xbee import LinkParams, RadioLink, XBeeModule, XBeeParams

MS = 1_000_000
GT = 1000 * MS
DATA = st.binary(min_size=1, max_size=30).filter(lambda b: b"+" not in b and b"\r" not in b)


class TransparentMachine(RuleBasedStateMachine):
    def __init__(self) -> None:
        super().__init__()
        self.v = XBeeModule(XBeeParams(ap=0), np.random.default_rng(0), "telemetry")
        self.g = XBeeModule(XBeeParams(ap=0, my=0, dl=1), np.random.default_rng(1), "ground")
        self.link = RadioLink(LinkParams(), np.random.default_rng(2))
        self.link.attach(self.v)
        self.link.attach(self.g)
        self.t = 0
        self.sent = bytearray()  # what the far end must eventually receive
        self.got = bytearray()
        self.command = False
        self.last_rx = -(1 << 62)

    def step(self, dt: int) -> None:
        self.t += dt
        self.v.advance(self.t)
        self.link.advance(self.t)
        self.got += self.g.take_output()

    @rule(data=DATA, gap_ms=st.integers(0, 1500))
    def send_data(self, data: bytes, gap_ms: int) -> None:
        self.step(gap_ms * MS)
        if self.command:  # a line that is not a command
            self.v.receive(b"x" + data + b"\r", self.t)
            assert self.v.take_output() == b"ERROR\r"
        else:
            self.v.receive(data, self.t)
            self.last_rx = self.t
            self.sent += data

    @rule(gap_ms=st.integers(0, 2000), after_ms=st.integers(0, 1500))
    def plus_plus_plus(self, gap_ms: int, after_ms: int) -> None:
        if self.command:
            return
        self.step(gap_ms * MS)
        self.v.take_output()
        self.v.receive(b"+++", self.t)
        quiet_before = self.t - self.last_rx >= GT
        self.last_rx = self.t
        self.step(after_ms * MS)
        if quiet_before and after_ms * MS >= GT:
            assert self.v.take_output() == b"OK\r"
            self.command = True
        elif quiet_before:
            self.step(GT)  # let the guard time pass: command mode after all
            assert self.v.take_output() == b"OK\r"
            self.command = True
        else:
            self.sent += b"+++"
        assert self.v.in_command_mode == self.command

    @rule()
    def query(self) -> None:
        if not self.command:
            return
        self.v.receive(b"ATMY\r", self.t)
        assert self.v.take_output() == b"1\r"

    @rule()
    def exit_command_mode(self) -> None:
        if not self.command:
            return
        self.v.receive(b"ATCN\r", self.t)
        assert self.v.take_output() == b"OK\r"
        self.command = False
        self.last_rx = self.t

    @invariant()
    def far_end_gets_a_prefix_of_the_data(self) -> None:
        assert bytes(self.sent).startswith(bytes(self.got))

    def teardown(self) -> None:
        if self.command:
            self.exit_command_mode()
        self.step(2 * GT)
        assert bytes(self.got) == bytes(self.sent)


TransparentMachine.TestCase.settings = settings(max_examples=40, stateful_step_count=20, deadline=None)
TestTransparentMachine = TransparentMachine.TestCase
