"""A rig port whose far end is a board UART (hil/flight/board_port.py): device bytes go to the
pins and are tapped as the port's tx wire; the UART's bytes come back as rx at their sim time;
the line rate the devices see follows the programmed divisor within a UART's tolerance."""

from __future__ import annotations

import pytest

from hil.flight.board_port import BAUD_TOLERANCE, BoardPort
from hil.transport.base import LineSettings, WireRecord


def make() -> tuple[BoardPort, list[bytes], list[WireRecord], list[tuple[bytes, int]], list[LineSettings]]:
    pins: list[bytes] = []
    port = BoardPort("imu", 0, pins.append)
    taps: list[WireRecord] = []
    data: list[tuple[bytes, int]] = []
    lines: list[LineSettings] = []
    port.taps.append(taps.append)
    port.on_data = lambda d, t: data.append((d, t))
    port.on_line = lines.append
    port.sim_time = lambda: 1234
    return port, pins, taps, data, lines


def test_device_bytes_go_to_the_pins_and_are_tapped_as_tx() -> None:
    port, pins, taps, _, _ = make()
    assert port.write(b"\xfa\xff\x30\x00\xd1") == 5
    assert port.write(b"") == 0
    assert pins == [b"\xfa\xff\x30\x00\xd1"]
    assert [(r.direction.value, r.t_ns, r.data) for r in taps] == [("tx", 1234, b"\xfa\xff\x30\x00\xd1")]
    assert port.stats.bytes_tx == 5 and port.client_consumed() is None


def test_uart_bytes_reach_the_device_at_their_time_and_are_tapped_as_rx() -> None:
    port, _, taps, data, _ = make()
    port.from_pins(b"\xfa\xff\x30\x00\xd1", 987_654)
    assert data == [(b"\xfa\xff\x30\x00\xd1", 987_654)]
    assert [(r.direction.value, r.t_ns) for r in taps] == [("rx", 987_654)]
    assert port.stats.bytes_rx == 5


@pytest.mark.parametrize(("programmed", "seen"), [
    (921_600 * 1.0006, 921_600),  # the fractional divider's 0.06 %: the device's own rate
    (921_600 * (1 + BAUD_TOLERANCE), 921_600),
    (115_200 * 1.05, round(115_200 * 1.05)),  # too far: the programmed rate, a mismatch for the device
    (57_600.0, 57_600),
])
def test_the_device_sees_its_own_rate_within_the_tolerance(programmed: float, seen: int) -> None:
    port, _, _, _, lines = make()
    device = 921_600 if programmed > 500_000 else 115_200
    port.programmed(programmed, device)
    port.programmed(programmed, device)  # no change, no notification
    assert [(s.baud, s.opened) for s in lines] == [(seen, True)]
    port.programmed(device * 2, device)
    assert lines[-1].baud == device * 2 and not lines[-1].opened
