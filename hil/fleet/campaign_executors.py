"""Running campaign cases in parallel: a stdlib process pool, or Dask distributed (a TLS local
cluster or a scheduler address).

Each executor hands every finished case's result to a callback as it arrives, turns a case it
lost (its worker died, the executor failed it) into a failed result (:func:`failure`), and on
Ctrl-C or SIGTERM raises the campaign's stop flag, cancels the queued cases and waits for the
running ones to finalize their logs. Both return (interrupted, cases cancelled).
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import importlib.util
import itertools
import multiprocessing
import os
import signal
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

#: the unit of work: a case's params -> its result (a picklable module-level function)
CaseFn = Callable[[dict[str, Any]], dict[str, Any]]
_STOP_WAIT_S = 60.0  # after Ctrl-C, wait this long for the running cases to finalize


def default_workers() -> int:
    """One case per two cores: concurrent runs distort each other's timing (docs/performance.md, Cores per flight)."""
    return max(1, (os.cpu_count() or 2) // 2)


def dask_available() -> bool:
    return importlib.util.find_spec("distributed") is not None


def failure(case: dict[str, Any], end_reason: str, message: str) -> dict[str, Any]:
    """The result of a case that produced none (its worker died, the executor failed it)."""
    overrides = {**{f"flight.{k}": v for k, v in case["flight_overrides"].items()},
                 **{f"rig.{k}": v for k, v in case["rig_overrides"].items()}}
    return {"case_id": case["case_id"], "scenario": case["scenario_name"], "seed": case["seed"],
            "overrides": overrides, "passed": False, "end_reason": end_reason, "message": message,
            "criteria": [], "timing": {}, "sim_s": 0.0, "flight_returncode": None, "log": None,
            "returncode": None, "wall_s": None}


@contextlib.contextmanager
def sigterm_as_ctrl_c() -> Iterator[None]:
    """Within: SIGTERM (``kill``, a CI runner cancelling the job, a batch system's time limit)
    stops a campaign the way Ctrl-C does: the stop flag goes up, the running cases finalize
    their logs and the workers remove their temporary trees. Python's default ends the client
    at once, and the cases' processes fly on as orphans with their trees left behind.
    Signal handlers live in the main thread; elsewhere this does nothing."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _ignore_sigint() -> None:  # pool workers: Ctrl-C is the campaign's to handle
    signal.signal(signal.SIGINT, signal.SIG_IGN)


#: receives every case's result as it arrives
Handle = Callable[[dict[str, Any]], None]


def _take(fut: cf.Future[dict[str, Any]], case: dict[str, Any], handle: Handle, broken: list[dict[str, Any]]) -> None:
    """Hand one pool future's result on; a case lost to a broken pool goes to ``broken``."""
    try:
        result = fut.result()
    except cf.process.BrokenProcessPool:
        broken.append(case)
        return
    except Exception as exc:  # noqa: BLE001 - whatever the case function raised is that case's failure
        result = failure(case, "case error", f"{type(exc).__name__}: {exc}")
    handle(result)


def _pool_round(cases: list[dict[str, Any]], workers: int, case_fn: CaseFn, handle: Handle,
                stop_file: Path) -> tuple[bool, int, list[dict[str, Any]]]:
    """One process pool over ``cases``: (interrupted, cancelled, cases lost to a dead worker)."""
    pool = cf.ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                                  initializer=_ignore_sigint)
    futures = {pool.submit(case_fn, c): c for c in cases}
    broken: list[dict[str, Any]] = []
    handled: set[cf.Future[dict[str, Any]]] = set()
    try:
        for fut in cf.as_completed(futures):
            handled.add(fut)
            _take(fut, futures[fut], handle, broken)
    except KeyboardInterrupt:
        stop_file.touch()
        cancelled = sum(1 for f in futures if f.cancel())
        rest = [f for f in futures if f not in handled and not f.cancelled()]
        try:
            for fut in cf.as_completed(rest, timeout=_STOP_WAIT_S):
                handled.add(fut)
                _take(fut, futures[fut], handle, broken)
        except (KeyboardInterrupt, cf.TimeoutError):
            pass  # a second Ctrl-C: stop waiting
        pool.shutdown(wait=False, cancel_futures=True)
        return True, cancelled + len(broken) + sum(1 for f in rest if f not in handled), []
    pool.shutdown(wait=True)
    return False, 0, broken


