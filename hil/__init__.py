"""The bench: transports, clocks, the plant, the run loop and recording.

``hil`` may import ``emulators`` and everything else of ours except ``flightcode``. Its
packages follow its jobs (docs/architecture.md): ``config`` (rig and scenario files),
``flight`` (one flight), ``analysis`` (what a run or a log says), ``fleet`` (many flights,
replay), ``host`` (the machine under the bench), and beside them ``plant``, ``faults``,
``record``, ``transport`` and ``vtime``.
"""

# hil.clock first: its import stamp is the bench's start (start_to_tick0_s)
from hil import clock  # noqa: F401  # isort: skip
from hil import native

__version__ = "0.1.0"

# the compiled build (``hil build``), when it is the build of these sources (hil/native/)
native.install()
