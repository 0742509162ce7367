"""Judging: a run's trajectory turned into events, compared with the exact solution, and
given its verdict.

One run flows one way through this package: ``judge`` (events from the shared detectors,
screened by ``event_checks``) -> the comparison with the exact solution -> ``verdict``. The
suites and the hop map only turn the result into a row.
"""
