"""One flight on the bench: the flight code's process, the emulated devices and the plant,
the tick loop between them, the scenario played into it, and what the run records.

Entry point: :func:`hil.flight.run.run_flight` (``hil run``). ``hil devices``
(:mod:`hil.flight.devices_live`) serves the same devices to a hand-started client.
"""
