"""``hil perf``: benchmarks of the bench on this machine (never assertions in tests).

* plant: the cost of one 2.5 ms tick of the plant (median, p99, us);
* recording: the cost of one ``log()`` on the tick path and the writer's sustained rate;
* lockstep: the real-time factor of the full stack (plant, all emulators, the flight code
  as a subprocess, recording) and the bench's own cost per tick, interleaved with the bare
  lockstep skeleton (``hil.perf.skeleton``: the same exchanges over ptys with pyserial, nothing
  else), so the ratio says how much of what the transport allows the bench reaches; and the
  ceiling the flight-code process's CPU per sample sets on the RTF while it costs that much;
* realtime: the IMU emit-period error (the pacer's lateness) and the flight code's response
  latency (IMU emitted -> ESC command) p50/p99/max, next to a bare timer loop measured in
  the same process right before (the floor of this machine), with the steal time the run
  saw and the host's interruptions of a thread that only runs (hil/perf/hostnoise.py): what no
  guest priority prevents.

Numbers are medians over the runs made; machines are shared and noisy, so quote medians
and ratios, not single values.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import statistics
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hil import clock
from hil.host import cpulatency
from hil.perf import hostnoise
from hil.host.rtsched import RealtimePriority, RtPolicy, for_rig


@dataclass
class PerfReport:
    rows: list[tuple[str, str, str]] = field(default_factory=list)  #: (figure, value, note)

    def add(self, figure: str, value: float, unit: str, note: str = "") -> None:
        self.rows.append((figure, f"{value:.3g} {unit}".strip(), note))


def bare_timer_loop(n: int = 2000, period_ns: int = 2_500_000, *,
                    priority: RealtimePriority | None = None) -> np.ndarray:
    """Lateness (us) of the same pacer with no work at all: this machine's floor. With
    ``priority``, the loop runs as a realtime run's tick loop does (hil/host/rtsched.py), so the two
    are compared on the same scheduling."""

    async def run() -> list[int]:
        with priority or contextlib.nullcontext():
            pacer = clock.RealtimePacer()
            start = clock.monotonic_ns() + period_ns
            late = [await pacer.wait(start + k * period_ns) for k in range(n)]
            pacer.close()
        return late

    return np.asarray(asyncio.run(run())) / 1e3


def measure(*, lockstep_runs: int = 3, lockstep_s: float = 10.0, realtime_s: float = 10.0,
            noise_s: float = 5.0) -> PerfReport:
    """Run every benchmark; returns the table rows."""
    from hil import native
    from hil.flight.tickloop import Mode
    from hil.perf.plant_tick import measure_tick_cost
    from hil.perf.recording import measure_recording
    from hil.config.rig import load_rig
    from hil.flight.run import run_flight

    rep = PerfReport()
    rep.rows.append(("compiled parts (device models, plant, tick path)", native.describe(), "`hil build` compiles them (docs/performance.md, Builds)"))
    rig = load_rig(None)
    tick_ms = rig.tick_ns / 1e6
    plant = measure_tick_cost(20_000, params=rig.plant)
    rep.add(
        "plant tick (median)", plant["tick_median_us"], "us",
        f"p99 {plant['tick_p99_us']:.3g} us; {plant['substeps']:.0f} RK4 sub-steps (default rig); "
        f"{plant['budget_pct']:.1f} % of the {tick_ms:g} ms tick",
    )
    # Everything below wakes processes on idle CPUs: the skeleton and the bare pacer hold the
    # rig's CPU latency request as the runs do (hil/host/cpulatency.py), so the ratios compare like
    # with like.
    with tempfile.TemporaryDirectory() as tmp, cpulatency.for_rig(rig) as held:
        rep.rows.append(("host CPU wake-up latency", held.describe(), "the rig's [host] cpu_latency, held for the "
                         "runs and the references below alike"))
        rec = measure_recording(Path(tmp))
        rep.add("record log() call (median)", rec.log_us_median, "us", f"p99 {rec.log_us_p99:.3g} us, on the tick path")
        rep.add("record writer rate", rec.writer_msgs_per_s, "msg/s", "writer thread, zstd 64 KiB chunks")

        from hil.perf.skeleton import run_skeleton

        rtfs, costs, cpus, lat50, lat99, skel, fc, cores = [], [], [], [], [], [], [], []
        skel_bench, skel_flight = [], []
        for i in range(lockstep_runs):
            sk = asyncio.run(run_skeleton(lockstep_s))
            skel.append(sk.rtf)
            skel_bench.append(sk.bench_cpu_per_tick_us)
            skel_flight.append(sk.flight_cpu_per_tick_us)
            res = run_flight(None, "hover", mode=Mode.LOCKSTEP, duration_s=lockstep_s, out_dir=Path(tmp) / f"l{i}")
            rtfs.append(res.timing["rtf"])
            costs.append(res.timing.get("bench_cost_p50_us", float("nan")))
            cpus.append(res.timing.get("bench_cpu_per_tick_us", float("nan")))
            fc.append(res.timing.get("fc_compute_p50_us", float("nan")))
            cores.append(res.timing.get("cores_used", float("nan")))
            # host figures: on virtual time the flight code answers at the sample's own sim time
            lat50.append(res.timing.get("host_latency_p50_us", float("nan")))
            lat99.append(res.timing.get("host_latency_p99_us", float("nan")))
        rep.add("lockstep real-time factor (median)", statistics.median(rtfs), "x",
                f"{lockstep_runs} runs of {lockstep_s:g} s hover, everything recorded; runs: "
                + ", ".join(f"{r:.2f}" for r in rtfs))
        rep.add("bare lockstep skeleton RTF (median)", statistics.median(skel), "x",
                "hil.perf.skeleton, interleaved with the runs above; runs: " + ", ".join(f"{r:.2f}" for r in skel))
        rep.add("bench / skeleton RTF", statistics.median(rtfs) / statistics.median(skel), "",
                "share of what the pty transport allows (target >= 0.6)")
        rep.add("lockstep bench CPU per tick (median)", statistics.median(cpus), "us",
                "the bench process's CPU over the tick loop / ticks: the tick's work and serving the flight "
                "code's requests (target <= 150 us)")
        # The transport's own share of that: what the skeleton's bench side spends per tick on
        # the same writes and reads, and so what the plant, the device models, the recording and
        # the scheduling add on top of it.
        skel_bench_us = statistics.median(skel_bench)
        rep.add("skeleton bench-side CPU per tick (median)", skel_bench_us, "us",
                "hil.perf.skeleton's bench process: the pty writes and reads and asyncio's wake-ups alone; "
                f"flight side {statistics.median(skel_flight):.3g} us")
        rep.add("lockstep bench CPU per tick above the skeleton's", statistics.median(cpus) - skel_bench_us, "us",
                "the plant, the device models, recording and the virtual-time scheduling")
        # In lockstep the flight-code process's CPU per sample elapses inside every tick: the tick
        # over it bounds the RTF from above while that process costs this much.
        fc_us = statistics.median(fc)
        ceiling = tick_ms * 1e3 / fc_us
        rep.add("lockstep flight-code process CPU per sample (median of p50)", fc_us, "us",
                "all its threads in the runs above: the loop's compute, its serial I/O and the clock "
                "shim's work in it; it grows when other processes compete for the cores")
        rep.add("lockstep RTF ceiling at that flight-code CPU", ceiling, "x",
                f"the {tick_ms:g} ms tick / the CPU per sample above, whatever the bench's own tick costs; "
                f"/ skeleton = {ceiling / statistics.median(skel):.3g}")
        # A campaign's ceiling: flights at a time share this host's CPUs, and sharing never
        # makes a flight need less CPU (hil/host/cpuuse.py)
        n_cpus = len(os.sched_getaffinity(0))
        per_flight = statistics.median(cores)
        rep.add("cores per recorded flight (median)", per_flight, "",
                f"bench + flight code + recorder CPU over the wall time of the runs above; {n_cpus} flights at a "
                f"time on this host's {n_cpus} CPUs can be at most {n_cpus / per_flight:.3g}x as fast as one "
                "(hil/host/cpuuse.py)")
        rep.add("lockstep tick work (median of p50)", statistics.median(costs), "us",
                "wall time of the tick's own steps (plant, emitting, recording), without the waits")
        rep.add("lockstep flight response p50", statistics.median(lat50), "us", "IMU written -> ESC command read, host time")
        rep.add("lockstep flight response p99", statistics.median(lat99), "us", "")

        rt = for_rig(rig)
        bare = bare_timer_loop(priority=rt)
        assert rt.result is not None
        rep.add("bare timer loop lateness p50", float(np.percentile(bare, 50)), "us",
                f"same pacer, no work, {rt.result.describe()} as the realtime run below")
        rep.add("bare timer loop lateness p99", float(np.percentile(bare, 99)), "us", f"max {bare.max():.3g} us")
        res = run_flight(None, "hover", mode=Mode.REALTIME, duration_s=realtime_s, out_dir=Path(tmp) / "rt")
        t = res.timing
        rep.add("realtime IMU emit lateness p50", t.get("lateness_p50_us", float("nan")), "us",
                "tick start vs its wall deadline; "
                + (res.rt_scheduling.describe() if res.rt_scheduling is not None else "scheduling unknown"))
        rep.add("realtime IMU emit lateness p99", t.get("lateness_p99_us", float("nan")), "us",
                f"max {t.get('lateness_max_us', float('nan')):.3g} us, {t.get('late_ticks', 0):.0f} ticks > 1 ms late")
        rep.add("realtime flight response p50", t.get("latency_p50_us", float("nan")), "us", "IMU written -> ESC command read")
        rep.add("realtime flight response p99", t.get("latency_p99_us", float("nan")), "us",
                f"max {t.get('latency_max_us', float('nan')):.3g} us (target <= 1000 us)")
        rep.add("realtime samples without a command", t.get("rt_no_command", float("nan")), "",
                f"of {t.get('ticks', 0):.0f} (target 0)")
        rep.add("realtime host steal time", t.get("host_steal_ms", float("nan")), "ms",
                "the hypervisor's pauses of this machine's CPUs during that run (/proc/stat, 10 ms steps; "
                "n/a: not counted here): late ticks and missed commands follow them (hil/host/steal.py)")
        # What the host does to a thread that only runs, at the realtime run's priority: the
        # pauses no guest priority prevents, which the realtime figures above include.
        noise = hostnoise.measure(noise_s, priority=rt.result.priority if rt.result.policy is RtPolicy.FIFO else 0)
        longest = max(noise, key=lambda c: c.longest_us)
        rep.add(f"host interruptions > {hostnoise.THRESHOLD_US:g} us (per CPU, per 10 s)",
                statistics.median(c.per_10s() for c in noise), "",
                f"a thread that only reads the clock, {noise[0].policy}, {noise_s:g} s on each of {len(noise)} CPUs: "
                + ", ".join(f"CPU {c.cpu} {len(c.gaps_ns)} ({c.lost_ms:.3g} ms lost)" for c in noise)
                + " (hil/perf/hostnoise.py)")
        rep.add("longest host interruption", longest.longest_us, "us",
                f"CPU {longest.cpu}: a sample caught by one this long misses its {tick_ms:g} ms tick")
    return rep
