"""Reading a run's MCAP file back: messages, columns, metadata, attachments, counts.

Built on ``mcap.reader.make_reader`` (indexed, log-time order; equal log times keep file
order, so each channel comes back in the order it was logged). JSON messages are decoded
like Foxglove does: ``json.loads`` and base64 fields (``contentEncoding: base64`` in the
channel's schema) turned back into ``bytes``. Protobuf messages are decoded with the schema
the file carries (``hil/record/protobuf.py``); ``t_ns`` / ``t_host_ns`` they leave out are
put back from the log time / publish time.

Old and new logs read alike (docs/recording.md "Formats"): a ``hil.WireChunks`` message
(100 ms of one wire) comes back as one ``hil.WireChunk``-shaped dict per transport read/write,
and a ``hil.AdcConversions`` message (one tick) as one dict per conversion, each with its
own ``t_ns`` and log time, as JSON-era logs stored them.

A file without a footer (a killed run, usually ``*.mcap.part``) raises
``TornRecordingError``: run ``hil.record.recover`` (``hil recover LOG``) first.
"""

from __future__ import annotations

import base64
import heapq
import json
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np
from mcap.reader import McapReader, make_reader
from mcap.records import Schema
from mcap.well_known import MessageEncoding

from hil.record import protobuf

_MAGIC = b"\x89MCAP0\r\n"


class TornRecordingError(ValueError):
    """The file does not end with the MCAP footer magic (killed writer): recover it first."""


def _check_complete(f: IO[bytes], path: Path) -> None:
    f.seek(0, 2)
    size = f.tell()
    if size >= 2 * len(_MAGIC):
        f.seek(size - len(_MAGIC))
        if f.read(len(_MAGIC)) == _MAGIC:
            f.seek(0)
            return
    raise TornRecordingError(f"{path}: no MCAP footer (killed run?); salvage it with `hil recover {path}`")


def _open(path: Path | str) -> tuple[IO[bytes], McapReader]:
    p = Path(path)
    f = p.open("rb")
    try:
        _check_complete(f, p)
        return f, make_reader(f)
    except BaseException:
        f.close()
        raise


def _decoder(schema: Schema | None, message_encoding: str) -> Callable[[bytes], dict[str, Any]]:
    if message_encoding == MessageEncoding.Protobuf:
        if schema is None or not schema.data:
            raise ValueError("a protobuf channel without a schema")
        return protobuf.decoder(schema.name, bytes(schema.data))
    if message_encoding != MessageEncoding.JSON:
        raise ValueError(f"unsupported message encoding {message_encoding!r} (this bench writes json and protobuf)")
    b64_fields: list[str] = []
    if schema is not None and schema.data:
        props = json.loads(schema.data).get("properties", {})
        b64_fields = [k for k, v in props.items() if isinstance(v, dict) and v.get("contentEncoding") == "base64"]

    def decode(data: bytes) -> dict[str, Any]:
        msg = json.loads(data)
        for k in b64_fields:
            if isinstance(msg.get(k), str):
                msg[k] = base64.b64decode(msg[k])
        return msg

    return decode


def _restamp(fields: frozenset[str], run_start_ns: int) -> Callable[[dict[str, Any], int, int], dict[str, Any]]:
    """Put back the ``t_ns`` / ``t_host_ns`` a protobuf message left out (first, as JSON had them)."""
    has_t = "t_ns" in fields
    has_host = "t_host_ns" in fields

    def restamp(msg: dict[str, Any], log_time: int, publish_time: int) -> dict[str, Any]:
        head: dict[str, Any] = {}
        if has_t:
            head["t_ns"] = msg.pop("t_ns", log_time - run_start_ns)
        if has_host:
            head["t_host_ns"] = msg.pop("t_host_ns", publish_time)
        return head | msg if head else msg

    return restamp


def expand_wire(log_time: int, msg: dict[str, Any]) -> Iterator[tuple[int, dict[str, Any]]]:
    """The transport reads/writes of a ``hil.WireChunks`` message: (log time, chunk dict)."""
    data: bytes = msg.get("data", b"")
    lens = msg.get("chunk_len") or [len(data)]
    dts = msg.get("chunk_dt_ns") or [0] * len(lens)
    dhs = msg.get("chunk_dt_host_ns") or [0] * len(lens)
    t, host, lt, off = int(msg["t_ns"]), int(msg["t_host_ns"]), log_time, 0
    for n, dt, dh in zip(lens, dts, dhs, strict=True):
        t, host, lt = t + dt, host + dh, lt + dt
        yield lt, {"t_ns": t, "t_host_ns": host, "port": msg.get("port", ""), "direction": msg.get("direction", ""),
                   "len": n, "data": data[off : off + n]}
        off += n


