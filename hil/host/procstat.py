"""The fields of ``/proc/<pid>/stat`` (proc(5)), read one way for the whole bench.

The command name (field 2) is in parentheses and may itself hold spaces and parentheses, so
the fields are split after the last ``)``: index 0 here is field 3 (the state letter).
"""

from __future__ import annotations

from pathlib import Path

#: indices into :func:`stat_fields` (proc(5) field number - 3)
STATE, UTIME, STIME, STARTTIME = 0, 11, 12, 19


def stat_fields(pid: int | str, proc: Path = Path("/proc")) -> list[bytes] | None:
    """The fields after the command name of process ``pid`` ("self" for this one); None if
    there is no such process."""
    try:
        raw = (proc / str(pid) / "stat").read_bytes()
    except OSError:
        return None
    return raw[raw.rindex(b")") + 2 :].split()
