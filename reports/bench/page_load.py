"""Benchmark: how large report.html is and how fast it opens in headless Chromium.

Run with ``python -m hoopbench.reports.bench.page_load [REPORT_DIR_OR_HTML] [--repeat N]``
(default: the newest ``reports/output/*/report.html``). Needs the test extra's Selenium and
Debian's chromium and chromium-driver. Prints the file's size, and, best of N fresh loads
from file://, the time to the load event (the page parsed, plotly.js run, the figures in
view drawn), and the time until every figure of the page is drawn (most are drawn only as
they scroll into view). The target of issue 20: under 20 MB and a load under 3 s.
This is a measurement, not a test: nothing here asserts a time.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from hoopbench.reports.report.page import PAGE_NAME

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"


def _driver() -> Any:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for argument in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1400,1000"):
        options.add_argument(argument)
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)


def measure(page: Path) -> dict[str, float]:
    """One fresh browser's load of ``page``: seconds to the load event and to every figure."""
    driver = _driver()
    try:
        start = time.perf_counter()
        driver.get(page.resolve().as_uri())  # returns at the load event
        loaded = time.perf_counter() - start
        navigation = driver.execute_script(
            "const t = performance.getEntriesByType('navigation')[0];"
            "return t.loadEventEnd - t.startTime;"
        )
        driver.execute_async_script("const done = arguments[0]; hoopDrawAll().then(() => done());")
        everything = time.perf_counter() - start
        errors = [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
    finally:
        driver.quit()
    return {
        "load_s": loaded,
        "navigation_s": navigation / 1000.0,
        "all_drawn_s": everything,
        "errors": float(len(errors)),
    }


def _newest() -> Path | None:
    pages = sorted(Path("reports/output").glob(f"*/{PAGE_NAME}"))
    return pages[-1] if pages else None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("page", nargs="?", help="report.html or its folder (default: newest)")
    parser.add_argument("--repeat", type=int, default=3, help="fresh loads, best kept")
    args = parser.parse_args(argv)
    page = Path(args.page) if args.page else _newest()
    if page is not None and page.is_dir():
        page = page / PAGE_NAME
    if page is None or not page.is_file():
        print(f"no {PAGE_NAME}: {args.page or 'reports/output/*/'} (run make report)")
        return 2
    runs = [measure(page) for _ in range(max(1, args.repeat))]
    best = {key: min(run[key] for run in runs) for key in runs[0]}
    print(f"{page}: {page.stat().st_size / 1e6:.1f} MB")
    print(
        f"load event {best['load_s']:.2f} s (navigation timing {best['navigation_s']:.2f} s), "
        f"every figure drawn {best['all_drawn_s']:.2f} s, console errors {best['errors']:.0f}; "
        f"best of {len(runs)}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
