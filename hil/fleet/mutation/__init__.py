"""Mutation testing of a flight code against a scenario suite (``hil mutate``, docs/mutation.md).

``catalogue.py`` loads and checks an edit catalogue and its equivalents file; ``edits.py``
applies edits to a copy of the source tree; ``operators.py`` draws operator mutants
(cosmic-ray's operators) by seed; ``worker.py`` flies one mutant from its own temporary copy
on a campaign worker; ``runner.py`` runs the baseline and the mutants on the campaign
executors; ``report.py`` scores them and writes the table, JSON and heat map.
"""
