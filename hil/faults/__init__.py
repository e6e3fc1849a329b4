"""Fault injection: one catalogue of faults, scheduled in sim time, seeded, logged.

    from hil.faults import CATALOGUE, FaultSchedule, load_faults

    faults = load_faults(scenario.faults, rig, source=str(scenario_path))   # refuses at load
    schedule = FaultSchedule(faults, devices, log_event=logger.event, flight=flight)
    ... each tick: schedule.before_tick(t_ns)
    ... at the end: schedule.finish(t_ns); await schedule.aclose()

See docs/faults.md for the catalogue and the scenario syntax.
"""

from hil.faults.base import Fault, FaultParams, Layer, Refused, ScheduledFault, Timing
from hil.faults.catalogue import CATALOGUE, catalogue_table, print_catalogue
from hil.faults.loader import check_fault, load_faults
from hil.faults.schedule import ActiveFault, FaultHandle, FaultSchedule

__all__ = [
    "CATALOGUE",
    "ActiveFault",
    "Fault",
    "FaultHandle",
    "FaultParams",
    "FaultSchedule",
    "Layer",
    "Refused",
    "ScheduledFault",
    "Timing",
    "catalogue_table",
    "check_fault",
    "load_faults",
    "print_catalogue",
]
