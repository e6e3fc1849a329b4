"""Cost of ``hil run --live`` (not a test): RTF and CPU per tick of the bench and of the
recorder child (where the live server runs), side by side in one session.

Run: ``.venv/bin/python tests/bench/bench_live.py [--runs 3] [--seconds 5]``. Each round flies
the same lockstep hover (same seed) four ways, interleaved so host load hits them alike:
``off`` (no --live), ``no client``, ``default`` (one client subscribed to the default set) and
``all`` (one client subscribed to every topic). Prints the median of the runs for each.
The client is the tests' independent foxglove.sdk.v1 client (tests/system/live_client.py).
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import sys
import tempfile
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from hil.config.rig import load_rig  # noqa: E402
from hil.config.scenario import load_scenario  # noqa: E402
from hil.flight.run import run_flight_async  # noqa: E402
from hil.live.topics import DEFAULT_TOPICS, LiveConfig  # noqa: E402
from hil.record.topics import TOPICS  # noqa: E402
from tests.system.live_client import LiveClient  # noqa: E402

WAYS = ("off", "no client", "default", "all")


async def fly(way: str, seconds: float, out: Path) -> dict[str, float]:
    rig = load_rig(None)
    source = rig.scenario_path("hover")
    topics = {"default": DEFAULT_TOPICS, "all": tuple(TOPICS)}.get(way, DEFAULT_TOPICS)
    url: asyncio.Future[str] = asyncio.get_running_loop().create_future()
    live = None if way == "off" else LiveConfig(topics=topics, announce=url.set_result)
    opened = asyncio.Event()
    stats: dict[str, Any] = {}

    def on_ready(loop: Any, devices: Any, runner: Any) -> None:
        stats["loop"] = loop

        async def gate() -> None:  # tick 0 waits for the client (not counted: the loop's clock starts after)
            await opened.wait()

        loop.tick_gate = gate

    flight = asyncio.create_task(run_flight_async(rig, load_scenario(source), scenario_source=source,
                                                  duration_s=seconds, out_dir=out, live=live, on_ready=on_ready))
    client = None
    if way in ("default", "all"):
        client = LiveClient(await url)
        await client.connect()
        await client.subscribe(*topics)
    opened.set()
    result = await flight
    if client is not None:
        await client.close()
    st = stats["loop"].stats
    wall_s = (st.wall_end_ns - st.wall_start_ns) / 1e9
    return {"rtf": result.sim_s / wall_s, "bench_us": st.cpu_ns / st.ticks / 1e3,
            "recorder_us": result.timing.get("recorder_cpu_per_tick_us", float("nan")),
            "received": sum(len(v) for v in client.messages.values()) if client else 0}


async def main(runs: int, seconds: float) -> None:
    results: dict[str, list[dict[str, float]]] = {w: [] for w in WAYS}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(runs):
            for way in WAYS:
                results[way].append(await fly(way, seconds, Path(tmp) / f"{way}-{r}".replace(" ", "_")))
    base = statistics.median(x["rtf"] for x in results["off"])
    print(f"| --live | RTF | vs off | bench CPU per tick (us) | recorder+server CPU per tick (us) | messages received |")
    print("|---|---|---|---|---|---|")
    for way in WAYS:
        med = {k: statistics.median(x[k] for x in results[way]) for k in results[way][0]}
        print(f"| {way} | {med['rtf']:.2f} | {100 * (med['rtf'] / base - 1):+.1f} % | {med['bench_us']:.0f} | "
              f"{med['recorder_us']:.0f} | {med['received']:.0f} |")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=5.0)
    args = ap.parse_args()
    asyncio.run(main(args.runs, args.seconds))
