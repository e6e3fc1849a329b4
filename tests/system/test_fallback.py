"""Lockstep falls back to the host clock, loudly, where virtual time cannot be had; a flight
code that execs itself out of the clock shim falls back instead of hanging the run."""

from __future__ import annotations

import dataclasses

import pytest

from hil.flight.tickloop import Clock, EndReason
from hil.record import read_metadata
from hil.config.rig import load_rig
from tests.system.conftest import explain

pytestmark = [pytest.mark.system, pytest.mark.pty]


async def test_virtual_time_switched_off_says_so(fly) -> None:
    result = await fly("hover", duration_s=1.0, virtual_time=False)
    assert result.end_reason is EndReason.COMPLETED, explain(result)
    assert result.clock is Clock.WALL and "switched off" in result.clock_note
    assert any("lockstep on the host clock (load changes the flight)" in n for n in result.notes)
    assert result.log_path is not None
    verdict = read_metadata(result.log_path)["verdict"]
    assert verdict["clock"] == "wall" and "switched off" in verdict["clock_note"]


async def test_a_wrapper_that_drops_the_shim_falls_back_instead_of_hanging(fly) -> None:
    """`env -u LD_PRELOAD python -m flightcode`: env loads the shim, the flight code it execs
    does not. The bench notices when the flight code stalls (the shim is gone from its maps),
    boots and flies on the host clock, and says why."""
    rig = load_rig(None)
    command = ("env", "-u", "LD_PRELOAD", *rig.flight.command)
    wrapped = dataclasses.replace(rig, flight=dataclasses.replace(rig.flight, command=command))
    result = await fly("hover", rig=wrapped, duration_s=1.0)
    assert result.end_reason is EndReason.COMPLETED, explain(result)
    assert result.clock is Clock.WALL
    assert "runs without the clock shim" in result.clock_note
    assert result.log_path is not None
    assert read_metadata(result.log_path)["verdict"]["clock"] == "wall"
