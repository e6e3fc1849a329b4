"""firmware/mutation.toml applies to today's firmware: the catalogue validates, every anchor is
found exactly once, every estimation and control mutant still compiles (a mutant that does not
build would be "killed" by the build, not by a flight), and the parity tests of this directory
fail on a few of them (the unit tests can see a wrong gain, a sign, an off-by-one)."""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest

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
