"""The whole-packet fast path against the byte-by-byte state table (its reference)."""

from __future__ import annotations

import dataclasses

from hypothesis import given, settings
from hypothesis import strategies as st

from emulators.maestro import (
    Command,
    Maestro,
    MaestroParams,
    compact,
    get_position,
    mini_ssc,
    pololu,
    set_multiple_targets,
    set_target,
)
from emulators.maestro.protocol import crc7


def _packets(crc: bool) -> st.SearchStrategy[bytes]:
    qus = st.integers(0, 16383)
    return st.one_of(
        st.builds(lambda f, ts: set_multiple_targets(f, ts, crc=crc), st.integers(0, 5),
                  st.lists(qus, min_size=1, max_size=6)),
        st.builds(lambda c, t: set_target(c, t, crc=crc), st.integers(0, 8), qus),
        st.builds(lambda c: get_position(c, crc=crc), st.integers(0, 8)),
        st.sampled_from([compact(Command.GET_ERRORS, crc=crc), compact(Command.GO_HOME, crc=crc),
                         compact(Command.GET_MOVING_STATE, crc=crc), compact(Command.GET_SCRIPT_STATUS, crc=crc)]),
        st.builds(lambda d, c: pololu(d, Command.SET_TARGET, bytes([c, 0x70, 0x2E]), crc=crc),
                  st.integers(0, 127), st.integers(0, 5)),
        st.builds(mini_ssc, st.integers(0, 254), st.integers(0, 254)),
        st.binary(min_size=1, max_size=6),  # garbage, a torn packet, a wrong CRC
    )


def _state(m: Maestro) -> tuple:
    events = [dataclasses.astuple(e) for e in m.take_events()]
    return (events, m.take_output(), dict(m.counters), m.errors,
            [(ch.target_qus, ch.position_qus) for ch in m.channels], m._state, bytes(m._data))


@settings(max_examples=300, deadline=None)
@given(data=st.data(), crc=st.booleans())
def test_fast_path_equals_the_state_table(data: st.DataObject, crc: bool) -> None:
    params = MaestroParams(crc_enabled=crc)
    fast, ref = Maestro(params), Maestro(params, fast_path=False)
    writes = data.draw(st.lists(_packets(crc), min_size=1, max_size=12))
    for k, w in enumerate(writes):  # one write() per packet, as a flight loop does
        t_ns = (k + 1) * 2_500_000
        fast.receive(w, t_ns)
        ref.receive(w, t_ns)
        assert _state(fast) == _state(ref), w.hex()


def test_a_bad_crc_is_caught_on_the_fast_path_too() -> None:
    params = MaestroParams(crc_enabled=True)
    good = set_multiple_targets(0, [6000, 6000, 6000, 6000], crc=True)
    bad = good[:-1] + bytes([(good[-1] + 1) & 0x7F])
    assert crc7(good[:-1]) == good[-1]
    for fast_path in (True, False):
        m = Maestro(params, fast_path=fast_path)
        m.receive(bad, 1)
        assert m.counters["crc_errors"] == 1 and not m.take_output()
