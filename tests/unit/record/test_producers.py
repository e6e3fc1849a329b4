"""Contract: what the bench's producers actually log conforms to the topic table's schemas.

The payloads are built from the real event records (emulators, criteria) the way
hil/flight/runlog.py builds them, so a field renamed on either side fails here, not in a viewer.
"""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
from mcap.reader import make_reader

from emulators.mcp3204.device import Mcp3204Conversion
from emulators.xsens.events import SampleSent
from hil.analysis.criteria import CriterionResult
from hil.record import Recorder
from hil.record.reader import iter_messages
from hil.record.validate import validate
from hil.flight.messages import jsonable as _jsonable
from tests.unit.record.support import RUN_START_NS, strict_json


def test_runlog_payloads_conform(tmp_path: Path) -> None:
    sample = SampleSent(t_ns=2_500_000, packet_counter=1, sample_time_fine=25, euler_deg=(0.1, -0.2, 45.0),
                        rate_radps=(0.0, 0.01, 0.0), acc_mps2=(0.0, 0.0, -9.81), nbytes=61)
    conv = Mcp3204Conversion(t_ns=2_500_000, channel=1, single_ended=True, code=1234, volts=1.507, vref_V=5.0)
    crit = CriterionResult(name="hover", signal="truth.h_m", metric="max_abs", value=0.1, bound="<= 0.2", passed=True)
    rec = Recorder(tmp_path / "r.mcap", run_start_unix_ns=RUN_START_NS, metadata={})
    with rec:
        rec.log("/hil/imu/sample", sample.t_ns, _jsonable(sample), 1)
        rec.log("/hil/adc/conversion", conv.t_ns, _jsonable(conv), 1)
        # a boot-time event: logged at t >= 0, its own (negative) sim time kept in the payload
        rec.log("/hil/events", 0, {"t_ns": -5_000_000, "kind": "device.imu", "name": "ConfigChanged",
                                   "detail": {"baud": 115200}}, 1)
        rec.log("/hil/verdict", 0, {"end_reason": "completed", "passed": True, "message": "", "flight_returncode": 0,
                                    "criteria": [_jsonable(crit)], "timing": {"p99_us": 200.0}}, 1)
        rec.log("/hil/device/counters", 0, {"counters": {"imu": {"frames": 3}, "port.imu": {"bytes_tx": 9}}}, 1)
        rec.log("/hil/timing/tick", 0, {"k": 0, "imu_emit_host_ns": 5, "esc_arrival_host_ns": -1,
                                        "latency_us": -1.0, "miss": True}, 1)
    v = validate(rec.path)  # JSON against its schema; protobuf decoded and checked against the table's
    assert v.ok and not v.schema_errors, v.problems
    assert sum(v.counts.values()) == 6
    (_, log_time, event), = iter_messages(rec.path, ["/hil/events"])
    assert event["t_ns"] == -5_000_000 and log_time == RUN_START_NS
