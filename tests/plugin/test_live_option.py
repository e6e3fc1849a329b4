"""--hil-live: every hil_bench run is served to Foxglove, its URL printed on the terminal."""

from __future__ import annotations

import pytest

pytest_plugins = ["pytester"]
pytestmark = [pytest.mark.system, pytest.mark.pty]

USER_TEST = '''
import pytest

pytestmark = pytest.mark.asyncio


async def test_served(hil_bench):
    bench = await hil_bench.start(duration_s=1.0)
    assert bench.live is not None and bench.live.host == "127.0.0.1"
    await bench.run_for(0.1)
'''


def test_hil_live_serves_each_bench_and_prints_its_url(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_user=USER_TEST)
    result = pytester.runpytest_subprocess("--hil-live", "-p", "no:cacheprovider")
    result.assert_outcomes(passed=1)
    result.stdout.fnmatch_lines(["*hil-live: test_user.py::test_served: ws://127.0.0.1:*"])


def test_without_hil_live_nothing_is_served(pytester: pytest.Pytester) -> None:
    served = 'is not None and bench.live.host == "127.0.0.1"'
    pytester.makepyfile(test_user=USER_TEST.replace(served, "is None"))
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider")
    result.assert_outcomes(passed=1)
    assert "hil-live" not in result.stdout.str() + result.stderr.str()
