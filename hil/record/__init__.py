"""Recording: one MCAP file per run, written off the tick path; reading and recovery.

See docs/recording.md for the topics, units, frames and how to open a run in Foxglove or
PlotJuggler.
"""

from hil.record.reader import (
    TornRecordingError,
    chunk_counts,
    iter_messages,
    iter_wire,
    message_counts,
    read_attachments,
    read_metadata,
    read_topic,
    read_wire,
)
from hil.record.recover import recover, recovered_path
from hil.record.topics import TOPICS, WIRE_PORTS, TopicSpec, UnknownTopicError, topic_spec, wire_topic
from hil.record.validate import Validation, validate
from hil.record.writer import Recorder, RecordStats, RecordWriteError

__all__ = [
    "TOPICS", "WIRE_PORTS", "RecordStats", "RecordWriteError", "Recorder", "TopicSpec", "TornRecordingError",
    "UnknownTopicError", "chunk_counts", "iter_messages", "iter_wire", "message_counts", "read_attachments", "read_metadata", "read_topic",
    "read_wire", "recover", "recovered_path", "topic_spec", "validate", "Validation", "wire_topic",
]
