"""A flight code that crashes mid-flight: the real one, until its 400th ESC command.

Used by the crash test as the rig's flight command: ``{python} crashing_flight.py {config}``.
It runs the unmodified flight code in this process and ends the process with status 7 (as a
segfault or an unhandled error in a compiled extension would: no cleanup) once the Maestro
port has been written 400 times.
"""

import os
import sys

import serial

CRASH_AFTER_ESC_WRITES = 400
_writes = {"n": 0}
_orig_write = serial.Serial.write


def _counting_write(self: serial.Serial, data: bytes) -> int | None:
    if str(self.port).endswith("/esc"):
        _writes["n"] += 1
        if _writes["n"] >= CRASH_AFTER_ESC_WRITES:
            sys.stderr.write("crashing_flight: simulated crash\n")
            sys.stderr.flush()
            os._exit(7)
    return _orig_write(self, data)


serial.Serial.write = _counting_write  # type: ignore[method-assign]

if __name__ == "__main__":
    from flightcode.__main__ import main

    sys.argv = ["flightcode", "--config", sys.argv[1]]
    sys.exit(main())
