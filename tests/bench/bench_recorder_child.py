"""Benchmark of the recorder child's work per tick (not a test): CPU us per tick, offline.

Run: ``.venv/bin/python tests/bench/bench_recorder_child.py [--rounds R] [--baseline DIR]
[--batches FILE] [hil run arguments ...]`` (default flight: ``-s hover --seed 1 --duration 10``).

First a flight is flown with the bench's batches to its recorder child captured as they are
sent (the pickled bytes of each tick's batch; ``--batches FILE`` keeps them, or reuses FILE if
it exists). Then the child's work is repeated offline on those bytes, in a fresh process per
round: unpickle each batch and write it to an MCAP file exactly as the child does
(``hil/record/process.py``), CPU time (``time.process_time_ns``) divided by the batches.
Measured offline because the child's figure in a run (``recorder_cpu_per_tick_us``,
``tests/bench/recorder_cpu.py``) also counts its reads of the pipe and swings with the
neighbours' load; the same bytes every round make rounds comparable.

``--baseline DIR`` runs the same rounds with the ``hil`` package of DIR (an export of an
older commit: ``git archive <commit> | tar -x -C DIR``), interleaved with this checkout's,
and prints the ratio of the medians. Prints; asserts nothing about time.
"""

from __future__ import annotations

import argparse
import os
import pickle
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

_ROOT = Path(__file__).resolve().parents[2]


def capture(run_args: list[str], out: Path) -> None:
    """Fly ``hil run run_args`` with every batch the bench sends its recorder child kept in ``out``."""
    code = (
        "import pickle, sys\n"
        "import hil.record.process as P\n"
        "bodies = []\n"
        "send = P.ProcessRecorder._send\n"
        "def keep(self, kind, payload):\n"
        "    bodies.append(pickle.dumps((kind, payload), protocol=pickle.HIGHEST_PROTOCOL))\n"
        "    return send(self, kind, payload)\n"
        "P.ProcessRecorder._send = keep\n"
        "from hil.cli import app\n"
        "sys.argv = ['hil', 'run', *sys.argv[2:]]\n"
        "try:\n"
        "    app()\n"
        "finally:\n"
        "    with open(OUT, 'wb') as f:\n"
        "        pickle.dump(bodies, f)\n"
    ).replace("OUT", repr(str(out)))
    with tempfile.TemporaryDirectory(prefix="bench-rec-") as logs:
        subprocess.run([sys.executable, "-c", code, "run", *run_args, "--out", logs, "-q"],
                       check=False, stdout=subprocess.DEVNULL, cwd=_ROOT)
    if not out.exists():
        raise SystemExit(f"the flight wrote no batches to {out}")


def one_round(batches: Path) -> float:
    """The child's CPU us per tick on the captured batches (this process's ``hil``)."""
    from hil.record.writer import Recorder

    bodies = [b for b in pickle.loads(batches.read_bytes()) if pickle.loads(b)[0] == 0]
    with tempfile.TemporaryDirectory(prefix="bench-rec-") as tmp:
        rec = Recorder(Path(tmp) / "x.mcap", run_start_unix_ns=1, metadata={}, writer_thread=False)
        rec.start()
        write_now = getattr(rec, "write_now", None)
        t0 = time.process_time_ns()
        for body in bodies:
            _, items = pickle.loads(body)
            if write_now is not None:
                write_now(items)
            else:  # an older checkout: the child's former loop
                for topic, t_ns, t_host_ns, item in items:
                    if topic is None:
                        rec.log_wire(item[0], item[1], t_ns, t_host_ns, item[2])
                    else:
                        rec.log(topic, t_ns, item, t_host_ns)
        cpu_ns = time.process_time_ns() - t0
        rec.close({})
    return cpu_ns / len(bodies) / 1e3


def _round_in(root: Path, batches: Path) -> float:
    env = dict(os.environ, PYTHONPATH=str(root))
    out = subprocess.run([sys.executable, __file__, "--one-round", str(batches)], env=env, cwd=root,
                         check=True, capture_output=True, text=True).stdout
    return float(out.split()[-1])


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--baseline", type=Path)
    ap.add_argument("--batches", type=Path)
    ap.add_argument("--one-round", type=Path, help=argparse.SUPPRESS)
    args, run_args = ap.parse_known_args(argv)
    if args.one_round is not None:
        print(f"{one_round(args.one_round):.3f}")
        return 0
    run_args = run_args or ["-s", "hover", "--seed", "1", "--duration", "10"]
    with tempfile.TemporaryDirectory(prefix="bench-rec-") as tmp:
        batches = args.batches or Path(tmp) / "batches.pkl"
        if not batches.exists():
            capture(run_args, batches)
        n = sum(1 for b in pickle.loads(batches.read_bytes()) if pickle.loads(b)[0] == 0)
        now: list[float] = []
        base: list[float] = []
        for _ in range(args.rounds):
            if args.baseline is not None:
                base.append(_round_in(args.baseline.resolve(), batches))
            now.append(_round_in(_ROOT, batches))
    print(f"recorder child's work, {n} batches of `hil run {' '.join(run_args)}`, CPU us per tick (median of "
          f"{args.rounds} rounds)")
    print(f"  this checkout  {statistics.median(now):7.1f}   rounds {' '.join(f'{v:.0f}' for v in now)}")
    if base:
        print(f"  baseline       {statistics.median(base):7.1f}   rounds {' '.join(f'{v:.0f}' for v in base)}")
        print(f"  this / baseline {statistics.median(now) / statistics.median(base):.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
