"""``ControlBlock.threads`` (one struct read of every slot, views reused while a slot's record
is unchanged) against a field-by-field ctypes reading of the same slots."""

from __future__ import annotations

from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from hil.vtime import abi
from hil.vtime.control import ControlBlock, ThreadView


def reference_threads(cb: ControlBlock) -> list[ThreadView]:
    """The slots read through ctypes, one field at a time (the reference)."""
    out = []
    for i, s in enumerate(cb.slots):
        if not s.tid:
            continue
        keys = None
        if s.nkeys != abi.KEYS_UNKNOWN:
            keys = tuple((s.key_rdev[k], s.key_events[k]) for k in range(min(s.nkeys, abi.MAX_KEYS)))
        out.append(ThreadView(
            i, s.tid, s.pid, s.seq, bool(s.seq & 1) and s.state == abi.State.BLOCKED,
            None if s.deadline_ns == abi.NO_DEADLINE else s.deadline_ns, s.cpu_ns, s.seen_epoch, keys,
            s.spin_yields, s.wait_kind, s.wait_pid,
        ))
    return out


slot_values = st.fixed_dictionaries({
    "tid": st.integers(0, 3),  # 0: a free slot
    "pid": st.integers(1, 2**31 - 1),
    "state": st.sampled_from(list(abi.State)),
    "seq": st.integers(0, 2**32 - 1),
    "deadline_ns": st.one_of(st.just(abi.NO_DEADLINE), st.integers(-(2**63), 2**63 - 1)),
    "cpu_ns": st.integers(0, 2**63 - 1),
    "seen_epoch": st.integers(0, 2**32 - 1),
    "nkeys": st.one_of(st.just(abi.KEYS_UNKNOWN), st.integers(0, abi.MAX_KEYS + 2)),
    "key_rdev": st.lists(st.integers(0, 2**32 - 1), min_size=abi.MAX_KEYS, max_size=abi.MAX_KEYS),
    "key_events": st.lists(st.integers(0, 2**16 - 1), min_size=abi.MAX_KEYS, max_size=abi.MAX_KEYS),
    "spin_yields": st.integers(0, 2**32 - 1),
    "clock_reads": st.integers(0, 2**32 - 1),
    "wait_kind": st.sampled_from(list(abi.Wait)),
    "wait_pid": st.integers(-(2**31), 2**31 - 1),
})


def _write(cb: ControlBlock, index: int, values: dict) -> None:
    s = cb.slots[index]
    for name, value in values.items():
        if isinstance(value, list):
            getattr(s, name)[:] = value
        else:
            setattr(s, name, value)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, abi.MAX_THREADS - 1), slot_values), max_size=12))
def test_threads_match_the_ctypes_reading_after_every_change(tmp_path_factory, changes) -> None:
    cb = ControlBlock(Path(tmp_path_factory.mktemp("vt")))
    try:
        assert cb.threads() == reference_threads(cb) == []
        for index, values in changes:
            before = {v.index: v for v in cb.threads()}
            _write(cb, index, values)
            views = cb.threads()
            assert views == reference_threads(cb)
            for v in views:  # untouched slots give the very same view
                if v.index != index and v.index in before:
                    assert v is before[v.index]
    finally:
        cb.close()


def test_a_field_changed_in_place_is_seen(tmp_path: Path) -> None:
    cb = ControlBlock(tmp_path)
    try:
        _write(cb, 3, {"tid": 7, "pid": 7, "state": abi.State.BLOCKED, "seq": 1, "deadline_ns": abi.NO_DEADLINE,
                       "nkeys": 1, "key_rdev": [5] + [0] * (abi.MAX_KEYS - 1)})
        (first,) = cb.threads()
        assert first.blocked and first.deadline_ns is None and first.keys == ((5, 0),)
        cb.slots[3].seen_epoch = 9  # a field the seq does not cover
        (second,) = cb.threads()
        assert second.seen_epoch == 9 and second is not first
        cb.slots[3].tid = 0
        assert cb.threads() == []
    finally:
        cb.close()
