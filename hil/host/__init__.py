"""The machine under the bench: real-time scheduling, the CPU latency request, steal time,
the CPU a run's processes use, ``/proc`` parsing. ``hil perf``'s measurements of what this
host allows are in :mod:`hil.perf`.
"""