def expand_adc(log_time: int, msg: dict[str, Any]) -> Iterator[tuple[int, dict[str, Any]]]:
    """The conversions of a ``hil.AdcConversions`` message, as ``hil.AdcConversion`` dicts."""
    codes = msg.get("code", [])
    n = len(codes)
    dts = msg.get("dt_ns") or [0] * n
    optional = {k: msg[k] for k in ("single_ended", "vref_V") if len(msg.get(k, ())) == n}
    for i in range(n):
        conv: dict[str, Any] = {"t_ns": int(msg["t_ns"]) + dts[i], "channel": msg["channel"][i], "code": codes[i],
                                "volts": msg["volts"][i]}
        for k, values in optional.items():
            conv[k] = values[i]
        if "port" in msg:
            conv["port"] = msg["port"]
        yield log_time + dts[i], conv


_EXPAND: dict[str, Callable[[int, dict[str, Any]], Iterator[tuple[int, dict[str, Any]]]]] = {
    "hil.WireChunks": expand_wire, "hil.AdcConversions": expand_adc}


def _run_start_ns(reader: McapReader) -> int:
    for m in reader.iter_metadata():
        if m.name == "run" and "run_start_unix_ns" in m.metadata:
            return int(m.metadata["run_start_unix_ns"])
    return 0


def iter_messages(path: Path | str, topics: Iterable[str] | None = None, *,
                  expand: bool = True) -> Iterator[tuple[str, int, dict[str, Any]]]:
    """Yield ``(topic, log_time_ns, message)`` in log-time order, optionally only ``topics``.

    ``expand`` (default): wire batches and per-tick ADC messages come back as one dict per
    chunk / conversion (module docstring), so old and new logs read alike; the items of one
    message follow each other (across topics, order is by the message's log time).
    ``expand=False`` gives the messages as stored.
    """
    f, reader = _open(path)
    decoders: dict[int, Callable[[bytes], dict[str, Any]]] = {}
    restampers: dict[int, Callable[[dict[str, Any], int, int], dict[str, Any]] | None] = {}
    expanders: dict[int, Callable[[int, dict[str, Any]], Iterator[tuple[int, dict[str, Any]]]] | None] = {}
    with f:
        run_start = _run_start_ns(reader)  # before iterating: it seeks
        for schema, channel, message in reader.iter_messages(topics=list(topics) if topics is not None else None):
            dec = decoders.get(channel.id)
            if dec is None:
                dec = decoders[channel.id] = _decoder(schema, channel.message_encoding)
                if channel.message_encoding == MessageEncoding.Protobuf and schema is not None:
                    restampers[channel.id] = _restamp(protobuf.field_names(schema.name, bytes(schema.data)), run_start)
                else:
                    restampers[channel.id] = None
                expanders[channel.id] = _EXPAND.get(schema.name) if expand and schema is not None else None
            msg = dec(message.data)
            restamp = restampers[channel.id]
            if restamp is not None:
                msg = restamp(msg, message.log_time, message.publish_time)
            expander = expanders[channel.id]
            if expander is None:
                yield channel.topic, message.log_time, msg
            else:
                for log_time, item in expander(message.log_time, msg):
                    yield channel.topic, log_time, item


def iter_wire(path: Path | str, topics: Iterable[str]) -> Iterator[tuple[str, int, dict[str, Any]]]:
    """Wire chunks of ``topics`` merged across topics in chunk log-time order (ties keep the
    topics' order). ``iter_messages`` orders wire messages by their first chunk, and one
    message holds up to 100 ms of a wire: a replay of several ports needs this instead."""
    def keyed(i: int, topic: str) -> Iterator[tuple[tuple[int, int, int], tuple[str, int, dict[str, Any]]]]:
        for n, (t, lt, msg) in enumerate(iter_messages(path, [topic])):
            yield (lt, i, n), (t, lt, msg)

    merged = heapq.merge(*(keyed(i, t) for i, t in enumerate(topics)), key=lambda x: x[0])
    for _, item in merged:
        yield item


def chunk_counts(path: Path | str) -> dict[str, int]:
    """Transport reads/writes per wire topic (the ``chunks.<topic>`` summary counts of the
    compact format; one per message in JSON-era logs)."""
    counts = message_counts(path)
    summary = read_metadata(path).get("summary", {})
    return {t: int(summary.get(f"chunks.{t}", n)) for t, n in counts.items() if t.startswith("/hil/wire/")}


