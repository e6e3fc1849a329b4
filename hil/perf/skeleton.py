"""The bare lockstep skeleton: what the pty transport allows, measured beside the bench.

Two processes and the bench's five ptys, no plant, no emulators, no recording. Per tick
(one 2.5 ms IMU period of sim time) the bytes are those of a recorded hover, in the same
order as the real exchange (sizes measured from a ``hil run -s hover`` log):

* bench -> flight: the IMU sample (69 B MTData2) and, every 9th tick, an RC capture frame;
* flight -> bench: one Bus Pirate bulk request for the four MCP3204 conversions (24 B);
* bench -> flight: its reply (24 B);
* flight -> bench: one Maestro Set Multiple Targets (11 B) and, every 8th tick, a telemetry
  frame (XBee API TX16, 46 B).

The bench (asyncio, add_reader on the pty masters, as the bench's ``PtyPort``) starts tick
k+1 when the ESC command of tick k has arrived. The flight side uses pyserial with read
timeouts, as ``flightcode`` does. The ratio of the bench's RTF to this one says how much of
what the transport allows the bench reaches (``hil perf``).

Run the flight side as ``python -m hil.perf.skeleton IMU RC ADC ESC TELEMETRY`` (slave paths).
"""

from __future__ import annotations

import asyncio
import os
import sys
import time
import tty
from dataclasses import dataclass

from hil.flight.spawn import uncancelled_start

IMU_N, RC_N, RC_EVERY = 69, 108, 9
ADC_REQ_N, ADC_RESP_N = 24, 24
ESC_N, TM_N, TM_EVERY = 11, 46, 8
PORTS = ("imu", "rc", "adc", "esc", "telemetry")
TICK_NS = 2_500_000


@dataclass(frozen=True)
class SkeletonResult:
    ticks: int
    wall_s: float
    #: CPU per tick over the ticks, us: this process's (the bench side: the pty writes and
    #: reads and asyncio's wake-ups, the transport's share of a bench tick) and the flight
    #: side's (NaN where /proc/<pid>/schedstat is missing)
    bench_cpu_per_tick_us: float = float("nan")
    flight_cpu_per_tick_us: float = float("nan")

    @property
    def rtf(self) -> float:
        return self.ticks * TICK_NS / 1e9 / self.wall_s


def flight_main(paths: list[str]) -> None:
    """The flight side: block on the IMU sample, one ADC round trip, the ESC command."""
    import serial

    ports = {name: serial.Serial(p, baudrate=921600, timeout=0.1, write_timeout=0.1)
             for name, p in zip(PORTS, paths, strict=True)}
    imu, rc, adc, esc, tm = (ports[n] for n in PORTS)
    req, cmd, frame = b"\x12" * ADC_REQ_N, b"\x9f" * ESC_N, b"\x7e" * TM_N
    esc.write(b"R")  # ready
    k = 0
    while True:
        if len(imu.read(IMU_N)) != IMU_N:
            return  # the bench is gone
        if rc.in_waiting:
            rc.read(rc.in_waiting)
        adc.write(req)
        adc.read(ADC_RESP_N)
        esc.write(cmd)
        if k % TM_EVERY == 0:
            tm.write(frame)
        k += 1


async def run_skeleton(seconds: float) -> SkeletonResult:
    """``seconds`` of sim time through the skeleton; its RTF."""
    from hil import clock

    loop = asyncio.get_running_loop()
    masters: dict[str, int] = {}
    slaves: dict[str, int] = {}
    paths = []
    try:
        for name in PORTS:
            m, s = os.openpty()
            masters[name], slaves[name] = m, s
            tty.setraw(s)
            os.set_blocking(m, False)
            paths.append(os.ttyname(s))
        # started as hil run starts a flight command: a Ctrl-C meanwhile cannot hang the start
        # (hil/flight/spawn.py)
        spawn = asyncio.ensure_future(loop.subprocess_exec(
            lambda: asyncio.subprocess.SubprocessStreamProtocol(limit=2**16, loop=loop),
            sys.executable, "-m", "hil.perf.skeleton", *paths, stdin=asyncio.subprocess.DEVNULL, stdout=None,
            stderr=asyncio.subprocess.DEVNULL))
        transport, protocol = await uncancelled_start(spawn)
    except BaseException:
        for fd in (*masters.values(), *slaves.values()):
            os.close(fd)
        raise
    proc = asyncio.subprocess.Process(transport, protocol, loop)
    counts = {"adc": 0, "esc": 0}
    waiter: list[asyncio.Future[None] | None] = [None]
    need = {"adc": ADC_REQ_N, "esc": ESC_N}

    def reader(name: str) -> None:
        counts[name] += len(os.read(masters[name], 4096))
        fut = waiter[0]
        if fut is not None and not fut.done() and counts[name] >= need[name]:
            fut.set_result(None)

    async def wait_for(name: str) -> None:
        while counts[name] < need[name]:
            fut = loop.create_future()
            waiter[0] = fut
            await fut
        counts[name] -= need[name]

    for name in ("adc", "esc"):
        loop.add_reader(masters[name], reader, name)
    loop.add_reader(masters["telemetry"], lambda: os.read(masters["telemetry"], 4096))
    imu_pkt, rc_frame, resp = b"\xfa" * IMU_N, b"\x00" * RC_N, b"\x01" * ADC_RESP_N
    try:
        need["esc"] = 1
        await wait_for("esc")  # the flight side is up
        need["esc"] = ESC_N
        ticks = round(seconds * 1e9 / TICK_NS)
        flight0 = _cpu_ns(proc.pid)
        cpu0 = time.process_time_ns()
        start = clock.monotonic_ns()
        for k in range(ticks):
            os.write(masters["imu"], imu_pkt)
            if k % RC_EVERY == 0:
                os.write(masters["rc"], rc_frame)
            await wait_for("adc")
            os.write(masters["adc"], resp)
            await wait_for("esc")
        wall_s = (clock.monotonic_ns() - start) / 1e9
        bench_us = (time.process_time_ns() - cpu0) / max(ticks, 1) / 1e3
        flight1 = _cpu_ns(proc.pid)
        flight_us = (flight1 - flight0) / max(ticks, 1) / 1e3 if flight0 is not None and flight1 is not None else float("nan")
    finally:
        if proc.returncode is None:
            proc.kill()
        await proc.wait()
        for fd in (*masters.values(), *slaves.values()):
            loop.remove_reader(fd)
            os.close(fd)
    return SkeletonResult(ticks, wall_s, bench_us, flight_us)


def _cpu_ns(pid: int) -> int | None:
    """CPU time process ``pid``'s main thread has run, ns (/proc/<pid>/schedstat; the flight
    side has one thread)."""
    try:
        with open(f"/proc/{pid}/schedstat", encoding="ascii") as f:
            return int(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        return None


if __name__ == "__main__":
    flight_main(sys.argv[1:])
