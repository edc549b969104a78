"""Real-time factor (sim seconds per wall second) of the line scenarios, geometric vs rendered
line sensor, measured in one process, median of repeats. Prints figures; asserts nothing.

    .venv/bin/python benchmarks/bench_line.py [--repeats 3] [--json OUT.json]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from kartci.bench import Better, Record
from kartci.sim import simulate
from kartci.spec import load_scenario


def rtf(name: str, mode: str, out: Path) -> float:
    spec = load_scenario(name, [f"agents.lt0.sensors.line_sensor.mode={mode}"])
    t0 = time.perf_counter()
    info = simulate(spec, out / f"{name}-{mode}.mcap")
    return info.sim_time_s / (time.perf_counter() - t0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", type=Path, help="also write the figures to this file "
                        "(compare two with `kartci bench compare`)")
    args = parser.parse_args()
    record = Record("bench_line")
    print(f"{'scenario':15s} {'sensor':10s} {'median RTF':>10s}  samples")
    with tempfile.TemporaryDirectory() as tmp:
        for name in ("line_straight", "line_circle"):
            for mode in ("geometric", "rendered"):
                samples = [rtf(name, mode, Path(tmp)) for _ in range(args.repeats)]
                record.add(f"{name} {mode} RTF", "x", samples, Better.HIGHER)
                print(f"{name:15s} {mode:10s} {statistics.median(samples):10.1f}x  "
                      + ", ".join(f"{s:.1f}" for s in samples))

    if args.json:
        record.save(args.json)


if __name__ == "__main__":
    main()