def _flatten(d: dict[str, Any], prefix: str, out: dict[str, Any]) -> None:
    for k, v in d.items():
        if isinstance(v, dict):
            _flatten(v, f"{prefix}{k}.", out)
        else:
            out[prefix + k] = v


def _column(values: list[Any]) -> np.ndarray:
    """A column of one field: numbers -> 1-D, equal-length numeric lists -> 2-D, else object."""
    present = [v for v in values if v is not None]
    if not present:
        return np.full(len(values), np.nan)
    if all(isinstance(v, bool) for v in present) and len(present) == len(values):
        return np.asarray(values, dtype=bool)
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        if len(present) == len(values) and all(isinstance(v, int) for v in values):
            try:
                return np.asarray(values, dtype=np.int64)
            except OverflowError:
                pass
        return np.asarray([np.nan if v is None else v for v in values], dtype=np.float64)
    if len(present) == len(values) and all(isinstance(v, list) for v in values):
        lengths = {len(v) for v in values}
        flat = [x for v in values for x in v]
        if len(lengths) == 1 and all(isinstance(x, (int, float)) or x is None for x in flat):
            n = lengths.pop()
            if all(isinstance(x, bool) for x in flat):
                return np.asarray(values, dtype=bool).reshape(len(values), n)
            if all(isinstance(x, int) and not isinstance(x, bool) for x in flat):
                return np.asarray(values, dtype=np.int64).reshape(len(values), n)
            return np.asarray([[np.nan if x is None else x for x in v] for v in values],
                              dtype=np.float64).reshape(len(values), n)
    if all(isinstance(v, str) for v in present) and len(present) == len(values):
        return np.asarray(values, dtype=str)
    out = np.empty(len(values), dtype=object)
    out[:] = values
    return out


def read_topic(path: Path | str, topic: str) -> dict[str, np.ndarray]:
    """All messages of ``topic`` as columns: ``log_time_ns`` (int64) plus one array per field.

    Nested objects become dotted names (``euler_deg.roll``); fixed-length numeric arrays
    become 2-D arrays (``p_N_m`` shape (n, 3)); integers stay int64, booleans bool, strings
    str; missing numbers are NaN; anything else is an object array. A topic with no
    messages gives only an empty ``log_time_ns``. ``KeyError`` if the file has no such topic.
    """
    f, reader = _open(path)
    with f:
        summary = reader.get_summary()
        known = {c.topic for c in summary.channels.values()} if summary is not None else set()
    if topic not in known:
        raise KeyError(f"{path}: no topic {topic!r} (has {sorted(known)})")
    times: list[int] = []
    rows: list[dict[str, Any]] = []
    for _, log_time, msg in iter_messages(path, [topic]):
        times.append(log_time)
        row: dict[str, Any] = {}
        _flatten(msg, "", row)
        rows.append(row)
    keys: dict[str, None] = {}
    for row in rows:
        keys.update(dict.fromkeys(row))
    out: dict[str, np.ndarray] = {"log_time_ns": np.asarray(times, dtype=np.int64)}
    for k in keys:
        out[k] = _column([row.get(k) for row in rows])
    return out


def read_metadata(path: Path | str) -> dict[str, dict[str, str]]:
    """Metadata records by name (``run``, ``verdict``, ``summary``, ``recovery`` ...)."""
    f, reader = _open(path)
    with f:
        return {m.name: dict(m.metadata) for m in reader.iter_metadata()}


def read_attachments(path: Path | str) -> dict[str, tuple[str, bytes]]:
    """Attachments by name: ``(media_type, data)``."""
    f, reader = _open(path)
    with f:
        return {a.name: (a.media_type, bytes(a.data)) for a in reader.iter_attachments()}


def message_counts(path: Path | str) -> dict[str, int]:
    """Messages per topic from the summary statistics (every channel, zeros included)."""
    f, reader = _open(path)
    with f:
        summary = reader.get_summary()
    if summary is None or summary.statistics is None:
        raise ValueError(f"{path}: no summary statistics")
    counts = summary.statistics.channel_message_counts
    out: dict[str, int] = {}
    for cid, ch in summary.channels.items():
        out[ch.topic] = out.get(ch.topic, 0) + counts.get(cid, 0)
    return out


def read_wire(path: Path | str, port: str, direction: str) -> bytes:
    """Every byte recorded on ``/hil/wire/<port>/<direction>``, concatenated in order."""
    return b"".join(m["data"] for _, _, m in iter_messages(path, [f"/hil/wire/{port}/{direction}"]))
