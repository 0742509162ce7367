"""Everything above one run: ``sweep`` (isolated, resumable sweeps), ``compare`` (suites and
their rows), ``hop_map`` (the map over a grid), ``report`` (report.md), ``bench`` (benchmark
scripts), and the command line (``cli``)."""
