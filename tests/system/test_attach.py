"""Rig ports on real serial lines: null-modem pty pairs and a loopback socket://.

`hil devices` serves the IMU over a null modem (a pyserial client), the ground XBee over a
null modem (the unmodified PyPI digi-xbee client) and the Maestro over socket://; `hil run`
in realtime flies our flight code through five null modems; errors name port and path.
"""

from __future__ import annotations

import asyncio
import io
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
import serial
import tomli_w
from rich.console import Console

from hil.config.attach import PortAttachment, load_ports_table, parse_attach_flags, refuse_lockstep, resolve_attachments
from hil.config import ConfigError
from hil.flight.devices_live import serve_devices
from hil.config.rig import load_rig
from hil.config.scenario import load_scenario
from tests.transport.nullmodem import loopback_server, null_modem

pytestmark = [pytest.mark.pty]
REPO = Path(__file__).resolve().parents[2]


def _xbus(mid: int, payload: bytes = b"") -> bytes:
    body = bytes([0xFF, mid, len(payload)]) + payload
    return b"\xfa" + body + bytes([(-sum(body)) & 0xFF])


# -- configuration ---------------------------------------------------------------------------
def test_ports_table_validates_with_file_key_reason() -> None:
    ok = load_ports_table({"imu": {"device": "/dev/ttyUSB0", "parity": "E", "stopbits": 2}}, file="r.toml")
    assert ok == {"imu": PortAttachment("/dev/ttyUSB0", parity="E", stopbits=2)}
    with pytest.raises(ConfigError, match=r"^r.toml: \[ports\] gps: unknown key"):
        load_ports_table({"gps": {"device": "/dev/ttyUSB0"}}, file="r.toml")
    with pytest.raises(ConfigError, match=r"r.toml: \[ports.imu\] parity"):
        load_ports_table({"imu": {"device": "/dev/ttyUSB0", "parity": "X"}}, file="r.toml")
    with pytest.raises(ConfigError, match=r"r.toml: \[ports.imu\] baud: .*(not permitted|Unexpected)"):
        load_ports_table({"imu": {"device": "/dev/ttyUSB0", "baud": 9600}}, file="r.toml")
    with pytest.raises(ConfigError, match=r"r.toml: \[ports.imu\] device: must not be empty"):
        load_ports_table({"imu": {"device": " "}}, file="r.toml")


def test_attach_flags() -> None:
    assert parse_attach_flags(["imu=/dev/ttyUSB0", "esc=socket://h:4001"]) == {
        "imu": "/dev/ttyUSB0", "esc": "socket://h:4001"}
    for bad, why in (("imu", "expected PORT=DEVICE"), ("gps=/dev/x", "unknown port 'gps'"),
                     ("imu=", "expected PORT=DEVICE")):
        with pytest.raises(ConfigError, match=why):
            parse_attach_flags([bad])
    with pytest.raises(ConfigError, match="given twice"):
        parse_attach_flags(["imu=/dev/a", "imu=/dev/b"])


def test_flags_override_the_rig_device_and_keep_its_framing() -> None:
    rig_ports = {"imu": PortAttachment("/dev/ttyUSB0", parity="E")}
    got = resolve_attachments(rig_ports, {"imu": "/dev/ttyUSB3", "esc": "/dev/ttyACM0"}, ("imu", "esc"), command="run")
    assert got == {"imu": PortAttachment("/dev/ttyUSB3", parity="E"), "esc": PortAttachment("/dev/ttyACM0")}
    with pytest.raises(ConfigError, match="`hil run` has no port 'adc-spidriver'"):
        resolve_attachments({}, {"adc-spidriver": "/dev/x"}, ("imu",), command="run")


def test_lockstep_refused_on_a_real_port() -> None:
    with pytest.raises(ConfigError, match=r"port imu is attached to /dev/ttyUSB0: .* realtime only.*--mode realtime"):
        refuse_lockstep({"imu": PortAttachment("/dev/ttyUSB0")}, "lockstep")
    refuse_lockstep({"imu": PortAttachment("/dev/ttyUSB0")}, "realtime")
    refuse_lockstep({}, "lockstep")


