"""docs/analog-chain.md stays true: its rig TOML is the defaults, its numbers are the chain's."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

from emulators.analog import AnalogParams
from emulators.analog.inverse import f_B_mps2_from_codes, pressure_Pa_from_code
from emulators.buspirate import BusPirateParams
from emulators.mcp3204 import Mcp3204Params
from emulators.spidriver import SpiDriverParams
from hil.config import validate

DOC = Path(__file__).resolve().parents[3] / "docs" / "analog-chain.md"


def test_doc_rig_toml_validates_to_the_defaults() -> None:
    block = re.search(r"```toml\n(.*?)```", DOC.read_text(), re.S)
    assert block is not None
    data = tomllib.loads(block.group(1))
    assert validate(AnalogParams, data["analog"], file=DOC, section="analog") == AnalogParams()
    adc = data["adc"]
    assert validate(Mcp3204Params, adc["mcp3204"], file=DOC, section="adc.mcp3204") == Mcp3204Params()
    assert validate(BusPirateParams, adc["buspirate"], file=DOC, section="adc.buspirate") == BusPirateParams()
    assert validate(SpiDriverParams, adc["spidriver"], file=DOC, section="adc.spidriver") == SpiDriverParams()


def test_doc_worked_examples() -> None:
    text = DOC.read_text()
    rows = re.findall(r"^\| (\d+) \| ([\d ]+\.\d)", text, re.M)
    assert len(rows) == 4
    for code, pa in rows:
        expected_Pa = float(pa.replace(" ", ""))
        assert pressure_Pa_from_code(int(code), AnalogParams()) == pytest.approx(expected_Pa, abs=0.05)
    assert f_B_mps2_from_codes((1351, 1351, 1622), AnalogParams()) == pytest.approx([0, 0, -9.81], abs=0.04)
