"""The closed-loop bench that users' tests drive: :class:`~hil.testing.bench.Bench` (one run,
waited on in sim time), the :class:`~hil.testing.factory.HilBench` factory behind the
``hil_bench`` fixture (``hil/pytest_plugin.py``) and the scenario it builds. See
docs/pytest-plugin.md.

Its modules, by job: ``records`` (errors and value records), ``state`` (what a bench's parts
share), ``observe`` (live values and results), ``simtime`` (the tick gate, tick hooks and the
waits), ``act`` (faults from the test), ``bench`` (start, wiring, stop), ``scenario`` (a test's
scenario) and ``factory`` (the benches of one test).
"""
