"""``hil devices`` owns its resources from the first one on, as ``hil run`` does
(tests/system/test_run_resources.py): a failure at any acquisition step - or inside one, or
after the last - leaves no process (recorder child), no open descriptor (attached serial line,
pty, pipe, socket), no run directory behind; a failing step ends in one error naming it."""

from __future__ import annotations

import io
from pathlib import Path

import pytest
from rich.console import Console

import hil.flight.devices_live
from hil.config.rig import load_rig
from hil.config.scenario import load_scenario
from hil.flight.devices_live import serve_devices
from hil.flight.run_setup import RunStartError
from hil.live.topics import LiveConfig
from hil.transport.pty import PtyPort
from tests.system.test_run_resources import STEPS as RUN_STEPS
from tests.system.test_run_resources import assert_names_step, fail_at
from tests.transport.nullmodem import null_modem

pytestmark = [pytest.mark.system, pytest.mark.pty]

#: hil devices acquires the first four of hil run's steps (the same run_setup functions)
STEPS = RUN_STEPS[: [name for name, _ in RUN_STEPS].index("start_recorder") + 1]


async def _fails(tmp_path: Path, clean_slate, error: type[BaseException], match: str,
                 **kwargs: object) -> pytest.ExceptionInfo[BaseException]:
    """``hil devices --live`` with the IMU on a real serial line (a null modem) fails with
    ``error``, and leaves nothing (checked while the null modem is still open: it is the slate's)."""
    rig = load_rig(None)
    scenario = load_scenario(rig.scenario_path("hover"))
    kwargs.setdefault("live", LiveConfig())
    async with null_modem(tmp_path, "imu") as (imu_bench, _):
        clean_slate()
        with pytest.raises(error, match=match) as info:
            await serve_devices(rig, scenario, seed=1, duration_s=30.0, console=Console(file=io.StringIO()),
                                attach={"imu": imu_bench}, **kwargs)  # type: ignore[arg-type]
        clean_slate(tmp_path / "no-logs")
    return info


@pytest.mark.parametrize(("step", "words"), STEPS)
async def test_a_failure_at_each_step_leaves_nothing(step: str, words: str, clean_slate, tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    fail_at(monkeypatch, step)
    info = await _fails(tmp_path, clean_slate, RunStartError, words)
    assert_names_step(info.value, step, words)


async def test_a_pty_that_fails_among_the_ports_leaves_nothing(clean_slate, tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """The ptys made before the failing one (and the attached line) are closed too."""
    start = PtyPort.start

    async def failing_start(self: PtyPort) -> None:
        if self.name == "rc":
            raise OSError(24, "injected failure opening the rc pty")
        await start(self)

    monkeypatch.setattr(PtyPort, "start", failing_start)
    await _fails(tmp_path, clean_slate, RunStartError, "opening the ports.*injected failure opening the rc pty")


async def test_a_failure_after_the_last_step_leaves_nothing(clean_slate, tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    """The tick loop cannot be built: the recorder child (and its live server) is stopped."""
    def injected(*_: object, **__: object) -> None:
        raise RuntimeError("injected failure building the tick loop")

    monkeypatch.setattr(hil.flight.devices_live, "TickLoop", injected)
    await _fails(tmp_path, clean_slate, RuntimeError, "injected failure building the tick loop")


async def test_a_failure_once_serving_leaves_nothing(clean_slate, tmp_path: Path) -> None:
    """Everything is up (steering on the server's pipe, the URL announced) when ``on_ready`` fails."""
    announced: list[str] = []

    def on_ready(paths: dict[str, str]) -> None:
        assert announced and set(paths) >= {"imu", "adc", "esc"}
        raise RuntimeError("injected failure once serving")

    await _fails(tmp_path, clean_slate, RuntimeError, "injected failure once serving",
                 live=LiveConfig(announce=announced.append), on_ready=on_ready)
    assert announced[0].startswith("ws://127.0.0.1:")
