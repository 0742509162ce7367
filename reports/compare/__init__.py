"""The comparison: suite files (and the shipped suites), and one row per run of a suite."""
