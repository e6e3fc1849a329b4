"""pytest plugin ``hil_bench``: closed-loop lockstep runs driven from users' own tests.

    async def test_hover(hil_bench):
        bench = await hil_bench.start(rig="paper-quad", scenario="hover", duration_s=15)
        await bench.until(lambda b: b.truth.h_m > 1.5, timeout_s=8)      # sim seconds
        await bench.always(lambda b: 1.0 < b.truth.h_m < 3.0, for_s=2)
        async with bench.fault("imu.silence"):
            await bench.until(lambda b: max(b.esc_command.pulse_us) <= 1000, timeout_s=0.05)

Each ``start`` is one :func:`hil.flight.run.run_flight_async` (own run dir, ptys, flight-code
process, MCAP) running as a task in the test's event loop. In lockstep the flight code runs
on the bench's clock (virtual time, docs/time.md) and the bench ticks only while the test
awaits one of its waits (``until``, ``always``, ``run_for``, a fault's start or end,
``finish``): the test's own code takes no sim time, however long it runs, so what a test
sees is the same on every run and every machine. Only where lockstep falls back to the host
clock (or in realtime) does the bench tick on regardless; event-loop stalls over
``STALL_WARN_S`` are then reported as :class:`HilBenchStallWarning`.
``until`` / ``always`` / ``run_for`` judge the predicate at every tick (hook after the
tick, no polling) and return the sim time of the deciding tick; a few more ticks may pass
before the test's next statement runs. Teardown stops the run (flight code stopped, MCAP
finalized); a failing test's MCAP is kept and its path printed. See docs/pytest-plugin.md.

This module is the plugin's face: pytest options and hooks, the ``hil_bench`` fixture and the
names users import from here; the bench itself is :mod:`hil.testing`.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path
import sys
from typing import TYPE_CHECKING, Any

import pytest

from hil.testing.factory import HilBench
from hil.testing.records import (
    EscCommand,
    HilBenchStallWarning,
    InjectedFault,
    Predicate,
    PredicateFailed,
    RunEnded,
    STALL_WARN_S,
    SimTimeout,
    Truth,
)
from hil.testing.scenario import INLINE_DURATION_S, build_scenario

if TYPE_CHECKING:
    from hil.testing.bench import Bench

__all__ = [
    "INLINE_DURATION_S", "STALL_WARN_S", "Bench", "EscCommand", "HilBench", "HilBenchStallWarning", "InjectedFault",
    "Predicate", "PredicateFailed", "RunEnded", "SimTimeout", "Truth", "build_scenario", "hil_bench", "keep_dir_of",
]


def __getattr__(name: str) -> Any:
    # Bench loads the emulators' modules (numpy and all): only when asked for, not with every
    # pytest session that has the plugin installed
    if name == "Bench":
        from hil.testing.bench import Bench

        return Bench
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# -- pytest hooks and the fixture ----------------------------------------------------------------------
_FACTORY = pytest.StashKey[HilBench]()
_REPORTS = pytest.StashKey[dict[str, pytest.TestReport]]()
_KEPT = pytest.StashKey[list[tuple[str, Path]]]()


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("hil-bench", "HIL bench (hil.pytest_plugin)")
    group.addoption("--hil-keep-logs", metavar="DIR", default=None,
                    help="keep the MCAP logs of failing hil_bench tests in DIR (default: <basetemp>/hil-logs)")
    group.addoption("--hil-keep-all", action="store_true", default=False,
                    help="keep the MCAP logs of passing hil_bench tests too")
    group.addoption("--hil-require-virtual-time", action="store_true", default=False,
                    help="a lockstep bench that would fall back to the host clock (clock shim missing, "
                         "static program, LD_PRELOAD dropped) errors instead (as hil run --require-virtual-time)")
    group.addoption("--hil-live", action="store_true", default=False,
                    help="serve every hil_bench run to Foxglove on 127.0.0.1 (docs/live.md); the URL goes to stderr")
    parser.addini("hil_keep_logs", "default for --hil-keep-logs", default="")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "hil_bench: the test starts a HIL bench (added to users of the hil_bench fixture)")
    config.stash[_KEPT] = []


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if "hil_bench" in getattr(item, "fixturenames", ()):
            item.add_marker("hil_bench")


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Any:
    report: pytest.TestReport = yield
    item.stash.setdefault(_REPORTS, {})[report.when] = report
    factory = item.stash.get(_FACTORY, None)
    if factory is not None and factory.benches and report.failed:
        report.sections.append(("hil-bench", factory.describe()))
    return report


def pytest_terminal_summary(terminalreporter: Any, config: pytest.Config) -> None:
    kept = config.stash.get(_KEPT, [])
    if kept:
        terminalreporter.write_sep("-", "hil-bench: MCAP logs kept")
        for nodeid, path in kept:
            terminalreporter.write_line(f"{nodeid}: {path}")


def _live(nodeid: str, config: pytest.Config) -> Any:
    """--hil-live: loopback, a free port; the URL printed on the terminal (past the capture)."""
    from hil.live.topics import LiveConfig

    reporter = config.pluginmanager.get_plugin("terminalreporter")
    capture = config.pluginmanager.get_plugin("capturemanager")

    def announce(url: str) -> None:
        line = f"hil-live: {nodeid}: {url}"
        if reporter is None or capture is None:
            print(line, file=sys.stderr, flush=True)
            return
        with capture.global_and_fixture_disabled():  # the test's output is captured; this line is not
            reporter.write_line(line)

    return LiveConfig(announce=announce)


def keep_dir_of(config: pytest.Config, basetemp: Path) -> Path:
    """--hil-keep-logs, else the ``hil_keep_logs`` ini value, else ``<basetemp>/hil-logs``."""
    value = config.getoption("hil_keep_logs") or config.getini("hil_keep_logs")
    return Path(config.invocation_params.dir, value) if value else basetemp / "hil-logs"


async def _hil_bench(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> AsyncIterator[HilBench]:
    item = request.node
    keep = keep_dir_of(request.config, tmp_path_factory.getbasetemp())
    factory = HilBench(item.nodeid, item.name, keep_dir=keep, keep_all=bool(request.config.getoption("hil_keep_all")),
                       require_virtual_time=bool(request.config.getoption("hil_require_virtual_time")),
                       live=_live(item.nodeid, request.config) if request.config.getoption("hil_live") else None)
    item.stash[_FACTORY] = factory
    yield factory
    failed = [r for r in item.stash.get(_REPORTS, {}).values() if r.failed]
    await factory.aclose(failed[0].longreprtext if failed else None)
    request.config.stash[_KEPT].extend((item.nodeid, p) for p in factory.kept)


try:
    import pytest_asyncio
except ImportError:  # pragma: no cover - the test extra brings it
    @pytest.fixture
    def hil_bench() -> None:
        pytest.fail("the hil_bench fixture needs pytest-asyncio (pip install 'mav-hil-bench[test]')")
else:
    hil_bench = pytest_asyncio.fixture(_hil_bench, name="hil_bench")  # type: ignore[assignment]
