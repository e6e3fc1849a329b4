"""Protobuf schemas for the compact topics, built from the topic table's JSON schemas.

Why protobuf: at 400 Hz a JSON message costs 2-4x its protobuf form in the file (keys,
17-digit floats, base64), and Foxglove reads protobuf channels in MCAP natively (schema
encoding ``protobuf``, schema data a serialized ``FileDescriptorSet``, schema name the full
message name), so its plot and raw-message panels keep working.

The JSON schema of a topic (``topics.py``) stays the one description of its fields: this
module turns it into a proto2 message (``proto2`` so that every scalar has presence: an item
a message does not carry is left out, as in JSON; no proto3 ``optional`` synthetic oneofs).
Mapping: ``number`` -> ``double`` (``float`` where the topic says float32, unless the field
says ``"format": "double"``), ``integer`` -> ``sint64`` (``uint64`` with ``minimum >= 0``),
``boolean`` -> ``bool``, ``string`` -> ``string`` (``bytes`` with ``contentEncoding: base64``),
fixed arrays -> packed ``repeated``, objects with properties -> a nested message. Field numbers follow the property order.
Free-form objects have no protobuf form: such topics stay JSON.

``google.protobuf`` is imported only when a protobuf topic is encoded or decoded (start-up
time of the ``hil`` command).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from functools import lru_cache
from typing import Any

_FILE_PREFIX = "mav-hil-bench/"


def _camel(name: str) -> str:
    return "".join(part[:1].upper() + part[1:] for part in name.split("_"))


def _add_message(msg: Any, schema: Mapping[str, Any], full_name: str, float32: bool) -> None:
    from google.protobuf import descriptor_pb2 as d

    F = d.FieldDescriptorProto
    for number, (name, prop) in enumerate(schema.get("properties", {}).items(), start=1):
        label = F.LABEL_OPTIONAL
        item = prop
        if prop.get("type") == "array":
            label = F.LABEL_REPEATED
            item = prop.get("items", {})
        kind = item.get("type")
        field = msg.field.add(name=name, number=number, label=label)
        if kind == "number":  # "format": "double" keeps a field exact in a float32 topic
            field.type = F.TYPE_FLOAT if float32 and item.get("format") != "double" else F.TYPE_DOUBLE
        elif kind == "integer":
            field.type = F.TYPE_UINT64 if item.get("minimum", -1) >= 0 else F.TYPE_SINT64
        elif kind == "boolean":
            field.type = F.TYPE_BOOL
        elif kind == "string":
            field.type = F.TYPE_BYTES if item.get("contentEncoding") == "base64" else F.TYPE_STRING
        elif kind == "object" and item.get("properties"):
            nested = msg.nested_type.add(name=_camel(name))
            _add_message(nested, item, f"{full_name}.{nested.name}", float32)
            field.type = F.TYPE_MESSAGE
            field.type_name = f".{full_name}.{nested.name}"
        else:
            raise ValueError(f"{full_name}.{name}: no protobuf form for {prop!r} (keep the topic JSON)")
        if label == F.LABEL_REPEATED and field.type not in (F.TYPE_MESSAGE, F.TYPE_STRING, F.TYPE_BYTES):
            field.options.packed = True


def file_descriptor_set(schema_name: str, schema: Mapping[str, Any], *, float32: bool = False) -> bytes:
    """The serialized ``FileDescriptorSet`` of message ``schema_name`` (``package.Message``)."""
    from google.protobuf import descriptor_pb2 as d

    package, _, message = schema_name.rpartition(".")
    f = d.FileDescriptorProto(name=f"{_FILE_PREFIX}{schema_name}.proto", package=package, syntax="proto2")
    msg = f.message_type.add(name=message)
    _add_message(msg, schema, schema_name, float32)
    return d.FileDescriptorSet(file=[f]).SerializeToString()  # type: ignore[no-any-return]


@lru_cache(maxsize=None)
def message_class(schema_name: str, descriptor_set: bytes) -> Any:
    """The Python message class of ``schema_name`` from its serialized ``FileDescriptorSet``
    (one private pool per schema: two files may define the same name differently)."""
    from google.protobuf import descriptor_pb2 as d
    from google.protobuf import descriptor_pool, message_factory

    pool = descriptor_pool.DescriptorPool()
    for f in d.FileDescriptorSet.FromString(descriptor_set).file:
        pool.Add(f)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema_name))


def encoder(schema_name: str, descriptor_set: bytes) -> Callable[[Mapping[str, Any]], bytes]:
    """``payload dict -> bytes``. Raises ``ValueError`` (unknown field) or ``TypeError`` (wrong
    type): the writer counts those as unencodable. NaN and inf are encoded as they are."""
    cls = message_class(schema_name, descriptor_set)

    def encode(payload: Mapping[str, Any]) -> bytes:
        return cls(**payload).SerializeToString()  # type: ignore[no-any-return]

    return encode


def to_dict(msg: Any) -> dict[str, Any]:
    """The fields a message carries, in field order (absent scalars are left out)."""
    out: dict[str, Any] = {}
    for fd, value in msg.ListFields():
        if fd.message_type is not None:
            out[fd.name] = [to_dict(v) for v in value] if fd.is_repeated else to_dict(value)
        elif fd.is_repeated:
            out[fd.name] = list(value)
        else:
            out[fd.name] = value
    return out


def decoder(schema_name: str, descriptor_set: bytes) -> Callable[[bytes], dict[str, Any]]:
    """``bytes -> dict`` for messages of ``schema_name`` (see ``to_dict``)."""
    cls = message_class(schema_name, descriptor_set)

    def decode(data: bytes) -> dict[str, Any]:
        return to_dict(cls.FromString(data))

    return decode


def field_names(schema_name: str, descriptor_set: bytes) -> frozenset[str]:
    """Top-level field names of the message."""
    return frozenset(f.name for f in message_class(schema_name, descriptor_set).DESCRIPTOR.fields)
