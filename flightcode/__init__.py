"""The quad-rotor's flight code, exactly as it runs on the vehicle (and, unchanged, on the bench).

Run it with ``python -m flightcode --config FILE`` (docs/flightcode.md). It sees only serial
ports and imports only the standard library, numpy, filterpy, control and pyserial.

* :mod:`flightcode.drivers` - device drivers (XSENS, Bus Pirate + MCP3204, RC, Maestro, XBee);
* :mod:`flightcode.estimation` / :mod:`flightcode.control` - altitude KF, memory attitude,
  yaw rate, LQI altitude, mixer;
* :mod:`flightcode.modes` - arming and failsafe state machine;
* :mod:`flightcode.loop` - the 400 Hz loop; :mod:`flightcode.telemetry` - downlink payload;
* :mod:`flightcode.config` - the TOML config; :mod:`flightcode.log` - logfmt to stderr.
"""
