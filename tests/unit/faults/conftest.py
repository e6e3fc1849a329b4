from __future__ import annotations

import pytest

from hil.config.rig import Rig, load_rig
from tests.unit.faults.harness import flight_rig


@pytest.fixture(scope="session")
def rig() -> Rig:
    """The default rig (rigs/paper-quad.toml)."""
    return load_rig(None)


@pytest.fixture(scope="session")
def frig(rig: Rig) -> Rig:
    """The default rig with the XSENS output the flight code configures."""
    return flight_rig(rig)
