"""The compiled device models, plant and tick path fly exactly like their Python sources.

``pip install`` compiles ``emulators``, ``hil.plant`` and the bench's tick path (the tick
loop, the device wiring, the scheduler, the run logger, the streaming trace and criteria) with
mypyc (setup.py); the ``.py`` files stay the reference. Here the same lockstep flight runs
twice in fresh processes: once on the installed (compiled) modules, once on a copy of the
sources with no compiled module in it. Every byte on the control wires, every plant truth
message and every criterion's verdict on the flight must be the same.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import emulators
from hil.record import iter_messages, read_wire
from tests.system.test_determinism import CONTROL_WIRES

pytestmark = [pytest.mark.system, pytest.mark.pty]

ROOT = Path(emulators.__file__).resolve().parent.parent
#: a flight that moves the plant (climb and settle) and exercises every wire
SCENARIO, DURATION_S = "altitude-step", 4.0

FLY = """
import json, sys
from pathlib import Path
import emulators.base, emulators.mcp3204.device, hil.plant.plant, hil.flight.tickloop, hil.flight.devices, hil.analysis.criteria_stream
from hil.flight.tickloop import Mode
from hil.flight.run import run_flight
res = run_flight(None, sys.argv[1], mode=Mode.LOCKSTEP, duration_s=float(sys.argv[2]), out_dir=Path(sys.argv[3]))
# the flight's criteria (host timing figures left out: they measure the host, not the flight)
criteria = [(c.name, repr(c.value), c.passed, c.detail) for c in res.criteria if not c.signal.startswith("timing.")]
print(json.dumps({"end": res.end_reason.value, "log": str(res.log_path), "criteria": criteria,
                  "modules": [emulators.base.__file__, emulators.mcp3204.device.__file__, hil.plant.plant.__file__,
                              hil.flight.tickloop.__file__, hil.flight.devices.__file__, hil.analysis.criteria_stream.__file__]}))
"""


def is_compiled(path: str) -> bool:
    return not path.endswith(".py")


def interpreted_copy(dest: Path) -> Path:
    """The project's Python sources (and data, and the clock shim, which is C) without any
    mypyc-compiled module."""
    compiled = shutil.ignore_patterns("*.so", "__pycache__")
    for package in ("emulators", "hil", "flightcode"):
        shutil.copytree(ROOT / package, dest / package, ignore=compiled)
    shutil.copytree(ROOT / "rigs", dest / "rigs")
    for shim in (ROOT / "hil" / "vtime").glob("_shim*.so"):
        shutil.copy2(shim, dest / "hil" / "vtime" / shim.name)
    return dest


def fly(out_dir: Path, pythonpath: Path | None) -> dict:
    env = dict(os.environ)
    if pythonpath is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(pythonpath), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    proc = subprocess.run(
        [sys.executable, "-c", FLY, SCENARIO, str(DURATION_S), str(out_dir)],
        env=env, cwd=out_dir.parent, capture_output=True, text=True, timeout=240,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


#: the plant's truth and what the emulators made of it, in sim time
SIM_TOPICS = ("/sim/truth", "/hil/imu/sample", "/hil/adc/conversion", "/hil/esc/output")


def sim_messages(log: Path) -> list[tuple[str, str]]:
    """The log's sim-time messages in order, host stamps left out: the MCAP log time is the
    run's wall-clock start plus sim time, and ``*host*`` fields are host clocks."""
    out = []
    for topic, _, msg in iter_messages(log, SIM_TOPICS):
        kept = {k: v for k, v in msg.items() if "host" not in k}
        out.append((topic, json.dumps(kept, sort_keys=True)))
    return out


def test_compiled_and_interpreted_fly_the_same(tmp_path: Path) -> None:
    compiled = fly(tmp_path / "compiled", None)
    if not all(is_compiled(p) for p in compiled["modules"]):
        pytest.skip(f"this install is not compiled (built with HIL_PURE_PYTHON=1?): {compiled['modules']}")
    source = interpreted_copy(tmp_path / "src")
    interpreted = fly(tmp_path / "interpreted", source)
    assert not any(is_compiled(p) for p in interpreted["modules"]), interpreted["modules"]
    assert all(p.startswith(str(source)) for p in interpreted["modules"]), interpreted["modules"]

    assert compiled["end"] == interpreted["end"] == "completed"
    assert compiled["criteria"], "the scenario has criteria on the flight"
    assert compiled["criteria"] == interpreted["criteria"]
    a, b = Path(compiled["log"]), Path(interpreted["log"])
    for port, direction in CONTROL_WIRES:
        wa, wb = read_wire(a, port, direction), read_wire(b, port, direction)
        assert len(wa) > 0, (port, direction)
        assert wa == wb, f"{port}/{direction}: compiled and interpreted differ ({len(wa)} vs {len(wb)} bytes)"
    ma, mb = sim_messages(a), sim_messages(b)
    assert {topic for topic, _ in ma} == set(SIM_TOPICS)
    assert ma == mb
