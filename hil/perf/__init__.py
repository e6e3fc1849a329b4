"""``hil perf``: benchmarks of the bench on this machine, apart from the product.

``measure`` builds the report: the recorded lockstep hover interleaved with the bare lockstep
``skeleton``, the bare pacer, the host's interruptions (``hostnoise``), the plant's cost per
tick (``plant_tick``) and the recorder's throughput (``recording``). Nothing that flies,
records or analyses imports this package (tests/unit/test_import_rules.py).
"""
