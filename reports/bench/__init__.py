"""Benchmark scripts that print figures (``python -m hoopbench.reports.bench.NAME``)."""
