"""Plays a scenario during a run: sticks, plant events, faults, phases, timing budgets.

The stick script is handed to the RC emulator once (it is a function of sim time);
plant events and faults fire from ``before_tick`` when their time comes, and each one is
logged as an event on ``/hil/events``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from functools import partial
from typing import TYPE_CHECKING, Any

from hil.analysis.criteria import CriterionResult, margin_of
from hil.config.scenario import GustEvent, PayloadEvent, Scenario, WindEvent

if TYPE_CHECKING:
    from emulators.rc.script import StickScript
    from hil.faults import FaultSchedule
    from hil.flight.devices import DeviceSet
    from hil.flight.process import FlightProcess
    from hil.plant.plant import Plant
    from hil.config.rig import Rig

S = 1_000_000_000

#: Timing budgets a scenario may declare in its [timing] table: key -> (timing key, sense)
TIMING_BUDGETS = {
    "latency_p99_us_max": ("latency_p99_us", "max"),
    "latency_max_us_max": ("latency_max_us", "max"),
    "barrier_misses_max": ("barrier_misses", "max"),
    "lateness_p99_us_max": ("lateness_p99_us", "max"),
    "late_ticks_max": ("late_ticks", "max"),
    "compute_p99_us_max": ("fc_compute_p99_us", "max"),
    "period_jitter_p99_us_max": ("period_jitter_p99_us", "max"),
}

#: budgets on the flight code's compute: judged only on a rig whose ``cpu_scale`` is calibrated
#: for the target (``[flight] cpu_scale_source``); this host's CPU time alone says nothing of it
NEEDS_CALIBRATION = frozenset({"compute_p99_us_max"})

EventLogger = Callable[[int, str, str, dict[str, Any]], None]


class ScenarioRunner:
    """Turns a :class:`Scenario` into actions on the devices, tick by tick."""

    def __init__(self, scenario: Scenario, rig: Rig, source: Path | None = None) -> None:
        self.scenario = scenario
        self.rig = rig
        self.source = source
        self.devices: DeviceSet | None = None
        self.flight: FlightProcess | None = None
        self.log_event: EventLogger = lambda t_ns, kind, name, detail: None
        self._timed: list[tuple[int, Callable[[int], None], str, dict[str, Any]]] = []
        # Faults are checked against the rig now, at load: a fault the rig cannot apply is
        # refused here with file, entry, key and reason (never accepted silently).
        from hil.faults import load_faults

        self.faults = load_faults(
            scenario.faults,
            rig,
            source=str(source) if source is not None else f"scenario {scenario.name}",
            run_duration_s=scenario.scenario.duration_s,
        )
        #: plays the scenario's [[faults]] (and a pytest bench's): built by attach_flight
        self.schedule: FaultSchedule | None = None
        self._next = 0
        for key in scenario.timing:
            if key not in TIMING_BUDGETS:
                from hil.config import ConfigError

                raise ConfigError(
                    f"scenario {scenario.name}: [timing] {key}: unknown budget (known: {', '.join(TIMING_BUDGETS)})"
                )

    # -- set-up -----------------------------------------------------------------------------
    def stick_script(self) -> StickScript:
        """The RC emulator's stick script built from the scenario's [[sticks]]."""
        from emulators.rc.script import Loss, Macro, Setpoint, Sine, StickScript

        segments: list[object] = []
        for e in self.scenario.sticks:
            if e.pulse_us is not None:
                assert e.channel is not None
                segments.append(Setpoint(e.t_s, e.channel, e.pulse_us, e.ramp_s))
            elif e.sine is not None:
                assert e.channel is not None
                s = e.sine
                segments.append(Sine(e.t_s, e.channel, s.amplitude_us, s.freq_hz, s.duration_s, s.offset_us, s.fade_s))
            elif e.action == "loss":
                assert e.duration_s is not None
                segments.append(Loss(e.t_s, e.duration_s))
            else:
                assert e.action is not None
                segments.append(Macro(e.t_s, e.action) if e.duration_s is None else Macro(e.t_s, e.action, e.duration_s))
        return StickScript(segments)  # type: ignore[arg-type]

    def source_bytes(self) -> bytes:
        if self.source is not None and self.source.exists():
            return self.source.read_bytes()
        import tomli_w

        return tomli_w.dumps(self.scenario.model_dump(exclude_none=True)).encode()

    def bind(self, devices: DeviceSet) -> None:
        self.devices = devices
        plant = devices.plant
        for ev in self.scenario.events:
            t_ns = int(round(ev.t_s * S))
            if isinstance(ev, PayloadEvent):
                self._at(t_ns, partial(_set_payload, plant, ev), "payload", ev.model_dump())
            elif isinstance(ev, WindEvent):
                until = None if ev.duration_s is None else t_ns + int(round(ev.duration_s * S))
                self._at(t_ns, partial(_add_wind, plant, ev, until), "wind", ev.model_dump())
            elif isinstance(ev, GustEvent):
                plant.add_gust(ev.wind_N_mps, t_ns, int(round(ev.duration_s * S)))
                self._at(t_ns, lambda t: None, "gust", ev.model_dump())
        self._timed.sort(key=lambda item: item[0])

    def attach_flight(self, flight: FlightProcess | None) -> None:
        """Build the fault schedule (process faults need the flight code process)."""
        from hil.faults import FaultSchedule

        self.flight = flight
        assert self.devices is not None, "bind(devices) first"
        self.schedule = FaultSchedule(
            self.faults,
            self.devices,
            log_event=lambda t_ns, kind, name, detail: self.log_event(t_ns, kind, name, detail),
            flight=flight,
        )

    def finish(self, t_ns: int) -> None:
        """End of the run: revert every active fault."""
        if self.schedule is not None:
            self.schedule.finish(t_ns)

    async def aclose(self) -> None:
        """Cancel background fault work (a pending flight-code restart)."""
        if self.schedule is not None:
            await self.schedule.aclose()

    def _at(self, t_ns: int, action: Callable[[int], None], name: str, detail: dict[str, Any]) -> None:
        self._timed.append((t_ns, action, name, detail))

    # -- during the run ----------------------------------------------------------------------------
    def before_tick(self, k: int, t_ns: int) -> None:
        if self.schedule is not None:
            self.schedule.before_tick(t_ns)
        while self._next < len(self._timed) and self._timed[self._next][0] <= t_ns:
            at, action, name, detail = self._timed[self._next]
            action(t_ns)
            self.log_event(t_ns, "scenario", name, detail)
            self._next += 1

    def phase(self, t_ns: int) -> str:
        label = ""
        for t_s, name in self.scenario.scenario.phases:
            if t_ns / S >= t_s:
                label = name
        return label

    # -- after the run --------------------------------------------------------------------------------
    def timing_criteria(self, timing: dict[str, float], logger: object) -> list[CriterionResult]:
        """The scenario's [timing] budgets checked against the run's timing figures."""
        out: list[CriterionResult] = []
        for key, bound in self.scenario.timing.items():
            field, _ = TIMING_BUDGETS[key]
            value = timing.get(field, math.nan)
            if key in NEEDS_CALIBRATION and self.rig.flight.board:
                ok = math.isfinite(value) and value <= bound
                out.append(CriterionResult(f"timing: {field}", f"timing.{field}", "max", value, f"<= {bound:g}", ok,
                                           _board_detail(value, bound, timing), margin=margin_of(value, None, bound)))
                continue
            if key in NEEDS_CALIBRATION and not self.rig.flight.cpu_scale_source.strip():
                out.append(CriterionResult(f"timing: {field}", f"timing.{field}", "max", value, f"<= {bound:g}", True,
                                           "no calibration: the rig has no [flight] cpu_scale_source", judged=False))
                continue
            ok = math.isfinite(value) and value <= bound
            detail = "" if math.isfinite(value) else f"no {field} figure in this run"
            out.append(CriterionResult(f"timing: {field}", f"timing.{field}", "max", value, f"<= {bound:g}", ok, detail,
                                       margin=margin_of(value, None, bound)))
        return out


def _board_detail(value: float, bound: float, timing: dict[str, float]) -> str:
    """A compute budget on a board run: where it was judged, and the margin left."""
    mhz = timing.get("board_cclk_hz", math.nan) / 1e6
    where = f"judged on the emulated LPC2148 at {mhz:g} MHz (target cycles)"
    if not math.isfinite(value):
        return f"{where}; no compute figure in this run"
    margin = bound - value
    word = "margin" if margin >= 0 else "over by"
    return f"{where}; {word} {abs(margin):.0f} us ({abs(margin) / bound:.0%} of the budget)"


def _set_payload(plant: Plant, ev: PayloadEvent, t_ns: int) -> None:
    plant.set_payload(ev.extra_mass_kg, ev.r_B_m)


def _add_wind(plant: Plant, ev: WindEvent, until_ns: int | None, t_ns: int) -> None:
    plant.add_wind(ev.wind_N_mps, until_ns)
