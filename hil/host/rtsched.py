"""Realtime runs at a real-time scheduling priority, where the host allows it.

In realtime mode the tick is due at a wall-clock instant and the flight code's command must
come within the tick. Under the default policy (``SCHED_OTHER``) any other busy process on
the host shares the cores with them: with CPU-bound processes beside a hover, ticks are
milliseconds late and many samples get no command. ``SCHED_FIFO`` threads run before every
``SCHED_OTHER`` one, which keeps the tick loop on time under the same load (`hil run
--mode realtime --stress-cpu 4` shows both on the machine at hand, docs/time.md).

What is raised, and what is not:

* the bench's tick-loop thread, for the tick loop only (put back after it: a campaign or a
  test session runs many flights in one process);
* what that thread starts meanwhile, which inherits the policy: the realtime pacer's thread
  (it wakes every tick: at the default policy it waited behind the load, and the raised
  tick loop with it) and the flight-code process with its restarts;
* not the recorder child, nor the ``--stress-cpu`` hogs: they are started before, and a slow
  writer costs a backlog, not a late tick.

The kernel's real-time throttling (``/proc/sys/kernel/sched_rt_runtime_us``, 0.95 s a second
by default) leaves the rest of the host a share even if a raised process spins.

Permission: root, ``CAP_SYS_NICE``, or a ``RLIMIT_RTPRIO`` (``ulimit -r``) of at least the
priority. ``policy = "auto"`` (the default) raises where that is granted and otherwise runs as
before, saying so in the run's notes; ``"fifo"`` refuses to run without it; ``"normal"`` never
raises.
"""

from __future__ import annotations

import enum
import os
import resource
from collections.abc import Callable
from dataclasses import dataclass
from types import TracebackType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from hil.config.rig import Rig

#: what sched_setscheduler is called through (tests put a refusing one in its place)
SetScheduler = Callable[[int, int, os.sched_param], None]


class RtPolicy(enum.Enum):
    AUTO = "auto"  #: SCHED_FIFO where the host allows it, else the default policy
    FIFO = "fifo"  #: SCHED_FIFO or no run
    NORMAL = "normal"  #: the default policy


class RtSchedError(Exception):
    """``policy = "fifo"`` on a host that does not allow it (the message says why and how)."""


@dataclass(frozen=True)
class RtScheduling:
    """What a realtime run got: FIFO and its priority, or NORMAL and why."""

    policy: RtPolicy  #: FIFO or NORMAL (what was applied, never AUTO)
    priority: int = 0
    reason: str = ""  #: why not FIFO (empty when it is)

    def describe(self) -> str:
        return f"SCHED_FIFO priority {self.priority}" if self.policy is RtPolicy.FIFO else f"SCHED_OTHER ({self.reason})"


def _refusal(priority: int, exc: OSError) -> str:
    soft, _hard = resource.getrlimit(resource.RLIMIT_RTPRIO)
    return (f"SCHED_FIFO priority {priority} was refused ({exc.strerror or exc}): it needs root, CAP_SYS_NICE "
            f"or a real-time priority limit of at least {priority} (this process: `ulimit -r` = {soft})")


class RealtimePriority:
    """Raise the calling thread, and what it starts, for the ``with`` block."""

    def __init__(self, policy: RtPolicy, priority: int, *, setscheduler: SetScheduler | None = None) -> None:
        self.policy = policy
        self.priority = priority
        self._set: SetScheduler = setscheduler or os.sched_setscheduler
        self._saved: tuple[int, os.sched_param] | None = None
        self.result = RtScheduling(RtPolicy.NORMAL, 0, "policy = \"normal\"") if policy is RtPolicy.NORMAL else None

    def probe(self) -> None:
        """``policy = "fifo"``: raise :class:`RtSchedError` now if the host refuses SCHED_FIFO,
        before a run creates anything (the thread's policy is put back at once)."""
        if self.policy is RtPolicy.FIFO:
            with RealtimePriority(RtPolicy.FIFO, self.priority, setscheduler=self._set):
                pass

    def __enter__(self) -> RtScheduling:
        if self.policy is RtPolicy.NORMAL:
            assert self.result is not None
            return self.result
        saved = (os.sched_getscheduler(0), os.sched_getparam(0))
        try:
            self._set(0, os.SCHED_FIFO, os.sched_param(self.priority))
        except OSError as exc:  # EPERM, or EINVAL where the kernel has no RT class
            why = _refusal(self.priority, exc)
            if self.policy is RtPolicy.FIFO:
                raise RtSchedError(why) from exc
            self.result = RtScheduling(RtPolicy.NORMAL, 0, why)
            return self.result
        self._saved = saved
        self.result = RtScheduling(RtPolicy.FIFO, self.priority)
        return self.result

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        if self._saved is not None:
            policy, param = self._saved
            self._saved = None
            os.sched_setscheduler(0, policy, param)


def for_rig(rig: Rig, *, realtime: bool = True) -> RealtimePriority:
    """The rig's ``[realtime]`` scheduling for a run (``realtime=False``: a lockstep run, never
    raised). ``policy = "fifo"`` on a host that refuses it is a :class:`~hil.config.ConfigError`
    naming the rig file and the key, raised here, before the run creates anything."""
    from hil.config import ConfigError

    section = rig.realtime
    rt = RealtimePriority(RtPolicy(section.policy) if realtime else RtPolicy.NORMAL, section.priority)
    try:
        rt.probe()
    except RtSchedError as exc:
        raise ConfigError(f"{rig.path}: [realtime] policy = \"fifo\": {exc}") from None
    return rt


def fifo_allowed(priority: int = 1) -> bool:
    """Whether this process may run on SCHED_FIFO at ``priority`` (its policy is left as it was)."""
    try:
        RealtimePriority(RtPolicy.FIFO, priority).probe()
    except RtSchedError:
        return False
    return True
