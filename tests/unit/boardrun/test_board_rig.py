"""A rig that flies a board: ``[flight] board`` and ``firmware`` validated like every rig key
(file, key, reason; ``hil run`` exits 2 before anything is created); what a board run refuses
(realtime, attached lines, faults on ports it does not have, process faults); the run's flight
config written into the image, and refused when it does not fit."""

from __future__ import annotations

import asyncio
import subprocess
import sys
from pathlib import Path

import pytest

from hil.board.core import Core
from hil.board.elf import FirmwareImage, Segment
from hil.config import ConfigError
from hil.config.rig import load_rig
from hil.config.scenario import load_scenario
from hil.faults import load_faults
from hil.flight.board_image import flight_config_text, install_config
from hil.flight.run import run_flight_async
from hil.flight.tickloop import Mode

ROOT = Path(__file__).resolve().parents[3]
BOARD_RIG = ROOT / "rigs" / "paper-quad-lpc2148.toml"


def rig_with(tmp_path: Path, flight: str, name: str = "board-rig") -> Path:
    """The board rig with its [flight] table replaced by ``flight`` (its config beside it)."""
    text = BOARD_RIG.read_text()
    head, rest = text.split("[flight]\n", 1)
    rest = rest[rest.index("\n[record]"):]
    path = tmp_path / f"{name}.toml"
    path.write_text(f"{head}[flight]\n{flight}\nconfig = \"{ROOT / 'rigs' / 'firmware-paper-quad.toml'}\"\n{rest}")
    return path


@pytest.mark.parametrize(("flight", "reason"), [
    ('board = "lpc2148"', "[flight] firmware: missing"),
    ('firmware = "arm"', "[flight] firmware: set without [flight] board"),
    ('board = "lpc2148"\nfirmware = "no/such.elf"', "is not a file"),
    ('board = "lpc2138"\nfirmware = "arm"', "board"),
])
def test_a_bad_board_table_names_file_key_and_reason(tmp_path: Path, flight: str, reason: str) -> None:
    path = rig_with(tmp_path, flight)
    with pytest.raises(ConfigError) as err:
        load_rig(path)
    assert str(path) in str(err.value) and reason in str(err.value)


def test_hil_run_exits_2_on_a_bad_board_rig(tmp_path: Path) -> None:
    path = rig_with(tmp_path, 'board = "lpc2148"')
    hil = Path(sys.executable).with_name("hil")
    done = subprocess.run([str(hil), "run", str(path), "-s", "arm-idle", "--out", str(tmp_path)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stdout + done.stderr
    assert "[flight] firmware: missing" in done.stdout + done.stderr
    assert not list(tmp_path.glob("*.mcap"))


def test_the_shipped_rig_flies_the_arm_build() -> None:
    rig = load_rig(BOARD_RIG)
    assert (rig.flight.board, rig.flight.firmware, rig.flight.firmware_target) == ("lpc2148", "arm", True)
    assert load_rig(ROOT / "rigs" / "paper-quad-c.toml").flight.board == ""


@pytest.mark.parametrize(("mode", "attach", "reason"), [
    (Mode.REALTIME, None, "lockstep only"),
    (Mode.LOCKSTEP, {"imu": "/dev/ttyUSB0"}, "cannot be attached"),
])
def test_a_board_run_refuses_realtime_and_attached_lines(tmp_path: Path, mode: Mode, attach: dict[str, str] | None,
                                                         reason: str) -> None:
    rig = load_rig(BOARD_RIG)
    scenario = load_scenario(rig.scenario_path("arm-idle"))
    with pytest.raises(ConfigError, match=reason):
        asyncio.run(run_flight_async(rig, scenario, mode=mode, attach=attach, out_dir=tmp_path))
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(("fault", "key"), [
    ({"kind": "wire.bit_flips", "t_s": 1.0, "port": "rc", "bit_error_rate": 1e-3}, "port"),
    ({"kind": "wire.silence", "t_s": 1.0, "port": "esc", "direction": "rx"}, "port"),
    # SPI's master clocks every bit: nothing to drop, duplicate or delay on the adc's lines
    ({"kind": "wire.byte_loss", "t_s": 1.0, "port": "adc", "loss_probability": 0.1}, "kind"),
    ({"kind": "wire.delay", "t_s": 1.0, "port": "adc", "delay_s": 0.01}, "kind"),
    ({"kind": "process.kill", "t_s": 1.0}, "kind"),
    ({"kind": "process.restart", "t_s": 1.0, "duration_s": 0.5}, "kind"),
])
def test_faults_a_board_cannot_take_are_refused_naming_the_key(fault: dict[str, object], key: str) -> None:
    with pytest.raises(ConfigError) as err:
        load_faults([fault], load_rig(BOARD_RIG), source="s.toml")
    assert f"(#0 ({fault['kind']}) {key}:" in str(err.value).replace("[[faults]] ", "(")


def test_port_faults_on_the_uarts_and_bit_faults_on_the_spi_lines_are_accepted() -> None:
    faults = load_faults([{"kind": "wire.bit_flips", "t_s": 1.0, "port": "imu", "bit_error_rate": 1e-4},
                          {"kind": "imu.silence", "t_s": 1.0, "duration_s": 0.2},
                          {"kind": "wire.silence", "t_s": 1.0, "port": "telemetry", "direction": "rx"},
                          {"kind": "wire.bit_flips", "t_s": 1.0, "port": "adc", "bit_error_rate": 1e-3},
                          {"kind": "wire.silence", "t_s": 1.0, "port": "adc", "direction": "both"}],
                         load_rig(BOARD_RIG), source="s.toml")
    assert [f.target for f in faults] == ["port imu tx", "imu", "port telemetry rx", "port adc tx", "port adc both"]


def fake_image(tmp_path: Path, room: int) -> tuple[Core, FirmwareImage]:
    from emulators.lpc2148 import Lpc2148

    text_at, len_at = 0x1000, 0x2000
    image = FirmwareImage(tmp_path / "fake.elf", 0, (Segment(text_at, b"x" * room + b"\0", False),
                                                     Segment(len_at, room.to_bytes(4, "little"), False)),
                          {"fw_flight_config_text": text_at, "fw_flight_config_text_len": len_at})
    core = Core(Lpc2148())  # type: ignore[arg-type]
    core.load(image)
    return core, image


def test_the_runs_config_is_written_into_the_image_where_it_fits(tmp_path: Path) -> None:
    rig = load_rig(BOARD_RIG)
    text = flight_config_text(rig, load_scenario(rig.scenario_path("paper-literal-weights")))
    assert b'law = "paper_literal"' in text  # the scenario's [flight] over the template
    core, image = fake_image(tmp_path, len(text) + 10)
    install_config(core, image, text, where="rig.toml")
    assert core.read_memory(0x1000, len(text) + 1) == text + b"\0"
    assert int.from_bytes(core.read_memory(0x2000, 4), "little") == len(text)
    core, image = fake_image(tmp_path, len(text) - 1)
    with pytest.raises(ConfigError, match=f"{len(text)} bytes; the firmware .* holds {len(text) - 1}"):
        install_config(core, image, text, where="rig.toml")
