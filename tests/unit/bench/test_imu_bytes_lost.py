"""dev.imu_bytes_lost: the bench's count of bytes the IMU's line lost on their way to the flight
code, what fault-imu-byte-loss judges the flight code's missing samples against. It counts
every wire fault on port imu, device to flight code, and keeps a fault's count after the fault
ends and leaves the port (a counter, so ``increase`` over a window is the bytes lost in it)."""

from __future__ import annotations

from collections import Counter
from types import SimpleNamespace

from emulators.rc.script import StickScript
from hil.analysis.trace import Trace
from hil.config.rig import load_rig
from hil.flight.devices import DeviceSet
from hil.flight.runlog import RunLogger


def _fault(tx_in: int, tx_out: int) -> SimpleNamespace:
    return SimpleNamespace(counters=Counter({"tx_bytes_in": tx_in, "tx_bytes_out": tx_out, "rx_bytes_in": 50}))


def test_counts_every_imu_line_fault_and_keeps_an_ended_ones_count() -> None:
    rig = load_rig(None)
    devices = DeviceSet(rig, seed=1, stick_script=StickScript([]))  # a real one: the compiled build checks
    logger = RunLogger(None, Trace(), devices, {}, rig)
    assert logger._imu_bytes_lost() == 0
    loss, silence = _fault(1000, 997), _fault(0, 0)
    devices.wire_filters["imu"] = [loss, silence, object()]  # type: ignore[list-item]  # no counters: counts nothing
    devices.wire_filters["adc"] = [_fault(500, 400)]  # type: ignore[list-item]  # another port's are not the IMU's
    assert logger._imu_bytes_lost() == 3
    loss.counters.update(tx_bytes_in=200, tx_bytes_out=195)
    silence.counters.update(tx_bytes_in=69)
    assert logger._imu_bytes_lost() == 3 + 5 + 69
    del devices.wire_filters["imu"]  # both ended: the schedule took them off the port
    assert logger._imu_bytes_lost() == 77
    devices.wire_filters["imu"] = [_fault(10, 9)]  # type: ignore[list-item]
    assert logger._imu_bytes_lost() == 78
