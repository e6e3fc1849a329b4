"""Python mirror of the control block's layout (``hvt_abi.h``).

The shim exports ``hvt_abi_layout`` (sizes, offsets, constants); tests/unit/vtime compares
it with these ctypes structures, so a change on one side that the other misses fails CI.
"""

from __future__ import annotations

import ctypes
import enum
import struct
from typing import Any

MAGIC = 0x31545648  #: "HVT1"
VERSION = 1
MAX_THREADS = 16
MAX_KEYS = 8
N_CALLS = 32
NO_DEADLINE = 2**63 - 1
KEYS_UNKNOWN = 0xFFFFFFFF


class Mode(enum.IntEnum):
    OFF = 0
    VIRTUAL = 1
    FREE_RUN = 2


class State(enum.IntEnum):
    FREE = 0
    RUNNING = 1
    BLOCKED = 2


class Wait(enum.IntEnum):
    FD = 0  #: on fds and/or the slot's wake FIFO
    FUTEX = 1  #: on a lock, semaphore, condition variable or join
    CHILD = 2  #: wait/waitpid/wait3/wait4/waitid: a child or tracee ends it
    READ = 3  #: read/readv with nothing to read: its writer ends it


class Call(enum.IntEnum):
    """Index into ``Header.calls``: which interposed calls the flight code made."""

    CLOCK_GETTIME = 0
    GETTIMEOFDAY = 1
    TIME = 2
    TIMESPEC_GET = 3
    NANOSLEEP = 4
    CLOCK_NANOSLEEP = 5
    USLEEP = 6
    SLEEP = 7
    SELECT = 8
    PSELECT = 9
    POLL = 10
    PPOLL = 11
    EPOLL_WAIT = 12
    EPOLL_PWAIT = 13
    EPOLL_PWAIT2 = 14
    CPU_CLOCK = 15  #: CPU-time clocks, passed through by design
    SPIN_YIELD = 16  #: busy-waits on the clock turned into sim-time quanta
    WAIT_CHILD = 17  #: waits for a child that blocked
    READ_BLOCK = 18  #: reads that would block
    CLOCK_OTHER = 20  #: from here on: uncovered, these run on the host clock
    TIMERFD = 21
    TIMER_CREATE = 22
    SETITIMER = 23
    ALARM = 24
    COND_TIMEDWAIT = 25
    SEM_TIMEDWAIT = 26
    MUTEX_TIMEDLOCK = 27
    NO_SLOT = 28


FIRST_UNCOVERED = Call.CLOCK_OTHER


class Header(ctypes.Structure):
    _fields_ = [
        ("magic", ctypes.c_uint32),
        ("version", ctypes.c_uint32),
        ("max_threads", ctypes.c_uint32),
        ("slot_size", ctypes.c_uint32),
        ("time_seq", ctypes.c_uint32),
        ("mode", ctypes.c_uint32),
        ("now_ns", ctypes.c_int64),
        ("mono_base_ns", ctypes.c_int64),
        ("real_base_ns", ctypes.c_int64),
        ("tai_offset_ns", ctypes.c_int64),
        ("free_run_host_ns", ctypes.c_int64),
        ("spin_quantum_ns", ctypes.c_int64),
        ("spin_limit", ctypes.c_uint32),
        ("epoch", ctypes.c_uint32),
        ("bench_pid", ctypes.c_int32),
        ("attached", ctypes.c_uint32),
        ("calls", ctypes.c_uint64 * N_CALLS),
    ]


class Slot(ctypes.Structure):
    _fields_ = [
        ("tid", ctypes.c_int32),
        ("pid", ctypes.c_int32),
        ("state", ctypes.c_uint32),
        ("seq", ctypes.c_uint32),
        ("deadline_ns", ctypes.c_int64),
        ("cpu_ns", ctypes.c_int64),
        ("blocks", ctypes.c_uint64),
        ("seen_epoch", ctypes.c_uint32),
        ("nkeys", ctypes.c_uint32),
        ("key_rdev", ctypes.c_uint32 * MAX_KEYS),
        ("key_events", ctypes.c_uint16 * MAX_KEYS),
        ("spin_yields", ctypes.c_uint32),
        ("clock_reads", ctypes.c_uint32),
        ("wait_kind", ctypes.c_uint32),
        ("wait_pid", ctypes.c_int32),  #: a CHILD wait's target, as wait4 takes it
        ("reserved", ctypes.c_uint64 * 2),
    ]


BLOCK_SIZE = ctypes.sizeof(Header) + MAX_THREADS * ctypes.sizeof(Slot)

def _struct_of(structure: type[ctypes.Structure]) -> tuple[struct.Struct, dict[str, int]]:
    """``structure`` as a native ``struct`` record (same sizes and alignment as ctypes), and
    the index of each field's first value in an unpacked record."""
    fmt, index, i = "@", {}, 0
    for field in structure._fields_:
        name, ctype = field[0], field[1]  # (name, type) or (name, type, bit width)
        n = getattr(ctype, "_length_", 1)
        element: Any = getattr(ctype, "_type_") if hasattr(ctype, "_length_") else ctype
        fmt += f"{n}{element._type_}"
        index[name] = i
        i += n
    return struct.Struct(fmt), index


#: ``Slot`` as one ``struct`` record, derived from its ctypes fields, for reading every slot
#: in one C call (the bench's idle check reads them several times a tick; ctypes field
#: access costs about 20x more)
SLOT_STRUCT, SLOT_INDEX = _struct_of(Slot)
SLOT_TID, SLOT_PID, SLOT_STATE, SLOT_SEQ = (SLOT_INDEX[f] for f in ("tid", "pid", "state", "seq"))
SLOT_DEADLINE, SLOT_CPU, SLOT_BLOCKS = (SLOT_INDEX[f] for f in ("deadline_ns", "cpu_ns", "blocks"))
SLOT_SEEN_EPOCH, SLOT_NKEYS = SLOT_INDEX["seen_epoch"], SLOT_INDEX["nkeys"]
SLOT_KEY_RDEV, SLOT_KEY_EVENTS = SLOT_INDEX["key_rdev"], SLOT_INDEX["key_events"]
SLOT_SPIN_YIELDS, SLOT_CLOCK_READS = SLOT_INDEX["spin_yields"], SLOT_INDEX["clock_reads"]
SLOT_WAIT_KIND, SLOT_WAIT_PID = SLOT_INDEX["wait_kind"], SLOT_INDEX["wait_pid"]

def rdev_key(st_rdev: int) -> int:
    """A character device number as the shim publishes it: ``(major << 20) | minor``."""
    import os

    return (os.major(st_rdev) << 20) | os.minor(st_rdev)


def expected_layout() -> tuple[int, ...]:
    """The values the shim's ``hvt_abi_layout`` must hold, in its order."""
    return (
        MAGIC, VERSION, MAX_THREADS, MAX_KEYS, N_CALLS,
        ctypes.sizeof(Header), ctypes.sizeof(Slot),
        Header.time_seq.offset, Header.now_ns.offset, Header.free_run_host_ns.offset, Header.epoch.offset,
        Header.calls.offset,
        Slot.seq.offset, Slot.deadline_ns.offset, Slot.cpu_ns.offset, Slot.nkeys.offset,
        Slot.key_rdev.offset, Slot.key_events.offset, Slot.clock_reads.offset, Slot.wait_kind.offset,
        Slot.wait_pid.offset,
    )  # fmt: skip
