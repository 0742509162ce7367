"""``python -m hoopbench``: the command line, as the ``hoopbench`` script runs it."""

from __future__ import annotations

from hoopbench.reports.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
