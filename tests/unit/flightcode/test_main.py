"""``python -m flightcode``: exit statuses, and a real run on ptys ended by SIGTERM."""

from __future__ import annotations

import asyncio
import os
import signal
import sys
from pathlib import Path

import pytest

from flightcode.__main__ import BLAS_THREAD_VARS, EXIT_CONFIG, EXIT_DEVICE, main, single_threaded_blas
from hil.transport.pty import PtyPort
from tests.unit.flightcode.fakes import FakeBusPirate, FakeCaptureRc, FakeMaestro, FakeXsens

ROOT = Path(__file__).resolve().parents[3]


def _config(paths: dict[str, str], extra: str = "") -> str:
    ports = "".join(f'[ports.{n}]\npath = "{p}"\nbaud = 115200\n' for n, p in paths.items())
    return ports + extra


def test_invalid_config_exits_2_naming_file_and_key(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / "vehicle.toml"
    cfg.write_text(_config({n: "/dev/null" for n in ("imu", "adc", "rc", "esc", "telemetry")}, "[yaw]\nkp = 1\n"))
    assert main(["--config", str(cfg)]) == EXIT_CONFIG
    err = capsys.readouterr().err
    assert f"{cfg}: yaw.kp: unknown key" in err
    assert "level=error event=config.invalid" in err


def test_missing_device_exits_3_naming_it(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / "vehicle.toml"
    cfg.write_text(_config({n: str(tmp_path / f"no-{n}") for n in ("imu", "adc", "rc", "esc", "telemetry")}))
    assert main(["--config", str(cfg)]) == EXIT_DEVICE
    err = capsys.readouterr().err
    assert "device 'imu' failed at boot: cannot open" in err and "no-imu" in err


def test_blas_thread_settings_are_set_unless_given() -> None:
    environ = {"OMP_NUM_THREADS": "4"}
    single_threaded_blas(environ)
    assert environ == {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "4", "MKL_NUM_THREADS": "1"}


class PtyDevice:
    """Puts a scripted fake device (written against FakeSerial) behind a real pty."""

    def __init__(self, port: PtyPort) -> None:
        self.port = port
        self.on_write = lambda data: None
        port.on_data = lambda data, t_ns: self.on_write(data)

    def feed(self, data: bytes) -> None:
        self.port.write(data)


@pytest.mark.pty
async def test_real_ptys_boot_fly_disarmed_and_sigterm(tmp_path: Path) -> None:
    dev_dir = tmp_path / "dev"
    dev_dir.mkdir(mode=0o700)
    ports = {n: PtyPort(n, dev_dir) for n in ("imu", "adc", "rc", "esc", "telemetry")}
    for p in ports.values():
        await p.start()
    imu = FakeXsens(PtyDevice(ports["imu"]))  # type: ignore[arg-type]
    FakeBusPirate(PtyDevice(ports["adc"]), lambda ch: (2900, 2048, 2048, 1592)[ch])  # type: ignore[arg-type]
    rc = FakeCaptureRc(PtyDevice(ports["rc"]), lambda t: [1500.0, 1500.0, 1000.0, 1500.0] + [1000.0] * 4)  # type: ignore
    esc_link = PtyDevice(ports["esc"])
    maestro = FakeMaestro(esc_link)  # type: ignore[arg-type]
    telemetry = bytearray()
    ports["telemetry"].on_data = lambda data, t_ns: telemetry.extend(data)
    loop = asyncio.get_running_loop()
    measuring, command = asyncio.Event(), asyncio.Event()
    imu_write = imu.port.on_write

    def on_imu(data: bytes) -> None:
        imu_write(data)
        if imu.measuring:
            measuring.set()

    imu.port.on_write = on_imu
    esc_write = esc_link.on_write

    def on_esc(data: bytes) -> None:
        esc_write(data)
        command.set()

    esc_link.on_write = on_esc
    cfg = tmp_path / "vehicle.toml"
    cfg.write_text(_config({n: p.path for n, p in ports.items()},
                           "[rc.capture]\nlock_frames = 2\n[adc.baro]\nzero_average_s = 0.05\n"))
    env = {k: v for k, v in os.environ.items() if k not in BLAS_THREAD_VARS}  # the flight code's own choice
    proc = await asyncio.create_subprocess_exec(sys.executable, "-m", "flightcode", "--config", str(cfg),
                                                cwd=ROOT, stderr=asyncio.subprocess.PIPE, env=env)
    try:
        await asyncio.wait_for(measuring.wait(), 30)  # python-control/filterpy imports take seconds
        # numpy and scipy loaded (the loop runs): still one thread, no BLAS workers beside it
        assert os.listdir(f"/proc/{proc.pid}/task") == [str(proc.pid)]
        for k in range(100):  # lockstep: a sample, then wait for its ESC command
            command.clear()
            t_ns = k * 2_500_000
            rc.advance(t_ns)
            imu.port.feed(imu.sample(t_ns, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, -9.81)))
            await asyncio.wait_for(command.wait(), 5)
        assert maestro.commands == 101 and maestro.bad == 0  # boot minimum + one per sample
        assert maestro.pulses_us[:4] == [1000.0] * 4  # disarmed
        command.clear()
        proc.send_signal(signal.SIGTERM)
        _, err = await asyncio.wait_for(proc.communicate(), 10)
        assert proc.returncode == 0
        await asyncio.wait_for(command.wait(), 5)  # the shutdown write
        text = err.decode()
        assert "event=signal name=SIGTERM" in text and "event=shutdown" in text
        assert "event=mode old=boot new=disarmed" in text
        assert "event=gc" in text  # the loop's collector ran and handed collection back (gc_policy)
        assert telemetry.count(b"\x7e\x00\x5f\x01") >= 12  # 100 samples / 8, API TX16 frames
    finally:
        if proc.returncode is None:
            proc.kill()
            await proc.wait()
        for p in ports.values():
            p.close()
