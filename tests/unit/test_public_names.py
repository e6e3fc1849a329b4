"""The names users import, from the paths the docs give them, after the layout by job.

The modules that define them were split (docs/architecture.md); these paths re-export them.
A name that stops importing from here breaks users' code and examples.
"""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

PUBLIC = {
    "hil.pytest_plugin": ["Bench", "HilBench", "RunEnded", "SimTimeout", "PredicateFailed", "HilBenchStallWarning",
                          "Truth", "EscCommand", "InjectedFault", "build_scenario"],
    "hil.fleet.campaign": ["load_campaign", "run_campaign", "run_case", "start_local_cluster", "Campaign",
                           "CampaignRun", "KeepLogs", "TIMING_KEYS", "summarize", "print_summary"],
    "hil.fleet.replay": ["replay", "replay_ports", "ReplayError", "verify", "VerifyResult"],
    "hil.flight.run": ["RunResult", "run_flight", "run_flight_async", "pump_before", "write_flight_config",
                       "default_log_path", "PORTS"],
    "hil.flight.tickloop": ["TickLoop", "Mode", "Clock", "EndReason", "BootError", "TickStats"],
    "hil.record": ["Recorder", "read_topic", "iter_messages", "read_metadata", "message_counts", "read_wire"],
    "hil.record.writer": ["Recorder", "RecordBatch", "RecordStats", "RecordWriteError", "LOG_FILE_MODE", "PROFILE",
                          "ZSTD_LEVEL"],
    "hil.plant.params": ["PlantParams", "WindParams", "GustShape", "AeroParams", "VibrationParams", "BatteryParams"],
    "hil.plant": ["Plant"],
    "hil.config": ["ConfigError", "load_toml", "validate", "DEFAULT_RIG", "RIGS_DIR"],
    "hil.faults": ["FaultSchedule", "load_faults"],
}


@pytest.mark.parametrize(("module", "name"), [(m, n) for m, names in PUBLIC.items() for n in names])
def test_a_public_name_imports_from_its_documented_path(module: str, name: str) -> None:
    assert hasattr(importlib.import_module(module), name), f"{module}.{name}"


def _documented_references() -> list[str]:
    """Every ``hil.<package>.<module>.<Name>`` the docs and the README spell out."""
    found = set()
    for doc in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        found |= set(re.findall(r"\bhil(?:\.[a-z_]+)+\.[A-Za-z_][A-Za-z0-9_]*\b", doc.read_text()))
    return sorted(found)


@pytest.mark.parametrize("ref", _documented_references())
def test_what_the_docs_name_exists(ref: str) -> None:
    """A dotted name in the docs is a module, or a name in the longest module prefix."""
    parts = ref.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj: object = importlib.import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        for attr in parts[cut:]:
            assert hasattr(obj, attr), f"{ref}: {'.'.join(parts[:cut])} has no {attr}"
            obj = getattr(obj, attr)
        return
    pytest.fail(f"{ref}: no such module")
