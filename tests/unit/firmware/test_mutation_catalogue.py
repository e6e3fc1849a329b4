"""firmware/mutation.toml applies to today's firmware: the catalogue validates, every anchor is
found exactly once, every estimation and control mutant still compiles (a mutant that does not
build would be "killed" by the build, not by a flight), and the parity tests of this directory
fail on a few of them (the unit tests can see a wrong gain, a sign, an off-by-one)."""

from __future__ import annotations

import math
import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from flightcode.config import FlightConfig
from hil.fleet.mutation.catalogue import Mutant, load_catalogue
from hil.fleet.mutation.edits import Edit, apply_edit
from tests.unit.firmware import cfw
from tests.unit.firmware import test_altitude_kf_parity as kf_parity
from tests.unit.firmware import test_baro_motion_parity as bm_parity
from tests.unit.firmware import test_control_parity as ctl_parity
from tests.unit.firmware import test_plausibility_parity as pl_parity

FIRMWARE = cfw.ROOT / "firmware"
CATALOGUE = load_catalogue(FIRMWARE / "mutation.toml")
MUTANTS = {m.id: m for m in CATALOGUE.mutant}
MINE = [m for m in CATALOGUE.mutant if m.file.startswith(("src/estimation/", "src/control/"))]


def test_the_catalogue_names_the_firmware_tree() -> None:
    assert (cfw.ROOT / CATALOGUE.target.tree).resolve() == FIRMWARE
    assert len(MINE) >= 30
    kinds = {m.kind for m in MINE}
    assert {"integer overflow", "float/int truncation", "off-by-one", "unsigned compare", "integer division",
            "wrong dt", "missing reset", "sign"} <= kinds


@pytest.mark.parametrize("mutant", CATALOGUE.mutant, ids=lambda m: m.id)
def test_every_anchor_is_found_once(mutant: Mutant) -> None:
    path = FIRMWARE / mutant.file
    assert path.is_file(), f"{mutant.id}: {mutant.file} is not in firmware/"
    assert path.read_text().count(mutant.old) == 1, f"{mutant.id}: the old text must occur exactly once"
    assert mutant.old != mutant.new


def mutated_src(mutant: Mutant, into: Path) -> Path:
    """A copy of firmware/src with the mutant's edit applied; returns the copy's src."""
    src = into / "src"
    shutil.copytree(FIRMWARE / "src", src)
    rel = Path(mutant.file).relative_to("src")
    (src / rel).write_text(apply_edit((src / rel).read_text(), Edit(str(rel), mutant.old, mutant.new)))
    return src


@pytest.mark.parametrize("mutant", MINE, ids=lambda m: m.id)
def test_every_mutant_compiles(mutant: Mutant, tmp_path: Path) -> None:
    src = mutated_src(mutant, tmp_path)
    flags = [f for f in cfw.hostlib.CFLAGS if f != "-Werror"]
    sources = cfw.hostlib.estctl_sources(src) if mutant.file.endswith(".h") else (src / Path(mutant.file).relative_to("src"),)
    for c_file in sources:
        proc = subprocess.run([*cfw.hostlib.compiler(), *flags, f"-I{src}", "-c", "-o", str(tmp_path / "m.o"),
                               str(c_file)], capture_output=True, text=True)
        assert proc.returncode == 0, f"{mutant.id} does not build:\n{proc.stderr}"


#: (mutant, the parity test that must fail on it)
KILLS: list[tuple[str, Callable[[cfw.Lib, FlightConfig], None]]] = [
    ("fw-ctl-lqi-integral-sign", ctl_parity.test_lqi_random_inputs_saturating_both_ways),
    ("fw-est-kf-acc-innovation-sign", kf_parity.test_random_inputs_including_non_finite_and_resets),
    ("fw-est-flat-ring-off-by-one", lambda lib, cfg: pl_parity.test_flat_line_verdicts_over_a_long_trace(lib, 1)),
    ("fw-est-baro-motion-ring-newest-off-by-one", lambda lib, cfg: bm_parity.test_identical_on_an_exact_grid(lib, 11)),
]


