"""MCAP footprint of a run log (not a test): file size, MB per flight minute, per-topic share.

Run: ``.venv/bin/python tests/bench/mcap_footprint.py LOG.mcap [LOG2.mcap ...]``

Per topic: messages, rate, payload bytes (uncompressed message data), and the estimated
share of the file. The share of a chunk's compressed size is each topic's marginal cost
(the chunk's records zstd-compressed with and without the topic's records), scaled so the
shares add up to the chunk's real compressed size; plus the 16-byte message-index entry each
message costs outside the chunks (when the file has message indexes). The flight minute is the span of ``/hil/timing/tick`` (else of
every message) in log time.
"""

from __future__ import annotations

import struct
import sys
from collections import Counter, defaultdict
from pathlib import Path

import zstandard
from mcap.records import Chunk, Message, MessageIndex
from mcap.stream_reader import StreamReader, breakup_chunk

_MSG_HEADER = 31  # opcode 1 + length 8 + channel 2 + sequence 4 + log_time 8 + publish_time 8
_INDEX_ENTRY = 16  # log_time 8 + offset 8, per message, outside the chunk


def footprint(path: Path) -> dict[str, object]:
    size = path.stat().st_size
    topics: dict[int, str] = {}
    count: Counter[str] = Counter()
    payload: Counter[str] = Counter()
    share: defaultdict[str, float] = defaultdict(float)
    indexed = False
    t_min: dict[str, int] = {}
    t_max: dict[str, int] = {}
    with path.open("rb") as f:
        for rec in StreamReader(f, skip_magic=False, emit_chunks=True).records:
            if isinstance(rec, MessageIndex):
                indexed = True
            elif hasattr(rec, "topic") and hasattr(rec, "message_encoding"):
                topics[rec.id] = rec.topic  # type: ignore[attr-defined]
            elif isinstance(rec, Chunk):
                raw: Counter[str] = Counter()
                records: defaultdict[str, list[bytes]] = defaultdict(list)
                for inner in breakup_chunk(rec, validate_crc=False):
                    if hasattr(inner, "topic") and hasattr(inner, "message_encoding"):
                        topics[inner.id] = inner.topic  # type: ignore[attr-defined]
                    if isinstance(inner, Message):
                        topic = topics.get(inner.channel_id, f"#{inner.channel_id}")
                        count[topic] += 1
                        payload[topic] += len(inner.data)
                        raw[topic] += _MSG_HEADER + len(inner.data)
                        records[topic].append(struct.pack("<HIQQ", inner.channel_id, inner.sequence, inner.log_time,
                                                          inner.publish_time) + inner.data)
                        t_min[topic] = min(t_min.get(topic, inner.log_time), inner.log_time)
                        t_max[topic] = max(t_max.get(topic, inner.log_time), inner.log_time)
                compressed = len(rec.data) + 8 * 4 + 4 + len(rec.compression)
                order = [t for t in records]
                whole = len(zstandard.compress(b"".join(b"".join(records[t]) for t in order)))
                marginal = {t: max(1, whole - len(zstandard.compress(b"".join(b"".join(records[u]) for u in order if u != t))))
                            for t in order}
                total = sum(marginal.values())
                for topic, m in marginal.items():
                    share[topic] += compressed * m / total
    if indexed:
        for topic, n in count.items():
            share[topic] += _INDEX_ENTRY * n
    span_topic = "/hil/timing/tick" if count.get("/hil/timing/tick") else None
    if span_topic:
        span_ns = t_max[span_topic] - t_min[span_topic]
    else:
        span_ns = (max(t_max.values()) - min(t_min.values())) if t_max else 0
    minutes = max(span_ns / 60e9, 1e-9)
    return {"path": path, "size": size, "minutes": minutes, "indexed": indexed,
            "count": count, "payload": payload, "share": share}


def main(argv: list[str]) -> int:
    for arg in argv:
        fp = footprint(Path(arg))
        size, minutes = fp["size"], fp["minutes"]  # type: ignore[assignment]
        print(f"{arg}: {size / 1e6:.2f} MB, {minutes * 60:.1f} s of flight, "
              f"{size / 1e6 / minutes:.2f} MB per flight minute, message indexes: {fp['indexed']}")
        count, payload, share = fp["count"], fp["payload"], fp["share"]  # type: ignore[assignment]
        print(f"  {'topic':<28} {'msgs':>8} {'msg/s':>8} {'payload B/msg':>13} {'file kB/min':>11}")
        for topic in sorted(count, key=lambda t: -share[t]):
            print(f"  {topic:<28} {count[topic]:>8} {count[topic] / (minutes * 60):>8.1f} "
                  f"{payload[topic] / count[topic]:>13.1f} {share[topic] / 1e3 / minutes:>11.1f}")
        other = size - sum(share.values())
        print(f"  {'(header, metadata, attachments, summary)':<44} {other / 1e3:>8.1f} kB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
