"""Suite-wide settings.

pytest-timeout (120 s, pyproject.toml) guards against hangs, it is not a performance check.
Closed-loop tests fly tens of sim seconds: on a machine loaded several times over they take
minutes of wall time and must still pass, so the ``system`` tests get a larger guard.
"""

from __future__ import annotations

import pytest
from hypothesis import settings

# hypothesis's per-example deadline (200 ms) is a timed assertion: on a machine loaded several
# times over it fails tests whose code is right (explicit @settings still override this)
settings.register_profile("loaded-host", deadline=None)
settings.load_profile("loaded-host")

#: wall seconds for a closed-loop test before pytest-timeout ends it
SYSTEM_TIMEOUT_S = 900


def pytest_report_header(config: pytest.Config) -> str:
    # which way the device models, the plant and the tick path run (`hil build`, hil/native/)
    from hil import native

    return f"hil: {native.describe()}"


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if item.get_closest_marker("system") is not None and item.get_closest_marker("timeout") is None:
            item.add_marker(pytest.mark.timeout(SYSTEM_TIMEOUT_S))
