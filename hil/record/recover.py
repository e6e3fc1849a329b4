"""Salvage a killed run's MCAP file (``hil recover LOG``).

A SIGKILLed writer leaves the header, the ``run`` metadata and attachments (written first),
every complete chunk, then a torn record and no summary or footer. Readers that seek
(``make_reader``) fail on it; ``mcap.stream_reader.StreamReader`` reads every record up to
the tear, validating chunk CRCs, and we copy them into a fresh, indexed file with the same
chunking. mcap-python has no recover of its own.

Nothing is lost on the way: an output that is the input (same path or same file) is
refused, a file that is not an MCAP at all is refused (:class:`~hil.record.log_check.LogError`),
and the result is written to a temporary file beside ``dst`` and renamed over it only once
it is complete.
"""

from __future__ import annotations

import contextlib
import os
import struct
import secrets
import zlib
from pathlib import Path
from typing import BinaryIO

from mcap.exceptions import McapError
from mcap.records import Attachment, Channel, Footer, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from hil.record.log_check import LogError, check_mcap
from hil.record.writer import LOG_FILE_MODE

try:  # zstd decompression errors of a torn/corrupt chunk
    from zstandard import ZstdError as _ZstdError
except ImportError:  # pragma: no cover - zstandard is a dependency
    _ZstdError = McapError  # type: ignore[misc,assignment]

_RECORD_LIMIT = 1 << 30  # a torn tail can decode as an absurd length; do not try to allocate it
_TORN = (McapError, EOFError, ValueError, struct.error, _ZstdError, zlib.error, MemoryError, IndexError)


def recovered_path(src: Path | str) -> Path:
    """Where ``hil recover`` puts the result: ``run.mcap.part`` -> ``run.mcap``,
    ``run.mcap`` (or any other name) -> ``run.recovered.mcap``: the result is an MCAP file."""
    p = Path(src)
    if p.name.endswith(".part"):
        return p.with_name(p.name[: -len(".part")])
    return p.with_suffix(".recovered.mcap")


def _same_file(a: Path, b: Path) -> bool:
    if a.resolve() == b.resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # b does not exist yet
        return False


def _create_temp(dst: Path) -> tuple[int, Path]:
    """A new hidden file beside ``dst`` (same file system: the rename is atomic), with the
    mode of a recorded log (LOG_FILE_MODE, narrowed by the umask)."""
    while True:
        tmp = dst.with_name(f".{dst.name}.{secrets.token_hex(4)}.tmp")
        try:
            return os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, LOG_FILE_MODE), tmp
        except FileExistsError:
            continue


def recover(src: Path | str, dst: Path | str, *, chunk_size: int = 65536) -> int:
    """Copy every readable record of ``src`` into a valid MCAP ``dst``; returns messages copied.

    Header (profile), metadata, attachments, schemas, channels and the messages of every
    complete chunk are kept, in file order. A ``recovery`` metadata record notes the source,
    the count and where and why reading stopped. ``dst`` is replaced only once the new file is
    complete. Raises :class:`LogError` (nothing written) when ``src`` is not an MCAP file or
    ``dst`` is ``src``.
    """
    src_p, dst_p = check_mcap(src), Path(dst)
    if _same_file(src_p, dst_p):
        raise LogError(f"{dst_p}: the output is the input file; recover writes a new file (choose another --out)")
    fd, tmp_name = _create_temp(dst_p)
    try:
        with os.fdopen(fd, "wb") as out:
            n = _copy(src_p, out, chunk_size)
        os.replace(tmp_name, dst_p)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp_name)
        raise
    return n


def _copy(src_p: Path, out: BinaryIO, chunk_size: int) -> int:
    n = 0
    stop_reason = "footer"
    with src_p.open("rb") as f:
        w = Writer(out, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        started = False
        schemas: dict[int, int] = {0: 0}
        channels: dict[int, int] = {}
        orphans = 0
        try:
            for rec in StreamReader(f, validate_crcs=True, record_size_limit=_RECORD_LIMIT).records:
                if not started:
                    w.start(profile=rec.profile if isinstance(rec, Header) else "",
                            library="mav-hil-bench recover (mcap-python)")
                    started = True
                if isinstance(rec, Schema):
                    if rec.id not in schemas:
                        schemas[rec.id] = w.register_schema(rec.name, rec.encoding, rec.data)
                elif isinstance(rec, Channel):
                    if rec.id not in channels and rec.schema_id in schemas:
                        channels[rec.id] = w.register_channel(rec.topic, rec.message_encoding,
                                                              schemas[rec.schema_id], dict(rec.metadata))
                elif isinstance(rec, Message):
                    cid = channels.get(rec.channel_id)
                    if cid is None:
                        orphans += 1
                        continue
                    w.add_message(cid, rec.log_time, rec.data, rec.publish_time, rec.sequence)
                    n += 1
                elif isinstance(rec, Metadata):
                    w.add_metadata(rec.name, dict(rec.metadata))
                elif isinstance(rec, Attachment):
                    w.add_attachment(rec.create_time, rec.log_time, rec.name, rec.media_type, bytes(rec.data))
                elif isinstance(rec, Footer):
                    break
            else:
                stop_reason = "end of file"
        except _TORN as e:
            stop_reason = f"{type(e).__name__}: {e}"[:500]
        if not started:
            w.start(profile="", library="mav-hil-bench recover (mcap-python)")
        note = {"source": src_p.name, "messages": str(n), "stopped_at": stop_reason}
        if orphans:
            note["orphan_messages"] = str(orphans)
        w.add_metadata("recovery", note)
        w.finish()
    return n
