"""`hil campaign --scheduler` on a cluster whose workers share no filesystem with the client.

A `dask scheduler` and two `dask worker`s run as separate processes with TLS (credentials
from `python -m hil.fleet.cluster_tls`, as docs/replay-and-campaigns.md shows). Each worker
runs in its own mount namespace (`unshare -m`) where a tmpfs hides this checkout and the
client's directory; the environment's interpreter and dependencies stay reachable (the venv
is bound back at its path when it lives in the checkout), and the bench is a plain
`pip install --target` of the package, so the workers have the installed package and nothing
else of the project: no rigs/, no scenarios, no client logs/ (checked on the workers).
`hil campaign` then flies 4 cases there: all pass, and their logs are in the client's own
campaign directory. No process and no case directory is left behind.
"""

from __future__ import annotations

import json
import os
import re
import selectors
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import psutil
import pytest

from hil.record import read_attachments, read_metadata

pytestmark = [pytest.mark.system, pytest.mark.pty, pytest.mark.timeout(1200)]
ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "tests" / "unit" / "campaign" / "data" / "hover-2s.toml"
#: the parts of a checkout `pip install` needs to build the package
PACKAGE_SOURCES = ("setup.py", "pyproject.toml", "README.md", "hil", "emulators", "flightcode")
START_TIMEOUT_S = 120.0
STOP_TIMEOUT_S = 15.0

#: run in the worker's new mount namespace: hide the checkout (the venv bound back when it is
#: inside) and the client's directory, then become the Dask worker
HIDE_AND_EXEC = r"""
set -e
if [ -n "$HIL_VENV_REL" ]; then mount --bind "$HIL_PROJECT/$HIL_VENV_REL" "$HIL_HOLD"; fi
mount -t tmpfs -o size=1m,mode=755 hil-hidden "$HIL_PROJECT"
if [ -n "$HIL_VENV_REL" ]; then
    mkdir -p "$HIL_PROJECT/$HIL_VENV_REL"
    mount --move "$HIL_HOLD" "$HIL_PROJECT/$HIL_VENV_REL"
fi
mount -t tmpfs -o size=1m,mode=755 hil-hidden "$HIL_CLIENT"
cd "$HIL_WORKDIR"
exec "$@"
"""


def _unshare_or_skip(tmp_path: Path) -> str:
    unshare = shutil.which("unshare")
    if unshare is None:
        pytest.skip("no unshare command (util-linux): cannot hide the project from the workers")
    probe = tmp_path / "probe"
    probe.mkdir()
    got = subprocess.run([unshare, "-m", "--propagation", "private", "sh", "-c",
                          'mount -t tmpfs -o size=1m hil-probe "$1"', "sh", str(probe)],
                         capture_output=True, text=True, timeout=60)
    if got.returncode != 0:
        pytest.skip(f"unshare -m with a tmpfs mount is not allowed here (status {got.returncode}: "
                    f"{got.stderr.strip()}): the workers cannot be kept from the project's files")
    return unshare


def _install_package(dest: Path) -> Path:
    """``pip install --target`` of a copy of the package's sources; returns the target."""
    src, site = dest / "src", dest / "site"
    src.mkdir(parents=True)
    for name in PACKAGE_SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, src / name,
                            ignore=shutil.ignore_patterns("__pycache__", "*.so", "*.pyc", "build"))
        else:
            shutil.copy2(ROOT / name, src / name)
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation",
                    "--target", str(site), str(src)], check=True, capture_output=True, timeout=600)
    shutil.rmtree(src)
    return site


