"""Report cost and size for a run folder (default: reports/latest, written by `kartci run`):
the interactive report.html (figures as JSON, uPlot inlined once) against the static
report-static.html (matplotlib SVG), median of repeats. Prints figures; asserts nothing.

    .venv/bin/python benchmarks/bench_report.py [OUT] [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from kartci import project
from kartci.project import current as active_project
from kartci.report.html import report_html
from kartci.runner.run import evaluate, scenario_folders


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("out", nargs="?", type=Path, default=Path("reports/latest"))
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    baselines = project.current().baselines
    results = [evaluate(f, baselines, active_project()) for f in scenario_folders(args.out)]
    print(f"{len(results)} scenarios from {args.out}")
    for static in (False, True):
        times, size = [], 0
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            size = len(report_html(results, static=static).encode("utf-8"))
            times.append(time.perf_counter() - t0)
        name = "report-static.html (SVG)" if static else "report.html (uPlot)"
        print(f"{name:26s} median {statistics.median(times):6.2f} s  max {max(times):6.2f} s  "
              f"{size / 1e6:5.2f} MB")


if __name__ == "__main__":
    main()