# -- the CLI: error, rc 2, nothing started ----------------------------------------------------
def _hil(args: list[str], tmp: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, TMPDIR=str(tmp), COLUMNS="300")
    return subprocess.run([sys.executable, "-m", "hil.cli", *args], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("command", [["devices", "--duration", "5"], ["run", "--mode", "realtime", "--duration", "5"]])
def test_missing_device_is_an_error_and_nothing_starts(command: list[str], tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    runs.mkdir()
    missing = tmp_path / "ttyUSB9"
    proc = _hil([*command, "--attach", f"imu={missing}", "--no-record"] if command[0] == "run"
                else [*command, "--attach", f"imu={missing}"], runs)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stderr.strip() == f"error: port imu: {missing}: cannot open: no such device"
    assert proc.stdout == ""
    assert list(runs.iterdir()) == []


def test_lockstep_with_an_attached_port_is_refused(tmp_path: Path) -> None:
    proc = _hil(["run", "--attach", "imu=/dev/ttyUSB0"], tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.startswith("error: port imu is attached to /dev/ttyUSB0: a real serial port runs in realtime only")
    assert list(tmp_path.iterdir()) == []


async def test_busy_device_through_the_cli(tmp_path: Path) -> None:
    async with null_modem(tmp_path) as (bench_end, _):
        holder = serial.Serial(bench_end, exclusive=True)
        try:
            runs = tmp_path / "runs"
            runs.mkdir()
            proc = await asyncio.to_thread(_hil, ["devices", "--duration", "5", "--attach", f"adc={bench_end}"], runs)
            assert proc.returncode == 2
            assert proc.stderr.startswith(f"error: port adc: {bench_end}: cannot open: busy")
            assert list(runs.iterdir()) == []
        finally:
            holder.close()


# -- hil devices: clients through real lines ----------------------------------------------------
async def test_devices_over_null_modems_and_socket(tmp_path: Path) -> None:
    from digi.xbee.devices import XBeeDevice
    from digi.xbee.models.protocol import XBeeProtocol

    rig = load_rig(None)
    scenario = load_scenario(rig.scenario_path("hover"))
    async with null_modem(tmp_path, "imu") as (imu_bench, imu_client), \
            null_modem(tmp_path, "ground") as (ground_bench, ground_client), loopback_server() as esc_server:
        paths: dict[str, str] = {}
        ready = asyncio.Event()

        def on_ready(p: dict[str, str]) -> None:
            paths.update(p)
            ready.set()

        console = Console(file=io.StringIO(), width=300)
        server = asyncio.create_task(serve_devices(
            rig, scenario, seed=1, duration_s=None, console=console, on_ready=on_ready,
            attach={"imu": imu_bench, "ground": ground_bench, "esc": esc_server.url}))
        try:
            await asyncio.wait_for(ready.wait(), 30)
            printed = console.file.getvalue()  # type: ignore[attr-defined]
            assert f"imu            {imu_bench}  (XSENS MTi (Xbus), attached, {rig.imu.baud_bps} baud 8N1)" in printed
            assert paths["esc"] == esc_server.url and paths["adc"].endswith("/dev/adc")  # the rest: ptys

            def imu_client_session() -> bytes:
                with serial.Serial(imu_client, rig.imu.baud_bps, timeout=0.5) as ser:
                    ser.write(_xbus(0x30))  # GoToConfig
                    ack = ser.read_until(_xbus(0x31))
                    ser.write(_xbus(0x10))  # GoToMeasurement
                    ser.read_until(_xbus(0x11))
                    return ack + ser.read(300)

            imu = await asyncio.to_thread(imu_client_session)
            assert _xbus(0x31) in imu
            assert imu.count(b"\xfa\xff\x36") >= 2 or imu.count(b"\xfa\xff\x32") >= 2

            sock = await esc_server.accept()
            await asyncio.to_thread(sock.sendall, bytes([0x84, 0x01, 0x70, 0x2E, 0x90, 0x01]))  # Set Target, Get Position
            assert int.from_bytes(await esc_server.read(2), "little") == 6000

            device = XBeeDevice(ground_client, 115200)  # the unmodified PyPI client
            await asyncio.to_thread(device.open)
            try:
                assert device.get_protocol() == XBeeProtocol.RAW_802_15_4
                assert device.get_node_id() == "GROUND"
            finally:
                await asyncio.to_thread(device.close)
        finally:
            server.cancel()
            counters = await asyncio.gather(server, return_exceptions=True)
    assert isinstance(counters[0], dict), counters
    assert counters[0]["ground"]["at_api"] >= 2


# -- hil run: our flight code through null modems, realtime -----------------------------------
@pytest.mark.system
async def test_flight_code_flies_through_null_modems(tmp_path: Path) -> None:
    from hil.flight.tickloop import EndReason, Mode
    from hil.record import read_wire
    from hil.flight.run import run_flight_async

    names = ("imu", "adc", "rc", "esc", "telemetry")
    base = tomllib.loads((REPO / "rigs" / "paper-quad.toml").read_text())
    # Realtime through five relays on a loaded machine: a boot reply can take longer than the
    # shipped 0.25 s (a real MTi answers in milliseconds). A late reply is not what this test is
    # about, so the boot waits are roomier here.
    flight_cfg = tomllib.loads((REPO / "rigs" / "flightcode-paper-quad.toml").read_text())
    flight_cfg["imu"]["reply_timeout_s"] = 2.0
    flight_cfg["adc"]["reply_timeout_s"] = 1.0
    (tmp_path / "flightcode.toml").write_text(tomli_w.dumps(flight_cfg))
    base.setdefault("flight", {})["config"] = str(tmp_path / "flightcode.toml")
    async with null_modem(tmp_path, "imu") as imu, null_modem(tmp_path, "adc") as adc, \
            null_modem(tmp_path, "rc") as rc, null_modem(tmp_path, "esc") as esc, \
            null_modem(tmp_path, "telemetry") as tm:
        ends = dict(zip(names, (imu, adc, rc, esc, tm), strict=True))
        base["ports"] = {n: {"device": b, "client_path": c} for n, (b, c) in ends.items()}
        rig_file = tmp_path / "nullmodem-quad.toml"
        rig_file.write_text(tomli_w.dumps(base))
        rig = load_rig(rig_file)
        source = REPO / "rigs" / "scenarios" / "hover.toml"
        result = await run_flight_async(rig, load_scenario(source), scenario_source=source, mode=Mode.REALTIME,
                                        duration_s=2.0, out_dir=tmp_path / "logs")
    assert result.end_reason is EndReason.COMPLETED, (result.message, result.flight_stderr_tail)
    assert result.timing["esc_commands"] > 400  # ~2 s at 400 Hz, through the lines
    assert result.log_path is not None
    imu_tx = read_wire(result.log_path, "imu", "tx")
    assert b"\xfa\xff\x36" in imu_tx or b"\xfa\xff\x32" in imu_tx  # wire taps work on a real line
    assert read_wire(result.log_path, "esc", "rx")


async def test_hil_devices_attach_as_printed(tmp_path: Path) -> None:
    """`hil devices --attach imu=<device>` serves the IMU there and says so; exit status 0."""
    async with null_modem(tmp_path, "imu") as (imu_bench, imu_client):
        runs = tmp_path / "runs"
        runs.mkdir()
        env = dict(os.environ, TMPDIR=str(runs), COLUMNS="300")
        proc = await asyncio.create_subprocess_exec(
            sys.executable, "-m", "hil.cli", "devices", "--duration", "3", "--attach", f"imu={imu_bench}",
            cwd=REPO, env=env, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
        assert proc.stdout is not None
        printed = b""
        while b"  ground " not in printed:  # the port list is printed once the devices are up
            line = await asyncio.wait_for(proc.stdout.readline(), 60)
            assert line, printed
            printed += line

        def session() -> bytes:
            with serial.Serial(imu_client, 115200, timeout=1.0) as ser:
                ser.write(_xbus(0x30))  # GoToConfig
                return ser.read_until(_xbus(0x31))

        ack = await asyncio.to_thread(session)
        out, err = await asyncio.wait_for(proc.communicate(), 60)
    assert proc.returncode == 0, err.decode()
    assert printed.splitlines()[1].decode() == (
        f"  imu            {imu_bench}  (XSENS MTi (Xbus), attached, {load_rig(None).imu.baud_bps} baud 8N1)"), printed
    assert ack.endswith(_xbus(0x31))


async def test_bus_pirate_b_menu_switches_the_real_line(tmp_path: Path) -> None:
    """A host on a real line drives the Bus Pirate's b menu to 1 Mbit/s: the bench switches
    the attached port after the confirmation, and the session goes on into binary mode."""
    from tests.transport.test_serialport import _line_baud

    rig = load_rig(None)
    scenario = load_scenario(rig.scenario_path("hover"))
    async with null_modem(tmp_path, "adc") as (adc_bench, adc_client):
        ready = asyncio.Event()
        server = asyncio.create_task(serve_devices(
            rig, scenario, seed=1, duration_s=None, console=Console(file=io.StringIO()),
            on_ready=lambda p: ready.set(), attach={"adc": adc_bench}))
        try:
            await asyncio.wait_for(ready.wait(), 30)

            def host() -> tuple[bytes, int | None, bytes]:
                with serial.Serial(adc_client, 115200, timeout=2.0) as ser:
                    ser.write(b"\r")
                    ser.read_until(b"HiZ>")
                    ser.write(b"b\r")
                    ser.read_until(b"(9)>")
                    ser.write(b"10\r")
                    ser.read_until(b"(34)>")
                    ser.write(b"3\r")
                    confirm = ser.read_until(b"Space to continue\r\n")
                    ser.baudrate = 1_000_000  # a real host switches its adapter too
                    ser.write(b" ")
                    rest = ser.read_until(b"HiZ>")
                    # the bench switched in the same loop callback that wrote the confirmation,
                    # so by the time it answered the space the line is at the new rate
                    line = _line_baud(adc_bench)
                    ser.write(b"\x00" * 20)
                    return confirm, line, rest + ser.read(5)

            confirm, line, rest = await asyncio.to_thread(host)
        finally:
            server.cancel()
            await asyncio.gather(server, return_exceptions=True)
    assert confirm.endswith(b"3\r\nAdjust your terminal\r\nSpace to continue\r\n")
    assert line == 1_000_000
    assert rest == b"HiZ>BBIO1"
