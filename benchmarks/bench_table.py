"""The speed table of the README and issue 14, measured through the command line as a user runs
it, for one or more kartci installs side by side (e.g. a checkout of an older commit and this
one), interleaved round by round so that both see the same machine load. Medians of rounds;
prints a Markdown table; asserts nothing.

    .venv/bin/python benchmarks/bench_table.py [--kartci OTHER/.venv/bin/kartci ...]
        [--rounds 3] [--suite-rounds 1] [--json-dir DIR]

Each `--kartci` is one column (default: this venv's). Figures per round:
- the real-time factor of single scenarios (`run.json`: sim time over simulation wall time),
- the MPCC's closed-loop solve time on mpcc_lap (median and p95 of its solves, from the
  run's `metrics.json` timing block),
- the default suite's wall time at -j 1 and -j 2 with a warm solver cache, and their ratio
  (the whole command: start-up, runs, scoring, reports).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from kartci.bench import Better, Record

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Row:
    """One scenario run whose real-time factor is a row of the table."""

    label: str
    scenario: str
    sets: tuple[str, ...]
    aim: str


ROWS = (
    Row("mpcc_lap RTF", "mpcc_lap", (), ">= 8x"),
    Row("multi_agent RTF", "multi_agent", (), ">= 4x"),
    Row("kart_manual (no lidar) RTF", "kart_manual", (), ">= 25x"),
    Row("kart_manual, VLP-16 10 Hz RTF", "kart_manual",
        ("agents.kart0.sensors.lidar.enabled=true",), ">= 15x"),
    Row("line_straight geometric RTF", "line_straight", (), ">= 60x"),
    Row("line_circle geometric RTF", "line_circle", (), ">= 60x"),
    Row("line_circle rendered RTF", "line_circle",
        ("agents.lt0.sensors.line_sensor.mode=rendered",), ">= 15x"),
)
AIMS = {"mpcc_lap solve median": "<= 3 ms", "mpcc_lap solve p95": "<= 5 ms",
        "default suite -j 2": "<= 20 s", "-j 2 over -j 1": ">= 1.85x"}


def _run(kartci: str, args: list[str], out: Path) -> float:
    t0 = time.perf_counter()
    done = subprocess.run([kartci, "run", *args, "--out", str(out)], cwd=ROOT,
                          capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if done.returncode not in (0, 1):
        sys.exit(f"{kartci} run {' '.join(args)}: exit {done.returncode}: "
                 f"{done.stderr.strip()[-300:]}")
    return wall


def _timing(folder: Path, name: str) -> float:
    timing = json.loads((folder / "metrics.json").read_text())["timing"]
    return float(timing[name]["value"])


def one_round(kartci: str, samples: dict[str, list[float]], suite: bool) -> None:
    """Every row once with this install, into `samples` (figure name -> values)."""
    with tempfile.TemporaryDirectory() as tmp:
        for i, row in enumerate(ROWS):
            out = Path(tmp) / str(i)
            sets = [a for s in row.sets for a in ("--set", s)]
            _run(kartci, [row.scenario, *sets], out)
            run = json.loads((out / row.scenario / "run.json").read_text())
            samples.setdefault(row.label, []).append(float(run["real_time_factor"]))
            if row.scenario == "mpcc_lap":
                for stat in ("median", "p95"):
                    samples.setdefault(f"mpcc_lap solve {stat}", []).append(
                        _timing(out / row.scenario, f"solve_ms_{stat}"))
        if suite:
            j1 = _run(kartci, ["-j", "1"], Path(tmp) / "j1")
            j2 = _run(kartci, ["-j", "2"], Path(tmp) / "j2")
            samples.setdefault("default suite -j 1", []).append(j1)
            samples.setdefault("default suite -j 2", []).append(j2)
            samples.setdefault("-j 2 over -j 1", []).append(j1 / j2)


def _unit(name: str) -> tuple[str, Better]:
    if name.endswith("RTF") or name.startswith("-j"):
        return "x", Better.HIGHER
    return ("ms" if "solve" in name else "s"), Better.LOWER


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kartci", action="append", help="a kartci executable (repeatable); "
                        "default: the one beside this Python")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--suite-rounds", type=int, default=1,
                        help="rounds that also time the default suite at -j 1 and -j 2")
    parser.add_argument("--json-dir", type=Path, help="write one benchmark JSON per install "
                        "here (compare two with `kartci bench compare`)")
    args = parser.parse_args()
    installs = args.kartci or [str(Path(sys.executable).with_name("kartci"))]
    samples: list[dict[str, list[float]]] = [{} for _ in installs]
    for r in range(args.rounds):
        for i, kartci in enumerate(installs):
            print(f"round {r + 1}/{args.rounds}: {kartci}", file=sys.stderr)
            one_round(kartci, samples[i], suite=r < args.suite_rounds)
    names = list(samples[0])
    print("| figure | " + " | ".join(f"install {i + 1}" for i in range(len(installs)))
          + " | aim |")
    print("|---" * (len(installs) + 2) + "|")
    for name in names:
        unit, _ = _unit(name)
        cells = [f"{statistics.median(s[name]):.1f} {unit}" for s in samples]
        aim = next((r.aim for r in ROWS if r.label == name), AIMS.get(name, ""))
        print(f"| {name} | " + " | ".join(cells) + f" | {aim} |")
    for i, kartci in enumerate(installs):
        print(f"install {i + 1}: {kartci}")
        if args.json_dir:
            record = Record("bench_table")
            for name in names:
                unit, better = _unit(name)
                record.add(name, unit, samples[i][name], better)
            record.save(args.json_dir / f"table-{i + 1}.json")


if __name__ == "__main__":
    main()
