"""The bench: transports, clocks, the plant, the run loop and recording.

``hil`` may import ``emulators`` and everything else of ours except ``flightcode``.
"""

__version__ = "0.1.0"
