"""The acquisition steps of a run, each handing its release to the run's exit stack.

Every step acquires one resource (the real serial lines, the private run directory, the
ptys, the recorder child, the flight code's config, the virtual-time session, the flight
code's process) and registers its release on the ``contextlib.AsyncExitStack`` the run
holds, before the next step starts: whatever fails afterwards - a later step, the flight,
the verdict, a Ctrl-C - unwinds them, last acquired first. The run (hil/flight/run.py)
releases them itself, in its own order, when it ends normally; every release here is
idempotent, so the stack then finds nothing left to do.

A step that fails raises; :func:`started` turns anything but a :class:`ConfigError` (bad
input, exit 2) into a :class:`RunStartError` naming the step.
"""

from __future__ import annotations

import contextlib
import shutil
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path

from hil.config import ConfigError
from hil.config.attach import PortAttachment, open_attached
from hil.config.rig import Rig
from hil.config.scenario import Scenario
from hil.flight.process import FlightProcess
from hil.flight.run_files import write_flight_config
from hil.flight.rundir import make_run_dir
from hil.flight.runlog import RunLogger
from hil.flight.signals import on_hard_exit
from hil.record.process import ProcessRecorder
from hil.transport.base import Port
from hil.transport.pty import PtyPort
from hil.vtime.preload import Fallback
from hil.vtime.session import VirtualTime

#: log names tried for one run before giving up (``<stem>.mcap``, ``<stem>-2.mcap``, ...)
LOG_NAME_TRIES = 1000


class RunStartError(RuntimeError):
    """A run could not acquire what it needs; everything acquired before was released."""


class VirtualTimeRequired(ConfigError):
    """Lockstep would fall back to the host clock, and the run requires virtual time."""


@contextlib.contextmanager
def started(step: str) -> Iterator[None]:
    """Name the step in the error a failing acquisition raises (bad input stays a ConfigError)."""
    try:
        yield
    except ConfigError:
        raise
    except Exception as exc:
        raise RunStartError(f"the run could not start ({step}): {type(exc).__name__}: {exc}") from exc


def open_serial_lines(stack: contextlib.AsyncExitStack, attachments: Mapping[str, PortAttachment],
                      rig: Rig) -> dict[str, Port]:
    """The rig's real serial lines, all or none (``open_attached``), closed by the stack."""
    attached = open_attached(attachments, rig.port_baud)
    for port in attached.values():
        stack.callback(port.close)
    return attached


def make_private_dir(stack: contextlib.AsyncExitStack, rig: Rig, *, keep: bool, prefix: str = "hil-") -> Path:
    """The run directory (mode 0700, hil/flight/rundir.py; named ``<prefix><rig>-...``) with its
    ``dev`` subdirectory; removed by the stack unless ``keep``."""
    run_dir = make_run_dir(f"{prefix}{rig.name}-")
    if not keep:
        # a second Ctrl-C exits at once (hil/flight/signals.py): the directory goes then too
        stack.callback(on_hard_exit(lambda: shutil.rmtree(run_dir, ignore_errors=True)))
        stack.callback(shutil.rmtree, run_dir, ignore_errors=True)
    (run_dir / "dev").mkdir(mode=0o700)
    return run_dir


async def open_ports(stack: contextlib.AsyncExitStack, names: tuple[str, ...], dev_dir: Path,
                     attached: Mapping[str, Port]) -> dict[str, Port]:
    """One port per name: the attached serial line, or a new pty (its symlink in ``dev_dir``);
    each closed by the stack from the moment it exists."""
    ports: dict[str, Port] = {}
    for name in names:
        port = attached.get(name) or PtyPort(name, dev_dir)
        stack.callback(port.close)
        ports[name] = port
    for port in ports.values():
        await port.start()
    return ports


def log_candidates(default: Path) -> Iterator[Path]:
    """``<stem>.mcap``, then ``<stem>-2.mcap``, ``<stem>-3.mcap``... (runs of the same rig,
    scenario and seed started in the same second)."""
    yield default
    stem = default.name.removesuffix(".mcap")
    for k in range(2, LOG_NAME_TRIES + 1):
        yield default.with_name(f"{stem}-{k}.mcap")


def start_recorder(stack: contextlib.AsyncExitStack, make: Callable[[Path], ProcessRecorder], log_path: Path,
                   *, unique: bool) -> ProcessRecorder:
    """Start the recorder child on ``log_path`` (``unique``: on the first free name of
    :func:`log_candidates`: the recorder creates ``<log>.part`` with O_EXCL, so two runs never
    share one). Until the run closes it with its verdict, the stack closes it with an
    ``aborted`` one: the log is finalized, never left as a ``.part``."""
    for path in log_candidates(log_path) if unique else (log_path,):
        if unique and (path.exists() or path.with_name(path.name + ".part").exists()):
            continue
        recorder = make(path)
        try:
            recorder.start()
        except OSError:
            if unique and (path.exists() or path.with_name(path.name + ".part").exists()):
                continue  # another run took this name between the look and the create
            raise
        stack.push(_abort_recorder(recorder))
        return recorder
    raise FileExistsError(f"{log_path}: {LOG_NAME_TRIES} logs of this name exist")


def _abort_recorder(recorder: ProcessRecorder) -> Callable[..., bool]:
    def close(exc_type: type[BaseException] | None, exc: BaseException | None, tb: object) -> bool:
        if recorder.pid is not None:  # not closed by the run itself
            why = "the run ended before its verdict" if exc is None else f"{type(exc).__name__}: {exc}"
            with contextlib.suppress(OSError):
                recorder.close({"status": "aborted", "end_reason": "error", "error": why[:2000]})
        return False

    return close


def write_config(rig: Rig, scenario: Scenario, ports: Mapping[str, Port], run_dir: Path) -> Path:
    """The flight code's config, in the run directory (removed with it)."""
    return write_flight_config(rig, scenario, ports, run_dir)


def open_virtual_time(stack: contextlib.AsyncExitStack, run_dir: Path, ports: Mapping[str, Port],
                      argv: list[str], wanted: bool, on_stall: Callable[..., None]) -> VirtualTime | Fallback:
    """Lockstep's clock session (hil/vtime), closed by the stack; a :class:`Fallback` says why
    the run flies on the host clock instead."""
    if not wanted:
        return Fallback("virtual time switched off (rig [flight] virtual_time or --wall-clock)")
    ptys = {n: p for n, p in ports.items() if isinstance(p, PtyPort)}
    assert len(ptys) == len(ports), "a real serial line in lockstep (refuse_lockstep let it through)"
    opened = VirtualTime.open(run_dir, ptys, argv, on_stall=on_stall)
    if isinstance(opened, VirtualTime):
        stack.callback(opened.close)
    return opened


def make_flight(stack: contextlib.AsyncExitStack, argv: list[str], logger: RunLogger,
                vt: VirtualTime | None, stop_grace_s: float) -> FlightProcess:
    """The flight code's process tree (started by the run); ended by the stack if still there."""
    flight = FlightProcess(argv, cwd=Path.cwd(), on_line=lambda stream, line: logger.flight_line(stream, line),
                           env=vt.env if vt is not None else None, stop_grace_s=stop_grace_s)
    if vt is not None:
        vt.bind(flight)
    stack.push_async_callback(_stop, flight, vt)
    return flight


async def _stop(flight: FlightProcess, vt: VirtualTime | None) -> None:
    if flight.proc is not None and (flight.running or flight.owner is not None):  # its tree not ended yet
        if vt is not None:
            vt.free_run()  # its shutdown at the host's pace
        await flight.stop()
