"""Wall-clock of `kartci faults` on the default suite with the standard catalogue at -j 2
(issue 42: at most 15 minutes on 2 cores), the whole command as a user runs it; prints the
median over the rounds and the detection matrix's score, asserts nothing. Before each command
it waits (up to a minute) for the CPUs to be idle, as bench_parallel.py does, and says when it
waited in vain.

    .venv/bin/python benchmarks/bench_faults.py [--rounds 1] [--jobs 2] [--keep DIR] [--json F]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from kartci.bench import Record

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_parallel import wait_for_quiet  # the sibling script's idle check


def run(jobs: int, out: Path) -> float:
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "kartci.cli", "faults", "--catalogue", "standard",
                        "-j", str(jobs), "--out", str(out)], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"kartci faults failed ({p.returncode}):\n{p.stderr[-3000:]}")
    return wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--keep", type=Path, help="write the last round's OUT here")
    parser.add_argument("--json", type=Path, help="also write the figures to this file "
                        "(compare two with `kartci bench compare`)")
    opts = parser.parse_args()
    walls: list[float] = []
    noisy = 0
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(opts.rounds):
            out = opts.keep if opts.keep and r == opts.rounds - 1 else Path(tmp) / f"r{r}"
            noisy += not wait_for_quiet()
            walls.append(run(opts.jobs, out))
        summary = json.loads((out / "summary.json").read_text())
    runs = sum(1 for c in summary["cells"] if c["run"]) + sum(
        1 for s in summary["scenarios"] if s["nominal"] is not None)
    score = summary["score"]
    print(f"kartci faults, default suite, standard catalogue, -j {opts.jobs}: {runs} runs, "
          f"{opts.rounds} round(s), median wall-clock {statistics.median(walls):.0f} s "
          f"({', '.join(f'{w:.0f}' for w in walls)})")
    if noisy:
        print(f"  (the machine was busy before {noisy} of the commands: figures are pessimistic)")
    print(f"  suite score: {score['caught']}/{score['judged']} caught")
    record = Record("bench_faults")
    record.add(f"kartci faults default suite standard -j {opts.jobs}", "s", walls)
    if opts.json:
        record.save(opts.json)


if __name__ == "__main__":
    main()
