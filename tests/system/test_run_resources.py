"""A run owns its resources from the first one on: a failure at any acquisition step leaves no
process, no open descriptor (pty or pipe), no run directory and no ``.part`` file behind, and
ends in one clean error naming the step. Two runs of the same rig, scenario and seed never
share a log name."""

from __future__ import annotations

from pathlib import Path

import pytest

import hil.flight.run
from hil.config.rig import load_rig
from hil.config.scenario import load_scenario
from hil.flight import run_setup
from hil.flight.run import RunStartError, run_flight_async
from hil.flight.tickloop import EndReason
from hil.live.topics import LiveConfig
from hil.record import read_metadata
from tests.system.conftest import explain  # clean_slate: a fixture of tests/system/conftest.py

pytestmark = [pytest.mark.system, pytest.mark.pty]

#: (step function in hil.flight.run_setup, the words of the error naming it)
STEPS = [
    ("open_serial_lines", "opening the serial lines"),
    ("make_private_dir", "creating the run directory"),
    ("open_ports", "opening the ports"),
    ("start_recorder", "starting the recorder"),
    ("write_config", "writing the flight code's config"),
    ("open_virtual_time", "setting up virtual time"),
    ("make_flight", "preparing the flight code's process"),
]


def fail_at(monkeypatch: pytest.MonkeyPatch, step: str) -> None:
    """Make run_setup's ``step`` raise an OSError naming it."""
    def injected(*_: object, **__: object) -> None:
        raise OSError(5, f"injected failure at {step}")

    monkeypatch.setattr(run_setup, step, injected)


def assert_names_step(error: BaseException, step: str, words: str) -> None:
    """One line naming the step (its words) and the injected cause."""
    message = str(error)
    assert words in message and f"injected failure at {step}" in message and "\n" not in message


def _load(scenario: str = "hover"):
    rig = load_rig(None)
    source = rig.scenario_path(scenario)
    return rig, load_scenario(source), source


@pytest.mark.parametrize(("step", "words"), STEPS)
async def test_a_failure_at_each_step_leaves_nothing(step: str, words: str, clean_slate, tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    fail_at(monkeypatch, step)
    clean_slate()
    rig, scenario, source = _load()
    out = tmp_path / "logs"
    with pytest.raises(RunStartError) as info:
        await run_flight_async(rig, scenario, scenario_source=source, duration_s=0.2, out_dir=out)
    assert_names_step(info.value, step, words)
    clean_slate(out)
    logs = list(out.glob("*.mcap")) if out.exists() else []
    started = [s for s, _ in STEPS].index(step) > [s for s, _ in STEPS].index("start_recorder")
    assert len(logs) == (1 if started else 0)
    for log in logs:  # a recorder that had started is closed: a finalized log saying why
        verdict = read_metadata(log)["verdict"]
        assert verdict["status"] == "aborted" and f"injected failure at {step}" in verdict["error"]


@pytest.mark.parametrize("live", [None, LiveConfig()], ids=["plain", "live"])
async def test_a_failure_after_the_last_step_leaves_nothing(live: LiveConfig | None, clean_slate, tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    """With --live too: the steering pipe the run had not taken yet is closed with the recorder."""
    def injected(*_: object, **__: object) -> None:
        raise RuntimeError("injected failure building the tick loop")

    monkeypatch.setattr(hil.flight.run, "TickLoop", injected)
    clean_slate()
    rig, scenario, source = _load()
    out = tmp_path / "logs"
    with pytest.raises(RuntimeError, match="injected failure building the tick loop"):
        await run_flight_async(rig, scenario, scenario_source=source, duration_s=0.2, out_dir=out, live=live)
    clean_slate(out)
    [log] = out.glob("*.mcap")
    assert read_metadata(log)["verdict"]["status"] == "aborted"


async def test_a_flight_code_that_cannot_start_leaves_nothing(clean_slate, tmp_path: Path) -> None:
    import dataclasses

    clean_slate()
    rig, scenario, source = _load()
    rig = dataclasses.replace(rig, flight=dataclasses.replace(rig.flight, command=(str(tmp_path / "no-such-program"),)))
    out = tmp_path / "logs"
    result = await run_flight_async(rig, scenario, scenario_source=source, duration_s=0.2, out_dir=out)
    assert result.end_reason is EndReason.ERROR and "no-such-program" in result.message
    clean_slate(out)
    assert result.log_path is not None and read_metadata(result.log_path)["verdict"]["end_reason"] == "bench error"


async def test_same_rig_scenario_seed_and_second_get_distinct_logs(tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "logs"
    # the clock's second is the same for both runs: their default names collide
    monkeypatch.setattr(hil.flight.run, "default_log_path", lambda out_dir, *_: out_dir / "same-second_s1.mcap")
    rig, scenario, source = _load()
    first = await run_flight_async(rig, scenario, scenario_source=source, duration_s=0.2, out_dir=out)
    second = await run_flight_async(rig, scenario, scenario_source=source, duration_s=0.2, out_dir=out)
    assert first.end_reason is EndReason.COMPLETED, explain(first)
    assert second.end_reason is EndReason.COMPLETED, explain(second)
    assert first.log_path == out / "same-second_s1.mcap"
    assert second.log_path == out / "same-second_s1-2.mcap"
    assert read_metadata(first.log_path)["verdict"] and read_metadata(second.log_path)["verdict"]


def test_a_name_taken_between_the_look_and_the_create_moves_on(tmp_path: Path) -> None:
    """Another process creates ``<log>.part`` after this one looked: its start fails, the next name is used."""
    import contextlib

    class Racing:
        def __init__(self, path: Path) -> None:
            self.path, self.pid = path, None

        def start(self) -> None:
            part = self.path.with_name(self.path.name + ".part")
            if self.path.name == "run.mcap":
                part.touch()  # the other process won this name
                raise OSError(f"recorder process could not start {self.path}: exists")
            self.pid = 1

    async def go() -> Path:
        async with contextlib.AsyncExitStack() as stack:
            rec = run_setup.start_recorder(stack, Racing, tmp_path / "run.mcap", unique=True)
            rec.pid = None  # closed by its run
            return rec.path

    import asyncio

    assert asyncio.run(go()) == tmp_path / "run-2.mcap"
