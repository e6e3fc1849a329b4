"""Is this file a run's log? One sentence on why not, for every command that reads one.

``hil timing``, ``hil report``, ``hil replay`` and ``hil recover`` call :func:`check_log`
(or :func:`check_mcap` for ``recover``, which also takes a torn file) before reading, and
turn :class:`LogError` into exit status 2. A file is refused when it is missing, not a
regular file, unreadable, not an MCAP file at all (no leading magic, MCAP specification
https://mcap.dev/spec#magic), torn (no footer: a killed run, usually ``*.mcap.part``),
damaged (its summary does not read) or foreign (an MCAP without this bench's ``run``
metadata record, hil/record/writer.py).
"""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path

from mcap.exceptions import McapError

MAGIC = b"\x89MCAP0\r\n"
#: what a damaged MCAP raises while its summary or records are read
READ_ERRORS: tuple[type[BaseException], ...] = (McapError, EOFError, ValueError, struct.error, zlib.error,
                                                 KeyError, IndexError, MemoryError)


class LogError(ValueError):
    """A file that is not a readable run log; the message is one sentence naming it."""


def check_mcap(path: Path | str) -> Path:
    """``path`` exists, is a readable regular file and starts with the MCAP magic; returns it."""
    p = Path(path)
    if not p.exists():
        raise LogError(f"{p}: no such file")
    if not p.is_file():
        raise LogError(f"{p}: not a regular file (a run's log is one .mcap file)")
    try:
        with p.open("rb") as f:
            head = f.read(len(MAGIC))
    except OSError as exc:
        raise LogError(f"{p}: cannot be read ({exc.strerror or exc})") from exc
    if head != MAGIC:
        what = "the file is empty" if not head else "not an MCAP file (it does not start with the MCAP magic bytes)"
        raise LogError(f"{p}: {what}; a run's log is the .mcap file `hil run` writes")
    return p


def check_log(path: Path | str) -> Path:
    """``path`` is a complete run log of this bench (see module docstring); returns it."""
    p = check_mcap(path)
    with p.open("rb") as f:
        f.seek(0, os.SEEK_END)
        size = f.tell()
        if size < 2 * len(MAGIC) or (f.seek(size - len(MAGIC)), f.read(len(MAGIC)))[1] != MAGIC:
            raise LogError(f"{p}: torn MCAP file, it has no footer (a killed run?); "
                           f"salvage it with `hil recover {p}`")
        f.seek(0)
        try:
            from mcap.reader import make_reader

            reader = make_reader(f)
            summary = reader.get_summary()
            names = ({ix.name for ix in summary.metadata_indexes} if summary is not None
                     else {m.name for m in reader.iter_metadata()})
        except READ_ERRORS as exc:
            raise LogError(f"{p}: damaged MCAP file, its index does not read ({type(exc).__name__}: {exc}); "
                           f"try `hil recover {p}`") from exc
    if "run" not in names:
        raise LogError(f"{p}: an MCAP file, but not a run log of this bench (no 'run' metadata record)")
    return p
