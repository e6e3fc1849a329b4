"""The firmware's ARM build flown on the emulated LPC2148 (rigs/paper-quad-lpc2148.toml,
docs/board.md): a short hover in closed loop, checked against the same flight of the host
build; the same flight beside CPU hogs (identical cycles, bytes and truth); the compute budget
judged in target cycles; the 1.2 ms defect of firmware/mutation.toml failing it on the board
while its host build passes; a port fault acting on the UART's bytes; ``replay --verify``.

Flights are short (the board costs about 15 ms of host CPU a tick today, RTF 0.05-0.15 on
this loaded 2-core machine): a 6 s hover (take-off at 3.4 s), otherwise 1.5-2.5 s."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hil.analysis.timing import analyze_log
from hil.config.rig import load_rig
from hil.fleet.mutation.catalogue import load_catalogue
from hil.fleet.mutation.edits import Edit, apply_edit
from hil.fleet.verify import verify
from hil.flight.board_image import firmware_elf
from hil.flight.run_result import RunResult
from hil.flight.tick import Clock
from hil.flight.tickloop import EndReason
from hil.record import iter_messages, read_topic, read_wire
from tests.system.conftest import explain

pytestmark = [pytest.mark.system]

ROOT = Path(__file__).resolve().parents[2]
BOARD_RIG = ROOT / "rigs" / "paper-quad-lpc2148.toml"
C_RIG = ROOT / "rigs" / "paper-quad-c.toml"
COMPUTE = "timing: fc_compute_p99_us"
#: the firmware's iteration at the end of the 1 s baro zero average logs four lines and takes
#: 2.7 ms on the target: sample 400 (t = 1.0 s) is answered late (docs/board.md, "Measured")
BOOT_END_NS = 1_000_000_000
#: board against host build, same scenario and seed (measured on hover seed 1, 6 s: see
#: test_a_short_hover_flies_on_the_board_as_on_the_host): the board answers each sample 1.4 ms
#: later and its PWM latches at the next period, so the trajectories drift apart slowly
HEIGHT_MAX_M, ROLL_MAX_DEG = 0.15, 1.5


@pytest.fixture(scope="module", autouse=True)
def arm_build() -> Path:
    if shutil.which("arm-none-eabi-gcc") is None:
        pytest.skip("arm-none-eabi-gcc is not installed (firmware/install-toolchain.sh)")
    return firmware_elf(load_rig(BOARD_RIG))


def board_criterion(result: RunResult, name: str):  # type: ignore[no-untyped-def]
    return next(c for c in result.criteria if c.name == name)


def miss_times(result: RunResult) -> list[int]:
    assert result.log_path is not None
    return [int(m["t_ns"]) for _, _, m in iter_messages(result.log_path, ["/hil/timing/tick"]) if m["miss"]]


async def test_a_short_hover_flies_on_the_board_as_on_the_host(fly, tmp_path: Path) -> None:
    board = await fly("hover", rig=str(BOARD_RIG), duration_s=6.0, out_dir=tmp_path / "board")
    assert board.end_reason is EndReason.COMPLETED, explain(board)
    assert board.clock is Clock.BOARD
    assert board.trace is not None
    t, h = board.trace.signal("truth.h_m")
    assert h[-1] > 1.0, explain(board)  # took off at about 3.4 s
    _, cmd = board.trace.signal("esc.cmd_us")  # the widths on the ESC pins, what the criteria read
    assert np.min(cmd[t >= 2.5]) >= 1000 and np.max(cmd[t >= 5.0]) > 1300, explain(board)
    compute = board_criterion(board, COMPUTE)
    assert compute.passed and compute.judged, explain(board)
    assert compute.detail.startswith("judged on the emulated LPC2148 at 60 MHz (target cycles); margin ")
    for name in ("board: stacks within their regions", "board: no UART RX overrun", "board: ESC pulses on time"):
        assert board_criterion(board, name).passed, explain(board)
    assert set(miss_times(board)) <= {BOOT_END_NS}, explain(board)
    timing = board.timing
    assert timing["board_samples_dropped"] == 0 and timing["board_samples_processed"] == timing["ticks"]
    assert 0 < timing["board_loop_busy_p50_cycles"] < timing["board_loop_busy_p99_cycles"] < 150_000
    assert timing["latency_p50_us"] > 750  # the 69-byte sample takes 0.75 ms on the wire at 921600 baud

    host = await fly("hover", rig=str(C_RIG), duration_s=6.0, out_dir=tmp_path / "host")
    assert host.end_reason is EndReason.COMPLETED, explain(host)
    assert host.trace is not None
    th, hh = host.trace.signal("truth.h_m")
    np.testing.assert_array_equal(t, th)
    assert np.max(np.abs(h - hh)) < HEIGHT_MAX_M
    _, roll = board.trace.signal("truth.roll_deg")
    _, roll_host = host.trace.signal("truth.roll_deg")
    assert np.max(np.abs(roll - roll_host)) < ROLL_MAX_DEG

    log = board.log_path
    assert log is not None
    assert len(read_wire(log, "imu", "tx")) >= 69 * 2400 and read_wire(log, "imu", "rx")  # samples; the bring-up
    assert read_wire(log, "telemetry", "rx")
    spi = read_topic(log, "/hil/board/spi")
    assert spi["mosi"].size > 0
    ticks = read_topic(log, "/hil/board/tick")
    assert set(ticks["cycles"][1:].astype(int)) <= set(range(149_900, 150_100))  # a tick: 150,000 cycles
    lines = [str(m["message"]) for _, _, m in iter_messages(log, ["/fc/log"])]
    assert any("event=boot.done" in line for line in lines) and any("arm_gesture" in line for line in lines)


async def test_the_same_flight_beside_cpu_hogs(fly, tmp_path: Path) -> None:
    quiet = await fly("hover", rig=str(BOARD_RIG), duration_s=1.5, out_dir=tmp_path / "quiet")
    loaded = await fly("hover", rig=str(BOARD_RIG), duration_s=1.5, out_dir=tmp_path / "loaded", stress_cpu=4)
    for r in (quiet, loaded):
        assert r.end_reason is EndReason.COMPLETED, explain(r)
        assert r.log_path is not None and r.trace is not None
    assert quiet.log_path is not None and loaded.log_path is not None
    for name in ("truth.h_m", "truth.roll_deg", "truth.pitch_deg", "truth.rotor_omega_radps"):
        np.testing.assert_array_equal(quiet.trace.signal(name)[1], loaded.trace.signal(name)[1], err_msg=name)
    for port, direction in (("imu", "tx"), ("imu", "rx"), ("telemetry", "rx")):
        assert read_wire(quiet.log_path, port, direction) == read_wire(loaded.log_path, port, direction)
    for topic in ("/hil/board/tick", "/hil/board/spi", "/hil/board/esc", "/hil/board/capture"):
        a, b = read_topic(quiet.log_path, topic), read_topic(loaded.log_path, topic)
        for key in a:
            if key not in ("log_time_ns", "publish_time_ns"):
                np.testing.assert_array_equal(a[key], b[key], err_msg=f"{topic} {key}")
    for key in ("board_loop_busy_p50_cycles", "board_loop_busy_max_cycles", "board_instructions", "latency_max_us"):
        assert quiet.timing[key] == loaded.timing[key], key


def build_mutant(tmp_path: Path, target: str) -> Path:
    """firmware/ with the catalogue's 1.2 ms defect, built for ``target`` (arm, host)."""
    mutant = next(m for m in load_catalogue(ROOT / "firmware" / "mutation.toml").mutant
                  if m.id == "fw-loop-settle-delay")
    tree = tmp_path / "tree"
    if not tree.exists():
        shutil.copytree(ROOT / "firmware", tree / "firmware", ignore=shutil.ignore_patterns("build"))
        (tree / "flightcode").symlink_to(ROOT / "flightcode")  # the design step's sources (Makefile GEN_SRC)
        path = tree / "firmware" / mutant.file
        path.write_text(apply_edit(path.read_text(), Edit(mutant.file, mutant.old, mutant.new)))
    done = subprocess.run(["make", "-s", "-C", str(tree / "firmware"), target, f"PYTHON={sys.executable}",
                           f"FLIGHT_CONFIG={ROOT / 'rigs' / 'firmware-paper-quad.toml'}"],
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stdout + done.stderr
    return tree / "firmware" / "build" / ("arm/fc.elf" if target == "arm" else "host/fc")


def rig_flying(tmp_path: Path, base: Path, flight: dict[str, str]) -> Path:
    """``base`` with [flight] keys replaced (absolute paths: the rig lives in tmp_path)."""
    lines, out = base.read_text().splitlines(), []
    for line in lines:
        key = line.split("=", 1)[0].strip()
        if key in flight:
            line = f"{key} = {flight.pop(key)}"
        elif key == "config":
            line = f'config = "{ROOT / "rigs" / "firmware-paper-quad.toml"}"'
        out.append(line)
    path = tmp_path / f"mutant-{base.name}"
    path.write_text("\n".join(out) + "\n")
    return path


async def test_the_1_2_ms_defect_fails_the_boards_budget_and_passes_the_hosts(fly, tmp_path: Path) -> None:
    elf = build_mutant(tmp_path, "arm")
    rig = rig_flying(tmp_path, BOARD_RIG, {"firmware": f'"{elf}"'})
    mutant = await fly("hover", rig=str(rig), duration_s=2.5, out_dir=tmp_path / "mutant")
    good = await fly("hover", rig=str(BOARD_RIG), duration_s=2.5, out_dir=tmp_path / "good")
    for r in (mutant, good):
        assert r.end_reason is EndReason.COMPLETED, explain(r)
    bad, ok = board_criterion(mutant, COMPUTE), board_criterion(good, COMPUTE)
    assert ok.passed and ok.judged and "margin" in ok.detail, explain(good)
    assert not bad.passed and bad.judged and "over by" in bad.detail, explain(mutant)
    # 1.2 ms a sample: 72,000 cycles more busy time per iteration than the unmodified loop's, less
    # what saturates (a loop that never idles is busy one period an iteration: 150,000 cycles)
    assert mutant.timing["board_loop_busy_p50_cycles"] - good.timing["board_loop_busy_p50_cycles"] > 55_000
    assert mutant.timing["barrier_misses"] > 100 * good.timing["barrier_misses"]

    host_fc = build_mutant(tmp_path, "host")
    host_rig = rig_flying(tmp_path, C_RIG, {"command": f'["{host_fc}", "--config", "{{config}}"]'})
    host = await fly("hover", rig=str(host_rig), duration_s=2.5, out_dir=tmp_path / "host")
    assert host.end_reason is EndReason.COMPLETED, explain(host)
    on_host = board_criterion(host, COMPUTE)
    assert on_host.passed and not on_host.judged  # no calibration: not judged, cannot fail
    assert host.timing["barrier_misses"] == 0 and all(c.passed for c in host.criteria if c.judged and
                                                       c.signal.startswith("timing."))


async def test_port_faults_act_on_the_uarts_bytes_and_the_spi_lines(fly, tmp_path: Path) -> None:
    scenario = tmp_path / "imu-cut.toml"
    scenario.write_text((ROOT / "rigs" / "scenarios" / "arm-idle.toml").read_text().split("[[criteria]]")[0]
                        + '[[faults]]\nkind = "wire.silence"\nt_s = 1.5\nduration_s = 0.3\nport = "imu"\n'
                        + '[[faults]]\nkind = "wire.bit_flips"\nt_s = 1.05\nduration_s = 0.3\nport = "adc"\n'
                        + 'bit_error_rate = 0.02\n')
    result = await fly(str(scenario), rig=str(BOARD_RIG), duration_s=2.2)
    assert result.end_reason is EndReason.COMPLETED, explain(result)
    assert result.log_path is not None
    lines = [str(m["message"]) for _, _, m in iter_messages(result.log_path, ["/fc/log"])]
    assert any("event=imu.timeout" in line for line in lines), lines
    # noise on MISO: the firmware's MCP3204 driver refuses the readings whose null bit or
    # plausibility it breaks; none before the fault
    failed = [int(line.split("adc_failed=")[1].split()[0]) for line in lines if "adc_failed=" in line]
    assert failed and failed[0] == 0 and failed[-1] > 0, lines
    answered = read_topic(result.log_path, "/hil/timing/tick")["t_ns"]  # the samples that reached the pin
    assert not np.any((answered >= 1_500_000_000) & (answered < 1_800_000_000))
    assert np.any(answered >= 1_800_000_000)  # and after it
    assert result.timing["board_samples_processed"] < result.timing["ticks"] - 100  # 120 samples cut


def test_replay_verify_flies_a_board_run_again(tmp_path: Path) -> None:
    from hil.flight.run import run_flight

    first = run_flight(BOARD_RIG, "arm-idle", duration_s=0.6, out_dir=tmp_path / "first")
    assert first.end_reason is EndReason.COMPLETED and first.log_path is not None
    again = verify(first.log_path, tmp_path / "again")
    assert again.ok, again.report()
    assert {"imu/tx", "imu/rx", "telemetry/rx", "spi", "esc", "capture", "truth"} <= set(again.compared)
    assert again.compared["spi"] > 0 and again.compared["imu/tx"] > 0


def test_hil_timing_shows_the_loops_cycles_against_the_budget(tmp_path: Path) -> None:
    from hil.flight.run import run_flight

    run = run_flight(BOARD_RIG, "arm-idle", duration_s=0.4, out_dir=tmp_path)
    assert run.log_path is not None
    hil = Path(sys.executable).with_name("hil")
    done = subprocess.run([str(hil), "timing", str(run.log_path), "--png", str(tmp_path / "t.png")],
                          capture_output=True, text=True, timeout=300, env={"COLUMNS": "200", "PATH": ""})
    assert done.returncode == 0, done.stdout + done.stderr
    out = done.stdout
    assert "loop busy time per sample (us on the emulated LPC2148)" in out
    assert (tmp_path / "t.png").stat().st_size > 0
    rep = analyze_log(run.log_path)
    # 0.4 s of 400 Hz samples: 160 or 161 iterations (161 since the accelerometers' mean check
    # was added, which does not touch the loop's pacing); the verdict on the budget is the point
    n = rep.compute_us.n
    assert rep.board_cclk_hz == 60e6 and len(rep.board_busy_cycles) == n and n in (160, 161)
    assert "budget 2500 us = 150,000 cycles" in out and f"0 of {n} over the budget" in out
    assert rep.compute_us.p50 * 60 == pytest.approx(float(np.median(rep.board_busy_cycles)), rel=0.01)
