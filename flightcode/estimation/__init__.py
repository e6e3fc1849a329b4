"""State estimation: :mod:`flightcode.estimation.altitude_kf` (barometer + accelerometer KF)."""
