"""A process of the flight command that the clock shim cannot see through (docs/time.md).

When the bench has waited ``stall_warn_s`` of wall time for the flight code to go idle, it
asks why. A thread whose slot says running while the kernel has it asleep is blocked in a
call the shim does not interpose (``pause``, ``sigsuspend``, a wait inside ``system()``); a
process of the tree with no slot never loaded the shim (a static program, a set-user-ID one,
``env -u LD_PRELOAD``). Either can wait for ever, and the bench cannot tell whether sim time
may move meanwhile. So such a *suspect* found twice, ``CONFIRM_S`` apart, in the same call
without having run at all in between, ends the run with one sentence naming it.

A stopped process (``T``, a debugger's ``t``) is never a suspect: a debugger stop just waits.
A thread the kernel has running is computing (a long start-up, a loop): it is waited for.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from hil.vtime.control import ThreadView
from hil.vtime.stall import HiddenWait, ShimLost, shim_mapped
from hil.vtime.tree import ProcessTree, what_it_waits_in

#: wall seconds between the two looks that confirm a suspect
CONFIRM_S = 1.0


@dataclass(frozen=True)
class Suspect:
    """A thread the bench cannot see through, as found at one look."""

    pid: int
    tid: int
    comm: str
    start: int  #: the process's start time: with pid and tid, who it is
    waits_in: str  #: the call it is blocked in ("pause"), or "running"
    syscall: bytes  #: /proc/<pid>/task/<tid>/syscall: the same wait reads the same
    run_ns: int  #: CPU time so far: unchanged if it never ran between two looks
    shimless: bool  #: the process has no slot: it never loaded the shim (or lost it)

    def sentence(self) -> str:
        who = f"process {self.pid} ({self.comm})"
        where = "is running" if self.waits_in == "running" else f"waits in {self.waits_in}"
        if self.shimless:
            return (f"{who} of the flight command never loaded the clock shim (a static or set-user-ID "
                    f"program, or one started without LD_PRELOAD) and {where}")
        return f"{who} of the flight command {where}, a call the clock shim does not interpose"

    def same_wait(self, later: Suspect) -> bool:
        """Still the same wait at ``later``: same call, and no CPU time used in between (a
        process of a shim-less tree is the same one, whatever it did)."""
        if (later.pid, later.tid, later.start) != (self.pid, self.tid, self.start):
            return False
        return self.shimless or (later.syscall == self.syscall and later.run_ns == self.run_ns)


def _read(path: str) -> bytes:
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError:
        return b""


def _run_ns(pid: int, tid: int) -> int:
    """CPU time of thread ``tid`` (ns, /proc schedstat), -1 if unknown."""
    try:
        return int(_read(f"/proc/{pid}/task/{tid}/schedstat").split()[0])
    except (IndexError, ValueError):
        return -1


def _thread_state(pid: int, tid: int) -> str:
    raw = _read(f"/proc/{pid}/task/{tid}/stat")
    i = raw.rfind(b")")
    return raw[i + 2 : i + 3].decode() if i >= 0 else ""


def suspects(tree: ProcessTree, threads: Iterable[ThreadView], library: str | None) -> list[Suspect] | None:
    """What keeps the flight command from going idle where the shim cannot see; None if a
    process of the tree is stopped (a debugger or SIGSTOP: the bench just waits)."""
    by_pid: dict[int, list[ThreadView]] = {}
    for t in threads:
        by_pid.setdefault(t.pid, []).append(t)
    tids: Mapping[int, list[int]] = {pid: [t.tid for t in ts if t.tid > 0] for pid, ts in by_pid.items()}
    tree.discover(tids)
    found: list[Suspect] = []
    for pid in list(tree.members):
        st = tree.state(pid)
        if st is None or st.dead:
            continue
        if st.stopped:
            return None
        mine = by_pid.get(pid)
        lost = mine is not None and library is not None and shim_mapped(pid, library) is False
        if mine is None or lost:
            found.append(Suspect(pid, pid, st.comm, st.start, what_it_waits_in(pid), _read(f"/proc/{pid}/syscall"),
                                 _run_ns(pid, pid), shimless=True))
            continue
        for t in mine:
            if t.blocked or t.tid <= 0:
                continue
            state = _thread_state(pid, t.tid)
            if state in ("T", "t"):
                return None
            if state in ("S", "D"):
                found.append(Suspect(pid, t.tid, st.comm, st.start, what_it_waits_in(pid, t.tid),
                                     _read(f"/proc/{pid}/task/{t.tid}/syscall"), _run_ns(pid, t.tid),
                                     shimless=False))
    return found


def confirmed(first: Iterable[Suspect], later: Iterable[Suspect]) -> list[Suspect]:
    """The suspects of ``later`` that were already in ``first`` in the same wait."""
    before = {(s.pid, s.tid): s for s in first}
    return [s for s in later if (s.pid, s.tid) in before and before[(s.pid, s.tid)].same_wait(s)]


def message(found: Iterable[Suspect], waited_s: float) -> str:
    """One sentence for the run's end."""
    return ("; ".join(s.sentence() for s in found)
            + f": virtual time cannot go on (the bench waited {waited_s:.0f} s of wall time for the flight "
              "command to go idle; docs/time.md, launchers).")


def check_shim(pid: int, library: str | None) -> None:
    """Raise :class:`ShimLost` if the flight command's own process exec'd out of the shim."""
    if library is not None and shim_mapped(pid, library) is False:
        raise ShimLost(f"the flight code (pid {pid}) runs without the clock shim: it exec'd a program "
                       "without LD_PRELOAD (a wrapper such as `env -u LD_PRELOAD` or `sudo`, or a "
                       "set-user-ID helper)")


def unseen_lines(found: list[Suspect] | None) -> tuple[str, ...]:
    """The stall note's lines: each suspect, or the stop that makes the bench wait."""
    if found is None:
        return ("a process of the flight command is stopped (a debugger or SIGSTOP): the bench waits",)
    return tuple(s.sentence() for s in found)


class StallWatch:
    """One wait for idle that has gone on: the stall warning once ``warn_s`` of wall time has
    passed, then a look every ``CONFIRM_S``; a suspect found at two looks in a row in the same
    wait raises :class:`HiddenWait`."""

    def __init__(self, now: float, warn_s: float) -> None:
        self.started = now
        self.due = now + warn_s  #: loop time of the next look
        self.reported = False
        self._before: list[Suspect] = []

    def look(self, now: float, found: list[Suspect] | None) -> bool:
        """A look at ``now`` with what it ``found`` (None: a process is stopped). True the
        first time: the stall to report."""
        self.due = now + CONFIRM_S
        first = not self.reported
        self.reported = True
        same = confirmed(self._before, found or [])
        if same:
            raise HiddenWait(message(same, now - self.started))
        self._before = found or []
        return first
