"""tables() on run logs: CPU time of decoding a log into its tables (kartci.logs.tables, what
scoring, judging and figures read), this checkout against another one (`--old`, e.g. a
worktree of main), side by side: each round runs one fresh process per checkout, interleaved,
in kartci's pinned environment; each process reads every log once to warm its caches (the
type store, rosbags' generated decoders: a suite's worker pays them once), then once timed.
Medians of rounds; prints a Markdown table; asserts nothing. The two checkouts' tables are
compared too (a hash of every table's bytes), and must agree.

    .venv/bin/python benchmarks/bench_tables.py --old ../main [--rounds 3] [LOG ...]

Without LOG, the run logs of mpcc_lap, multi_agent, line_circle, localization_lap and
perception_obstacles (default durations) are made first, with this checkout's kartci.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from kartci.portable import pinned_env

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ("mpcc_lap", "multi_agent", "line_circle", "localization_lap",
             "perception_obstacles")
CHILD = """
import hashlib, json, sys, time
from pathlib import Path
import kartci.logs.tables
read = sys.modules["kartci.logs.tables"]._read
out = {}
for p in sys.argv[1:]:
    read(Path(p), None)
for p in sys.argv[1:]:
    t0 = time.process_time()
    got = read(Path(p), None)
    cpu = time.process_time() - t0
    h = hashlib.sha256()
    for topic, df in got.items():
        h.update(repr((topic, list(df.columns), list(df.dtypes), df.index)).encode())
        for _, col in df.items():
            a = col.to_numpy()
            h.update(a.tobytes() if a.dtype.kind in "biuf" else repr(a.tolist()).encode())
    out[p] = [cpu, h.hexdigest()]
print(json.dumps(out))
"""  # the timed read: _read, as tables() would without its one-log memory


def _measure(tree: Path, logs: list[Path]) -> dict[str, list[float | str]]:
    env = {**pinned_env(os.environ), "PYTHONPATH": str(tree)}
    done = subprocess.run([sys.executable, "-c", CHILD, *map(str, logs)], env=env, check=True,
                          capture_output=True, text=True, cwd=tree)  # -c: the cwd comes first
    result: dict[str, list[float | str]] = json.loads(done.stdout)
    return result


def _make_logs(folder: Path) -> list[Path]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    for name in SCENARIOS:
        subprocess.run([sys.executable, "-m", "kartci", "run", name, "--out",
                        str(folder / name)], env=env, check=False, capture_output=True)
    return sorted(folder.glob("*/*/run.mcap"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("logs", nargs="*", type=Path)
    parser.add_argument("--old", type=Path, required=True, help="the other checkout")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        logs = args.logs or _make_logs(Path(tmp))
        trees = {"old": args.old.resolve(), "new": ROOT}
        times: dict[tuple[str, str], list[float]] = {}
        hashes: dict[tuple[str, str], set[str]] = {}
        for _ in range(args.rounds):
            for label, tree in trees.items():
                for log, (cpu, digest) in _measure(tree, logs).items():
                    times.setdefault((label, log), []).append(float(cpu))
                    hashes.setdefault((label, log), set()).add(str(digest))
    print(f"tables() CPU s, median of {args.rounds} (old: {trees['old']})\n")
    print("| log | old | new | new/old | tables equal |\n|---|---|---|---|---|")
    total = {"old": 0.0, "new": 0.0}
    for log in map(str, logs):
        old, new = (statistics.median(times[(k, log)]) for k in ("old", "new"))
        total["old"] += old
        total["new"] += new
        same = hashes[("old", log)] == hashes[("new", log)] and len(hashes[("old", log)]) == 1
        print(f"| {Path(log).parent.name} | {old:.3f} | {new:.3f} | {new / old:.2f} | {same} |")
    print(f"| total | {total['old']:.3f} | {total['new']:.3f} | "
          f"{total['new'] / total['old']:.2f} | |")


if __name__ == "__main__":
    main()
