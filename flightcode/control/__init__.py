"""Flight control laws, one module per job (imported directly, kept import-light here).

* :mod:`flightcode.control.reference` - third-order reference prefilter (angle/altitude
  setpoint -> value, rate, acceleration, jerk).
* :mod:`flightcode.control.memory_attitude` - memory-based (time-delay-estimation) roll/pitch
  controller of Wang/Ma/Sun Eq. 3.24 with the generalised weights.
* :mod:`flightcode.control.yaw_rate` - PI yaw-rate controller.
* :mod:`flightcode.control.lqi_altitude` - LQI altitude controller (gains from python-control).
* :mod:`flightcode.control.mixer` - torque/collective -> four motor throttles with saturation
  priority.

Frames: body FRD, world NED, altitude ``z`` positive up. Torques in N m about the FRD axes.
"""
