"""The compiled build flies exactly like the Python sources.

``hil build`` compiles ``emulators``, ``hil.plant`` and the bench's tick path (the tick loop,
the device wiring, the scheduler, the run logger, the streaming trace and criteria) with mypyc;
the ``.py`` files stay the reference. The same lockstep flight runs twice in fresh processes,
once on the compiled build and once interpreted (``HIL_NATIVE=0``). Every byte on the control
wires, every plant truth message and every criterion's verdict must be the same.

The flight (tests/system/data/equivalence.toml, 22 s) covers what a build could change: mean
wind with Dryden turbulence, a wire fault (ADC bit errors) and the driver's resync, an altitude
step, the RC through the SBUS front-end, and the ground XBee in transparent mode.

Where the environment has no fresh compiled build, the test compiles one into a temporary
directory first, at -O0 (under a minute on 2 cores, against 2-4 minutes at the build's -O2):
the suite checks mypyc's compiled semantics on any machine that can compile. gcc contracts no
floating-point operations for baseline x86-64 at any level, so the flight is the same bits;
`.ci/run` then runs this test again against the `hil build` users get.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import tomli_w

from hil import native
from hil.config import load_toml
from hil.flight.run_files import deep_merge
from hil.native.build import BuildError, build, preflight
from hil.native.sources import project_root
from hil.record import iter_messages, read_wire
from tests.system.test_determinism import CONTROL_WIRES

pytestmark = [pytest.mark.system, pytest.mark.pty]

ROOT = project_root()
SCENARIO = Path(__file__).parent / "data" / "equivalence.toml"
#: the paper's rig with the SBUS front-end and a transparent ground XBee
RIG_OVERRIDES = {
    "rc": {"frontend": "sbus"},
    "telemetry": {"ground": {"ap": 0}},
    "flight": {"overrides": {"rc": {"frontend": "sbus"}}},
}
#: the modules that say which way a process ran
PROBES = ("emulators.base", "emulators.rc.sbus", "emulators.xbee.module", "hil.plant.plant", "hil.plant.dryden",
          "hil.flight.tickloop", "hil.flight.devices", "hil.analysis.criteria_stream")

FLY = """
import importlib, json, sys
from pathlib import Path
from hil.flight.tickloop import Mode
from hil.flight.run import run_flight
res = run_flight(sys.argv[1], sys.argv[2], mode=Mode.LOCKSTEP, out_dir=Path(sys.argv[3]))
# the flight's criteria (host timing figures left out: they measure the host, not the flight)
criteria = [(c.name, repr(c.value), c.passed, c.detail) for c in res.criteria if not c.signal.startswith("timing.")]
files = {name: str(getattr(importlib.import_module(name), "__file__", "")) for name in sys.argv[4].split(",")}
print(json.dumps({"end": res.end_reason.value, "sim_s": res.sim_s, "log": str(res.log_path), "criteria": criteria,
                  "files": files}))
"""


@pytest.fixture(scope="session")
def compiled_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh compiled build: the environment's, or one compiled for this session."""
    if native.state().compiled:
        return native.build_dir()
    try:
        preflight()
    except BuildError as exc:
        pytest.skip(f"cannot compile here: {exc}")
    directory = tmp_path_factory.mktemp("native") / "build"
    build(directory=directory, opt_level="0")
    return directory


def rig_file(dest: Path) -> Path:
    rig = ROOT / "rigs" / "paper-quad.toml"
    data = deep_merge(load_toml(rig), RIG_OVERRIDES)
    data["flight"]["config"] = str((rig.parent / data["flight"]["config"]).resolve())
    path = dest / "paper-quad.toml"
    path.write_text(tomli_w.dumps(data))
    return path


def fly(rig: Path, out_dir: Path, env_over: dict[str, str]) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("HIL_NATIVE", "HIL_NATIVE_DIR")}
    env.update(env_over)
    proc = subprocess.run([sys.executable, "-c", FLY, str(rig), str(SCENARIO), str(out_dir), ",".join(PROBES)],
                          env=env, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return {**json.loads(proc.stdout.strip().splitlines()[-1]), "stderr": proc.stderr[-2000:]}


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


def test_compiled_and_interpreted_fly_the_same(tmp_path: Path, compiled_dir: Path) -> None:
    rig = rig_file(tmp_path)
    compiled = fly(rig, tmp_path / "compiled", {"HIL_NATIVE_DIR": str(compiled_dir)})
    interpreted = fly(rig, tmp_path / "interpreted", {"HIL_NATIVE": "0"})
    assert all(str(compiled_dir) in f and f.endswith(".so") for f in compiled["files"].values()), compiled
    assert all(f.endswith(".py") for f in interpreted["files"].values()), interpreted["files"]

    assert compiled["end"] == interpreted["end"] == "completed"
    assert compiled["sim_s"] >= 20.0
    assert compiled["criteria"], "the scenario has criteria on the flight"
    assert compiled["criteria"] == interpreted["criteria"]
    a, b = Path(compiled["log"]), Path(interpreted["log"])
    for port, direction in [*CONTROL_WIRES, ("telemetry", "rx"), ("ground", "tx")]:
        wa, wb = read_wire(a, port, direction), read_wire(b, port, direction)
        assert len(wa) > 0, (port, direction)
        assert wa == wb, f"{port}/{direction}: compiled and interpreted differ ({len(wa)} vs {len(wb)} bytes)"
    ma, mb = sim_messages(a), sim_messages(b)
    assert {topic for topic, _ in ma} == set(SIM_TOPICS)
    assert ma == mb