@pytest.mark.parametrize("mutant_id, parity", KILLS, ids=[k for k, _ in KILLS])
def test_the_parity_tests_fail_on_a_mutant(mutant_id: str, parity: Callable[[cfw.Lib, FlightConfig], None],
                                           rig_config: Path, rig_cfg: FlightConfig, lib: cfw.Lib,
                                           tmp_path: Path) -> None:
    parity(lib, rig_cfg)  # today's firmware passes
    mutant_lib = cfw.build(rig_config, tmp_path / "lib", src=mutated_src(MUTANTS[mutant_id], tmp_path))
    with pytest.raises(AssertionError):
        parity(mutant_lib, rig_cfg)


# -- the equivalents' claims (firmware/mutation-equivalents.toml) -----------------------------------
@pytest.fixture(scope="module")
def unclamped_yaw(rig_config: Path, tmp_path_factory: pytest.TempPathFactory) -> cfw.Lib:
    out = tmp_path_factory.mktemp("yaw-unclamped")
    return cfw.build(rig_config, out / "lib", src=mutated_src(MUTANTS["fw-ctl-yaw-integrator-unbounded"], out))


def _yaw_drive(lib: cfw.Lib, kp: float, ki: float, lim: float, seed: int) -> list[tuple[float, float]]:
    """The yaw loop's torque and integrator over 2000 steps of rates past the limit, with the
    mixer clipping, resets and NaN references (as the parity test drives it)."""
    c = cfw.CYaw(lib, kp, ki, lim, 0.0025)
    assert c.ok
    rng = np.random.default_rng(seed)
    refs, meas = ctl_parity.f32s(2000, rng, 1.5), ctl_parity.f32s(2000, rng, 1.0)
    out = []
    for k in range(2000):
        u = c.update(refs[k] if k % 333 else math.nan, meas[k], k % 700 > 20)
        if k % 3 == 0:
            c.set_applied(ctl_parity.f32(u * rng.uniform(-0.2, 1.0)))
        out.append((u, c.read()[0]))
    return out


@settings(max_examples=30)
@given(seed=st.integers(0, 2**32 - 1), kp=st.floats(0.0, 1.0), ki=st.floats(0.0, 1.0), lim=st.floats(0.01, 0.5))
@example(seed=1, kp=0.15, ki=0.15, lim=0.15)  # the shipped gains (rigs/firmware-paper-quad.toml [yaw])
def test_the_yaw_integrators_clamp_never_acts_while_kp_is_at_least_ki_T(
        lib: cfw.Lib, unclamped_yaw: cfw.Lib, seed: int, kp: float, ki: float, lim: float) -> None:
    # Unsaturated, |kp e + i| < lim, and a step ki T e no larger than kp e keeps |i| < lim; the
    # mixer's unwinding only shrinks |i|: so the clamp is a no-op and the mutant is equivalent.
    assume(kp >= ki * 0.0025)
    assert _yaw_drive(unclamped_yaw, kp, ki, lim, seed) == _yaw_drive(lib, kp, ki, lim, seed)


def test_a_pure_integral_yaw_loop_tells_the_unclamped_integrator_apart(lib: cfw.Lib, unclamped_yaw: cfw.Lib) -> None:
    # the equivalence needs kp >= ki T: with kp = 0 the integral is the torque, and its last step
    # before the limit (0.0475 + 0.003 per step here) carries it past 0.05 where the clamp acts
    integrals = []
    for which in (lib, unclamped_yaw):
        c = cfw.CYaw(which, 0.0, 1.2, 0.05, 0.0025)
        for _ in range(40):
            c.update(1.0, 0.0, True)
        integrals.append(c.read()[0])
    assert integrals[0] == pytest.approx(0.05) and integrals[1] == pytest.approx(0.051)
