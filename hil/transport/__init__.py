"""Byte transports between the bench and the flight code.

A :class:`~hil.transport.base.Port` is a byte pipe with no knowledge of protocols:
``write`` never blocks, received bytes go to ``on_data``, line-setting changes of the
client go to ``on_line``, and every byte in either direction goes to the wire tap.
``PtyPort`` is the real thing; ``MemoryPort`` is its in-memory twin for fast tests.
Both pass ``tests/transport/conformance.py``.
"""

from hil.transport.base import LineSettings, Port, PortStats, WireRecord
from hil.transport.memory import MemoryPort
from hil.transport.pty import PtyPort

__all__ = ["LineSettings", "MemoryPort", "Port", "PortStats", "PtyPort", "WireRecord"]
