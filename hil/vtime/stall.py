"""When the flight code keeps the bench waiting: the record of a stall (what its threads were
doing) and the stalls that end virtual time: the flight code running without the clock shim,
and a process of the flight command waiting where the shim cannot see (docs/time.md).
"""

from __future__ import annotations

from dataclasses import dataclass

from mypy_extensions import mypyc_attr

from hil.native.frozen import by_fields
from hil.vtime.control import ThreadView


@mypyc_attr(native_class=False)  # compiled classes cannot derive from RuntimeError
class ShimLost(RuntimeError):
    """The flight-code process no longer has the clock shim mapped: it exec'd a program
    without it (a wrapper that clears LD_PRELOAD, a set-user-ID helper). Its clocks are the
    host's from then on and it will never report idle, so virtual time cannot go on."""


@mypyc_attr(native_class=False)  # compiled classes cannot derive from RuntimeError
class HiddenWait(RuntimeError):
    """A process of the flight command's tree stayed blocked in a call the clock shim does not
    interpose (``pause``, a static program's ``nanosleep``, ``system()``'s internal wait), or
    never loaded the shim: the bench cannot tell whether it is idle, so virtual time cannot go
    on. The message is one sentence naming the process and what it waits in."""


def shim_mapped(pid: int, library: str) -> bool | None:
    """Whether process ``pid`` has ``library`` mapped (None if it is gone)."""
    try:
        with open(f"/proc/{pid}/maps", encoding="utf-8", errors="replace") as f:
            return any(library in line for line in f)
    except OSError:
        return None


@dataclass(frozen=True)
class Stall:
    """What the flight code was doing when the bench had waited long for it (wall time)."""

    waited_s: float
    threads: tuple[ThreadView, ...]
    #: what each slot-less process of the flight command's tree was doing ("pid 12 (sleep) ...")
    unseen: tuple[str, ...] = ()

    def __reduce__(self) -> tuple[type, tuple[object, ...]]:
        return by_fields(self)  # compiled records pickle by field (hil/native/frozen.py)
