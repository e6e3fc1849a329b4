"""One message appended to an ``mcap.writer.Writer``'s open chunk with one ``struct`` pack.

Why: ``Writer.add_message`` builds a ``Message`` record object and writes it field by field
(five packs, a seek back for the length), and the chunk's message index is written later
with two packs a message: together about 10 us a message in the recorder child, which writes
five a tick (docs/performance.md, Recording). ``MessageAppender.add`` does the same
bookkeeping (the file's statistics, the chunk's time range and message index) and writes the
same bytes, the record in one pack, the index in one pack a channel. It reaches into the Writer's private state, so it checks
that state's shape once and otherwise calls ``Writer.add_message`` itself;
tests/unit/record/test_mcap_append.py keeps the two writing identical files.
"""

from __future__ import annotations

import io
import struct
from collections.abc import Callable
from typing import Any

from mcap.opcode import Opcode
from mcap.records import MessageIndex
from mcap.writer import Writer

#: opcode, record length, channel id, sequence, log time, publish time (the MCAP Message record)
_HEAD = struct.Struct("<BQHIQQ")
_BODY_FIXED = 2 + 4 + 8 + 8
_OPCODE = int(Opcode.MESSAGE)
#: opcode, record length, channel id, records length (the MCAP Message Index record's head)
_INDEX_HEAD = struct.Struct("<BQHI")
_INDEX_OPCODE = int(Opcode.MESSAGE_INDEX)


class _MessageIndex(MessageIndex):
    """A chunk's message index, written with one pack of its (log time, offset) pairs instead
    of two packs a message (same bytes: the library wrote a sixth of the child's time here)."""

    def write(self, stream: Any) -> None:
        records = self.records
        n = 2 * len(records)
        stream.write(_INDEX_HEAD.pack(_INDEX_OPCODE, 6 + 8 * n, self.channel_id, 8 * n))
        stream.write(struct.pack(f"<{n}Q", *[v for record in records for v in record]))


def _internals(writer: Writer) -> tuple[Any, Any, int, Callable[[], None]] | None:
    """(statistics, chunk builder, chunk size, the chunk's finishing check) if they look as
    this module expects, else None."""
    stats = getattr(writer, "_Writer__statistics", None)
    chunk = getattr(writer, "_Writer__chunk_builder", None)
    size = getattr(writer, "_Writer__chunk_size", None)
    finish = getattr(writer, "_Writer__maybe_finalize_chunk", None)
    if stats is None or chunk is None or not isinstance(size, int) or not callable(finish):
        return None
    needed_stats = ("message_count", "message_start_time", "message_end_time", "channel_message_counts")
    needed_chunk = ("num_messages", "message_start_time", "message_end_time", "message_indices", "record_writer")
    if not all(hasattr(stats, n) for n in needed_stats) or not all(hasattr(chunk, n) for n in needed_chunk):
        return None
    if not isinstance(getattr(chunk.record_writer, "_buffer", None), io.BytesIO):
        return None
    return stats, chunk, size, finish


class MessageAppender:
    """``add(channel_id, log_time, data, publish_time, sequence)``, as ``writer.add_message``.

    Like ``add_message``, ``add`` finishes the chunk once it is past the writer's chunk size.
    ``fast``: whether the one-pack path is in use (False: the library's own ``add_message``)."""

    def __init__(self, writer: Writer, *, fast: bool = True) -> None:
        self._writer = writer
        found = _internals(writer) if fast else None
        self.fast = found is not None
        self.add: Callable[[int, int, bytes, int, int], None] = self._add if found is not None else writer.add_message
        if found is not None:
            self._stats, self._chunk, self._chunk_size, self._finish = found

    def _add(self, channel_id: int, log_time: int, data: bytes, publish_time: int, sequence: int) -> None:
        st = self._stats
        if st.message_count == 0 or log_time < st.message_start_time:
            st.message_start_time = log_time
        if log_time > st.message_end_time:
            st.message_end_time = log_time
        st.channel_message_counts[channel_id] += 1
        st.message_count += 1
        cb = self._chunk
        if cb.num_messages == 0 or log_time < cb.message_start_time:
            cb.message_start_time = log_time
        if log_time > cb.message_end_time:
            cb.message_end_time = log_time
        buf = cb.record_writer._buffer  # the chunk builder's buffer is replaced when a chunk ends
        offset = buf.tell()
        index = cb.message_indices.get(channel_id)
        if not index:
            index = cb.message_indices[channel_id] = _MessageIndex(channel_id=channel_id, records=[])
        index.records.append((log_time, offset))
        cb.num_messages += 1
        n = len(data)
        buf.write(_HEAD.pack(_OPCODE, _BODY_FIXED + n, channel_id, sequence, log_time, publish_time))
        buf.write(data)
        if offset + _HEAD.size + n > self._chunk_size:
            self._finish()


__all__ = ["MessageAppender"]
