"""Throughput of `kartci score` and `kartci simreal` (log seconds per wall second) on a 60 s
synthetic kart log (the simulated kart under the exciting command sequence, odometry noised),
median and p95 of repeats. Prints figures; asserts nothing.

    .venv/bin/python benchmarks/bench_realdata.py [--repeats 3] [--window-s 2] [--json OUT.json]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from kartci.bench import Better, Record
from kartci.project import current as active_project
from kartci.realdata.score import score_log, simreal_log
from kartci.realdata.synthetic import synthetic_log
from kartci.verdict.result import ScenarioResult

PROFILE = ("name: bench_kart\npose: {topic: /kart0/odom}\n"
           "commands: {topic: /kart0/ackermann_cmd}\nrobot: {kind: gokart}\n")
LOG_S = 60.0

def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--window-s", type=float, default=2.0)
    parser.add_argument("--json", type=Path, help="also write the figures to this file "
                        "(compare two with `kartci bench compare`)")
    args = parser.parse_args()
    record = Record("bench_realdata")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        log = synthetic_log("kart_simreal", [], LOG_S, folder / "kart60.mcap", active_project())
        profile = folder / "bench_kart.yaml"
        profile.write_text(PROFILE, encoding="utf-8")
        runs: dict[str, Callable[[Path], ScenarioResult]] = {
            "score": lambda out: score_log(log, profile, out, folder, active_project()),
            "simreal": lambda out: simreal_log(log, profile, None, [], args.window_s, out,
                                               folder, active_project())}
        print(f"{'command':10s} {'median':>12s} {'p95 (slowest)':>14s}  log s per wall s")
        for name, run in runs.items():
            samples = []
            for i in range(args.repeats):
                t0 = time.perf_counter()
                result = run(folder / f"{name}{i}")
                assert result.error is None, result.error
                samples.append(LOG_S / (time.perf_counter() - t0))
            record.add(f"{name} throughput", "log s / wall s", samples, Better.HIGHER)
            # p95 of a throughput is its slow end: the 5th percentile of the rates
            slow = sorted(samples)[max(0, round(0.05 * (len(samples) - 1)))]
            print(f"{name:10s} {statistics.median(samples):12.1f} {slow:14.1f}  "
                  f"{', '.join(f'{s:.1f}' for s in samples)}")
    if args.json:
        record.save(args.json)

if __name__ == "__main__":
    main()
