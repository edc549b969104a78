"""MPCC figures: solve-time distribution at the default horizon (closed loop on mpcc_lap),
first-run compile and cached start, and the default suite's wall time from a warm cache.

    .venv/bin/python benchmarks/bench_mpcc.py [--json OUT.json]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from kartci.bench import Record
from kartci.logs import tables
from kartci.mpcc.cache import get_solver
from kartci.sim import simulate
from kartci.spec import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def setup_times(record: Record) -> None:
    spec = load_scenario("mpcc_lap").agents["kart0"].controller
    with tempfile.TemporaryDirectory() as cache:
        os.environ["KARTCI_CACHE_DIR"] = cache
        first = get_solver(spec)  # type: ignore[arg-type]
        cached = [get_solver(spec).setup_s for _ in range(5)]  # type: ignore[arg-type]
        del os.environ["KARTCI_CACHE_DIR"]
    n = spec.horizon_steps  # type: ignore[attr-defined]
    step = spec.step_s  # type: ignore[attr-defined]
    print(f"horizon: {n} steps x {step} s = {n * step:.2f} s")
    record.add("solver first build (generate C + compile)", "s", [first.setup_s])
    record.add("solver cached start", "ms", [c * 1e3 for c in cached])
    print(f"first run (generate C + compile): {first.setup_s:.1f} s (aim < 60 s)")
    print(f"cached start (load the binary): median {np.median(cached) * 1e3:.0f} ms "
          "(aim < 2 s)")


def solve_times(record: Record) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "run.mcap"
        simulate(load_scenario("mpcc_lap"), log)
        ms = tables(log)["/kart0/mpcc/stats"]["solve_ms"].to_numpy()
    record.add("mpcc_lap closed-loop solve time", "ms", ms.tolist(),
               note="p95 is the figure's p95 over all solves")
    print(f"solve time over {len(ms)} closed-loop solves (mpcc_lap): median "
          f"{np.median(ms):.1f} ms (aim <= 5), p95 {np.percentile(ms, 95):.1f} ms (aim <= 10), "
          f"max {ms.max():.1f} ms")


def suite_time(record: Record) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        kartci = str(Path(sys.executable).with_name("kartci"))
        subprocess.run([kartci, "run", "--out", tmp], cwd=ROOT, check=False,
                       capture_output=True)
        wall = time.perf_counter() - t0
        record.add("default suite -j 1, warm solver cache", "s", [wall])
        print(f"default suite, warm solver cache: {wall:.0f} s wall "
              "(aim < 180 s)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", type=Path, help="also write the figures to this file "
                        "(compare two with `kartci bench compare`)")
    args = parser.parse_args()
    record = Record("bench_mpcc")
    setup_times(record)
    solve_times(record)
    suite_time(record)
    if args.json:
        record.save(args.json)


if __name__ == "__main__":
    main()