class _Proc:
    """A process in its own group whose stderr is read line by line (kept for messages)."""

    def __init__(self, argv: list[str], env: dict[str, str], cwd: Path) -> None:
        self.argv = argv
        self.proc = subprocess.Popen(argv, env=env, cwd=cwd, stdin=subprocess.DEVNULL,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)
        self.lines: list[str] = []
        self._new = threading.Condition()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stderr is not None
        for raw in self.proc.stderr:
            with self._new:
                self.lines.append(raw.decode(errors="replace"))
                self._new.notify_all()
        with self._new:
            self.lines.append("")  # end of file
            self._new.notify_all()

    def wait_for(self, pattern: str, timeout_s: float = START_TIMEOUT_S) -> re.Match[str]:
        """The first stderr line matching ``pattern``: waited on, within ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        seen = 0
        with self._new:
            while True:
                for line in self.lines[seen:]:
                    if line == "":
                        raise AssertionError(f"{self.argv[:3]} ended: {''.join(self.lines)[-3000:]}")
                    found = re.search(pattern, line)
                    if found:
                        return found
                seen = len(self.lines)
                left = deadline - time.monotonic()
                if left <= 0:
                    raise AssertionError(f"no {pattern!r} from {self.argv[:3]}: {''.join(self.lines)[-3000:]}")
                self._new.wait(left)

    def stop(self) -> list[psutil.Process]:
        """SIGTERM to its group and every descendant (cases run in sessions of their own), then
        SIGKILL to what is left after STOP_TIMEOUT_S; returns every process it had."""
        try:
            family = [psutil.Process(self.proc.pid), *psutil.Process(self.proc.pid).children(recursive=True)]
        except psutil.NoSuchProcess:
            family = []
        for sig in (signal.SIGTERM, signal.SIGKILL):
            try:
                os.killpg(self.proc.pid, sig)
            except ProcessLookupError:
                pass
            for p in family:
                try:
                    p.send_signal(sig)
                except psutil.NoSuchProcess:
                    pass
            _, alive = psutil.wait_procs(family, timeout=STOP_TIMEOUT_S)
            if not alive:
                break
        try:
            self.proc.wait(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            pass
        self._reader.join(timeout=STOP_TIMEOUT_S)
        return family


@pytest.fixture
def started(tmp_path: Path) -> Iterator[list[_Proc]]:
    """Processes the test starts; all stopped at the end, and none of their family survives."""
    procs: list[_Proc] = []
    try:
        yield procs
    finally:
        family = [p for proc in reversed(procs) for p in proc.stop()]
        survivors = [p.pid for p in family if p.is_running() and p.status() != psutil.STATUS_ZOMBIE]
        assert survivors == [], f"processes left: {survivors}"


def _probe(client: object, fn: object, *args: object) -> list[object]:
    return list(client.run(fn, *args).values())  # type: ignore[attr-defined]


def test_a_campaign_on_workers_without_the_project(tmp_path: Path, started: list[_Proc]) -> None:
    from distributed import Client
    from distributed.security import Security

    unshare = _unshare_or_skip(tmp_path)
    client_dir, worker_dir = tmp_path / "client", tmp_path / "worker"
    client_dir.mkdir()
    (worker_dir / "tmp").mkdir(parents=True)
    (worker_dir / "hold-venv").mkdir()
    site = _install_package(worker_dir)
    campaign = client_dir / "campaign.toml"
    campaign.write_text(f'[campaign]\nname = "no-shared-fs"\nrig = "{ROOT / "rigs" / "paper-quad.toml"}"\n'
                        f'scenarios = ["{SCENARIO}"]\nseeds = [1, 2, 3, 4]\nkeep_logs = "all"\n'
                        f'case_timeout_s = 600.0\nout = "{client_dir / "logs"}"\n')

    # the documented credentials: python -m hil.fleet.cluster_tls DIR, the yaml into Dask's config
    tls = tmp_path / "tls"
    made = subprocess.run([sys.executable, "-m", "hil.fleet.cluster_tls", str(tls)], capture_output=True, text=True,
                          timeout=120)
    assert made.returncode == 0, made.stderr
    assert (tls / "dask-cluster.key").stat().st_mode & 0o777 == 0o600
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "DASK_"))}
    env |= {"DASK_CONFIG": str(tls), "COLUMNS": "200"}
    dask = str(Path(sys.executable).parent / "dask")

    scheduler_dir = tmp_path / "scheduler"
    scheduler_dir.mkdir()
    started.append(_Proc([dask, "scheduler", "--protocol", "tls", "--host", "127.0.0.1", "--port", "0",
                          "--no-dashboard"], env, scheduler_dir))
    address = started[0].wait_for(r"Scheduler at:\s+(tls://\S+)").group(1)

    venv = Path(sys.prefix).resolve()
    worker_env = env | {
        "PYTHONPATH": str(site), "TMPDIR": str(worker_dir / "tmp"), "HIL_PROJECT": str(ROOT),
        "HIL_VENV_REL": str(venv.relative_to(ROOT)) if venv.is_relative_to(ROOT) else "",
        "HIL_HOLD": str(worker_dir / "hold-venv"), "HIL_CLIENT": str(client_dir), "HIL_WORKDIR": str(worker_dir),
    }
    for name in ("w1", "w2"):
        started.append(_Proc([unshare, "-m", "--propagation", "private", "sh", "-c", HIDE_AND_EXEC, "sh",
                              dask, "worker", address, "--nthreads", "1", "--name", name, "--no-dashboard",
                              "--local-directory", str(worker_dir / name)], worker_env, worker_dir))

    cert, key = str(tls / "dask-cluster.pem"), str(tls / "dask-cluster.key")
    security = Security(tls_ca_file=cert, tls_client_cert=cert, tls_client_key=key, require_encryption=True)
    with Client(address, security=security, timeout="60s") as client:
        client.wait_for_workers(2, timeout=START_TIMEOUT_S)
        # the workers see the installed package, and nothing of the project or of the client
        assert _probe(client, eval, "__import__('hil').__file__") == [str(site / "hil" / "__init__.py")] * 2
        assert _probe(client, os.path.exists, str(site / "hil" / "record" / "schemas")) == [True, True]
        for hidden in (ROOT / "rigs", ROOT / "hil", SCENARIO, campaign):
            assert _probe(client, os.path.exists, str(hidden)) == [False, False], hidden
            assert hidden.exists()  # here it is
        assert _probe(client, os.listdir, str(client_dir)) == [[], []]

    run = subprocess.run([sys.executable, "-m", "hil.cli", "campaign", str(campaign), "--scheduler", address],
                         env=env | {"PYTHONPATH": os.environ.get("PYTHONPATH", "")}, cwd=client_dir,
                         capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-4000:]
    assert f"4 cases on dask {address}" in run.stdout

    [cdir] = list((client_dir / "logs").glob("no-shared-fs-*"))
    results = [json.loads(line) for line in (cdir / "results.jsonl").read_text().splitlines()]
    assert sorted(r["seed"] for r in results) == [1, 2, 3, 4]
    for r in results:
        assert r["passed"] and r["end_reason"] == "completed", r
        log = Path(r["log"])
        assert log.parent == cdir / "logs" and log.name == f"{r['case_id']}_hover-2s_s{r['seed']}.mcap"
        assert read_metadata(log)["run"]["seed"] == str(r["seed"])
        assert read_attachments(log)["hover-2s.toml"][1] == SCENARIO.read_bytes()
    summary = json.loads((cdir / "summary.json").read_text())
    assert (summary["cases"], summary["passed"], summary["failed"]) == (4, 4, 0)
    assert list((worker_dir / "tmp").iterdir()) == []  # every case's directory removed on the workers
