"""``MessageAppender`` (hil/record/mcap_append.py) writes the same file, byte for byte, as
``mcap.writer.Writer.add_message``: statistics, chunk time ranges, message indexes, records."""

from __future__ import annotations

import io

from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.writer import CompressionType, Writer

from hil.record.mcap_append import MessageAppender

_message = st.tuples(st.integers(0, 2), st.integers(0, 1 << 40), st.binary(max_size=300),
                     st.integers(0, 1 << 40), st.integers(0, 0xFFFFFFFF))


def _file(messages: list[tuple[int, int, bytes, int, int]], chunk_size: int, *, fast: bool) -> tuple[bytes, bool]:
    out = io.BytesIO()
    w = Writer(out, chunk_size=chunk_size, compression=CompressionType.ZSTD, enable_crcs=True)
    w.start(profile="p", library="l")
    sid = w.register_schema("s", "jsonschema", b"{}")
    channels = [w.register_channel(f"/c{i}", "json", sid) for i in range(3)]
    add = MessageAppender(w, fast=fast)
    for ch, log_time, data, publish_time, seq in messages:
        if ch == 2 and log_time % 7 == 0:
            w.flush()  # a chunk finished by the caller, as hil.record.emit does
        add.add(channels[ch], log_time, data, publish_time, seq)
    w.finish()
    return out.getvalue(), add.fast


@settings(max_examples=200, deadline=None)
@given(st.lists(_message, max_size=60), st.sampled_from([64, 512, 4096, 1 << 20]))
def test_the_file_equals_the_librarys_byte_for_byte(messages: list[tuple[int, int, bytes, int, int]],
                                                    chunk_size: int) -> None:
    fast, used_fast = _file(messages, chunk_size, fast=True)
    slow, used_slow = _file(messages, chunk_size, fast=False)
    assert used_fast and not used_slow  # the one-pack path is the one in use with this mcap
    assert fast == slow


def test_a_wrong_record_is_seen() -> None:
    """The comparison above can fail: the same messages with one sequence number changed."""
    msgs = [(0, 10, b"abc", 1, 1), (1, 20, b"de", 2, 2)]
    assert _file(msgs, 4096, fast=True)[0] != _file([msgs[0], (1, 20, b"de", 2, 3)], 4096, fast=False)[0]


def test_an_unknown_writer_falls_back_to_add_message() -> None:
    class Other(Writer):
        pass

    w = Other(io.BytesIO(), use_chunking=False)
    assert not MessageAppender(w).fast
