"""Sans-I/O device models.

Every device here takes host bytes plus a sim time ``t_ns`` and physical inputs, and
produces device bytes and typed events. Nothing in this package reads a clock, touches
a file descriptor, or imports asyncio, os, time, random, ``hil`` or ``flightcode``.
"""
