"""The machine under the bench: real-time scheduling, the CPU latency request, steal time and
interruptions, the CPU a run's processes use, ``/proc`` parsing, and ``hil perf``, which
measures what this host allows against the bare lockstep skeleton.
"""