def run_pool(cases: list[dict[str, Any]], workers: int, case_fn: CaseFn, handle: Handle,
             stop_file: Path) -> tuple[bool, int]:
    """Stdlib process pool. A worker that dies breaks the pool and every unfinished case with
    it; those cases are then re-run one per fresh pool, so only the culprit fails ("worker
    died") and the others get their result. Returns (interrupted, cancelled)."""
    with sigterm_as_ctrl_c():
        interrupted, cancelled, broken = _pool_round(cases, workers, case_fn, handle, stop_file)
        for i, case in enumerate(broken):
            if interrupted:
                return True, cancelled + len(broken) - i
            interrupted, cancelled, again = _pool_round([case], 1, case_fn, handle, stop_file)
            if again:
                handle(failure(case, "worker died", "its worker process died (run alone in a fresh pool)"))
        return interrupted, cancelled


def local_cluster_security() -> Any:
    """TLS credentials for a local Dask cluster: a throw-away CA and certificate made for this
    cluster (``Security.temporary()``, needs ``cryptography``), encryption required.

    Dask's scheduler and workers listen on TCP ports; on loopback any local user could
    otherwise connect and run code as us (a Dask client can submit any function). With TLS
    and mutual authentication only holders of these in-memory credentials can."""
    from distributed.security import Security

    return Security.temporary()


def start_local_cluster(workers: int, **kwargs: Any) -> Any:
    """A LocalCluster of ``workers`` processes (one thread each, no dashboard) on 127.0.0.1,
    speaking TLS with temporary credentials (:func:`local_cluster_security`)."""
    from distributed import LocalCluster

    security = local_cluster_security()
    return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                        host="127.0.0.1", protocol="tls://", security=security, **kwargs)


def run_dask(cases: list[dict[str, Any]], workers: int, scheduler: str | None, case_fn: CaseFn, handle: Handle,
             stop_file: Path, tag: str, *, stop_event: str | None = None) -> tuple[bool, int]:
    """Dask distributed: a LocalCluster of ``workers`` processes, or the cluster at ``scheduler``.
    ``stop_event``: a Dask event set on Ctrl-C besides ``stop_file`` (for workers that cannot
    see the file; hil/fleet/campaign_worker.py), cleared at the end."""
    with sigterm_as_ctrl_c():
        return _run_dask(cases, workers, scheduler, case_fn, handle, stop_file, tag, stop_event)


def _run_dask(cases: list[dict[str, Any]], workers: int, scheduler: str | None, case_fn: CaseFn, handle: Handle,
              stop_file: Path, tag: str, stop_event: str | None) -> tuple[bool, int]:
    import logging

    from distributed import Client, Event, KilledWorker, as_completed, wait

    cluster = None
    if scheduler:
        # Security from Dask's configuration (distributed.comm.tls.*; docs/replay-and-campaigns.md)
        client = Client(scheduler)
    else:
        cluster = start_local_cluster(workers, silence_logs=logging.ERROR)
        client = Client(cluster, security=cluster.security)
        # A terminal Ctrl-C reaches the local workers too; the campaign stops the cases itself.
        with contextlib.suppress(Exception):
            client.run(_ignore_sigint)
    keys = [f"hil-case-{tag}-{c['case_id']}" for c in cases]
    by_key = dict(zip(keys, cases, strict=True))
    handled: set[str] = set()

    def take(fut: Any) -> None:
        handled.add(fut.key)
        try:
            handle(fut.result())
        except Exception as exc:  # noqa: BLE001 - KilledWorker (the worker died) or what the case raised
            end = "worker died" if isinstance(exc, KilledWorker) else "case error"
            handle(failure(by_key[fut.key], end, f"{type(exc).__name__}: {exc}"))

    try:
        futures = client.map(case_fn, cases, key=keys, pure=False)
        try:
            for fut in as_completed(futures):
                take(fut)
        except KeyboardInterrupt:
            stop_file.touch()
            if stop_event:
                Event(stop_event, client=client).set()
            running = set(itertools.chain.from_iterable(client.processing().values()))
            rest = [f for f in futures if f.key not in handled]
            queued = [f for f in rest if not f.done() and f.key not in running]
            client.cancel(queued)
            finishing = [f for f in rest if f not in queued]
            try:
                wait(finishing, timeout=_STOP_WAIT_S)
            except (KeyboardInterrupt, TimeoutError):
                pass
            for f in finishing:
                if f.done():
                    take(f)
            return True, len(rest) - sum(1 for f in rest if f.key in handled)
        return False, 0
    finally:
        if stop_event:
            with contextlib.suppress(Exception):  # the scheduler may be gone: nothing to clear then
                Event(stop_event, client=client).clear()
        client.close()
        if cluster is not None:
            cluster.close()


__all__ = ["CaseFn", "Handle", "dask_available", "default_workers", "failure", "local_cluster_security",
           "run_dask", "run_pool", "start_local_cluster"]
