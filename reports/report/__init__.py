"""The report: report.md from stored results, its sections, figures and findings."""
