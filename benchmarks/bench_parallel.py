"""Wall-clock of `kartci run` on the default suite: -j 1 against -j 2 (process pool), and the
Ray executor's overhead against the pool at the same -j. Each round runs every variant once
(the order rotating), the whole command as a user runs it; prints medians, asserts nothing.
Before each command it waits (up to a minute) for the CPUs to be idle, since a busy
neighbour on a 2-core machine halves what -j 2 can show; it says when it waited in vain.

    .venv/bin/python benchmarks/bench_parallel.py [--rounds 3] [--jobs 2] [--no-ray] [--json F]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from kartci.bench import Better, Record


def busy_fraction(window_s: float = 0.5) -> float:
    """Share of CPU time not idle over `window_s` (Linux /proc/stat; 0 elsewhere)."""
    def sample() -> tuple[int, int]:
        try:
            fields = [int(x) for x in Path("/proc/stat").read_text().split()[1:9]]
        except (OSError, ValueError):
            return 0, 0
        return sum(fields), fields[3] + fields[4]

    total0, idle0 = sample()
    time.sleep(window_s)
    total1, idle1 = sample()
    return 1 - (idle1 - idle0) / (total1 - total0) if total1 > total0 else 0.0


def wait_for_quiet(limit_s: float = 60.0) -> bool:
    deadline = time.monotonic() + limit_s
    while busy_fraction() > 0.15:
        if time.monotonic() > deadline:
            return False
    return True


def run(args: list[str], out: Path, baselines: Path) -> float:
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "kartci.cli", "run", *args, "--out", str(out),
                        "--baselines", str(baselines)], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode not in (0, 1):
        raise SystemExit(f"kartci run {' '.join(args)} failed ({p.returncode}):\n{p.stderr}")
    return wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--no-ray", action="store_true", help="skip the Ray executor")
    parser.add_argument("--json", type=Path, help="also write the figures to this file "
                        "(compare two with `kartci bench compare`)")
    opts = parser.parse_args()
    j = str(opts.jobs)
    variants = {"-j 1": ["-j", "1"], f"-j {j}": ["-j", j]}
    if not opts.no_ray and importlib.util.find_spec("ray") is not None:
        variants[f"ray -j {j}"] = ["--executor", "ray", "-j", j]
    walls: dict[str, list[float]] = {v: [] for v in variants}
    noisy = 0
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        (root / "baselines").mkdir()
        for r in range(opts.rounds):
            names = list(variants)
            for name in names[r % len(names):] + names[:r % len(names)]:
                noisy += not wait_for_quiet()
                walls[name].append(run(variants[name], root / name.replace(" ", ""),
                                       root / "baselines"))
        per = {p.parent.name: json.loads(p.read_text())["wall_s"]
               for p in (root / "-j1").glob("*/run.json")}
    med = {v: statistics.median(w) for v, w in walls.items()}
    print(f"default suite, {opts.rounds} rounds, whole `kartci run` command, median wall-clock:")
    if noisy:
        print(f"  (the machine was busy before {noisy} of the commands: figures are pessimistic)")
    for v, w in walls.items():
        print(f"  {v:10s} {med[v]:7.2f} s   ({', '.join(f'{x:.2f}' for x in w)})")
    total = sum(per.values())
    print(f"per-scenario run wall (-j 1): {', '.join(f'{k} {v:.1f} s' for k, v in per.items())}")
    print(f"  ideal -j {j} bound: {total / max(total / opts.jobs, max(per.values())):.2f}x "
          "(sum of runs over the longest run or an even split)")
    print(f"speed-up -j {j} over -j 1: {med['-j 1'] / med[f'-j {j}']:.2f}x")
    record = Record("bench_parallel")
    for v, w in walls.items():
        record.add(f"default suite {v}", "s", w)
    record.add(f"default suite -j {j} over -j 1", "x",
               [a / b for a, b in zip(walls["-j 1"], walls[f"-j {j}"], strict=True)],
               Better.HIGHER, "ratio of the two commands in the same round")
    if f"ray -j {j}" in med:
        extra = med[f"ray -j {j}"] - med[f"-j {j}"]
        print(f"Ray overhead vs the process pool: {extra:+.2f} s "
              f"({med[f'ray -j {j}'] / med[f'-j {j}']:.2f}x the pool's wall-clock)")

    if opts.json:
        record.save(opts.json)


if __name__ == "__main__":
    main()
