"""firmware/gen: the design header is the Python flight code's design in single precision, read
from the config the way the flight code reads it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from flightcode.config import load
from tests.unit.firmware import cfw
from tests.unit.firmware.conftest import PORTS, write_config

sys.path.insert(0, str(cfw.ROOT / "firmware"))
from gen import design as gen_design  # noqa: E402
from gen import emit  # noqa: E402


@pytest.mark.parametrize("which", ["rig", "template"])
def test_the_compiled_design_is_flightcodes_rounded_to_float32(which: str, request: pytest.FixtureRequest) -> None:
    lib: cfw.Lib = request.getfixturevalue("lib" if which == "rig" else "template_lib")
    cfg = load(request.getfixturevalue("rig_config" if which == "rig" else "template_config"))
    d = gen_design.design(cfg)
    c = lib.design()
    np.testing.assert_array_equal(c["F"], d.kf.F.astype(np.float32))
    np.testing.assert_array_equal(c["B"], d.kf.B[:, 0].astype(np.float32))
    np.testing.assert_array_equal(c["Q"], d.kf.Q.astype(np.float32))
    np.testing.assert_array_equal(c["lqi"], np.array([*d.lqi.F1, d.lqi.F2], dtype=np.float32))
    assert c["T_s"] == np.float32(cfg.T_s)


def test_the_two_configs_give_different_gains(lib: cfw.Lib, template_lib: cfw.Lib) -> None:
    # the rig's q_int 0.04 and q_z 0.003 against the template's 8.25e-3: a header that ignored
    # the config would pass the test above for one of them only
    assert not np.array_equal(lib.design()["lqi"], template_lib.design()["lqi"])


def test_design_inputs_are_written_as_exact_doubles(rig_config: Path, tmp_path: Path) -> None:
    (header,) = cfw.gen.generate(rig_config, tmp_path)
    text = header.read_text()
    cfg = load(rig_config)
    for dotted, member, is_int in gen_design.DESIGN_INPUTS:
        value = getattr(getattr(cfg, dotted.split(".")[0]), dotted.split(".")[1])
        literal = text.split(f"#define {emit.macro_name(dotted, 'FC_DESIGN')} ")[1].split("\n")[0]
        assert (int(literal) if is_int else float(literal)) == value, dotted
        assert f'X("{dotted}", {member}, ' in text
    assert "#define FC_DESIGN_ALTITUDE_Q_INT 0.04\n" in text


def test_float_literals_read_back_as_the_float32(tmp_path: Path) -> None:
    values = [0.1, 1e-6 * 0.0025, 2.0 / 3.0, 338.9, -0.0908295, 1.0, 0.0, 3.0e-6, 123456789.0]
    src = tmp_path / "lit.c"
    src.write_text('#include <stdio.h>\nint main(void){\n' + "".join(
        f'    printf("%a\\n", (double){emit.c_float(v)});\n' for v in values) + "    return 0;\n}\n")
    exe = tmp_path / "lit"
    subprocess.run([*cfw.hostlib.compiler(), "-std=c11", "-o", str(exe), str(src)], check=True)
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split()
    assert [float.fromhex(h) for h in out] == [float(np.float32(v)) for v in values]


def test_a_bad_config_exits_2_naming_the_key(tmp_path: Path) -> None:
    bad = write_config(tmp_path, "bad", "[altitude]\nq_int = -1.0\n")
    proc = subprocess.run([sys.executable, str(cfw.ROOT / "firmware" / "gen"), "--config", str(bad), "--out",
                           str(tmp_path / "out")], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.strip() == f"firmware/gen: {bad}: altitude.q_int: must be > 0 (got -1.0)"
    assert not (tmp_path / "out" / "fc_design.h").exists()


def test_the_cli_writes_the_header_and_rewrites_it_only_when_it_changes(tmp_path: Path) -> None:
    cfg = write_config(tmp_path, "c")
    out = tmp_path / "out"
    cmd = [sys.executable, str(cfw.ROOT / "firmware" / "gen"), "--config", str(cfg), "--out", str(out)]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=True)
    header = out / "fc_design.h"
    assert proc.stdout.strip() == str(header)
    stamp = header.stat().st_mtime_ns
    subprocess.run(cmd, check=True)
    assert header.stat().st_mtime_ns == stamp  # unchanged text: make rebuilds nothing
    cfg.write_text(PORTS + "[altitude]\nq_int = 0.02\n")
    subprocess.run(cmd, check=True)
    assert "#define FC_DESIGN_ALTITUDE_Q_INT 0.02\n" in header.read_text()
