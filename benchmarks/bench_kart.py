"""Go-kart speed: real-time factor of kart_manual with and without the VLP-16 at 10 Hz, of
localization_lap (lidar, GICP + EKF node and the MPCC), and the cost of one full VLP-16 /
HDL-32E scan, fast 2.5D model vs PyBullet's batched ray test, measured in one process, medians
of repeats. Each RTF is a whole `simulate()` (build, run, log written) after one warm-up run of
the same scenario, so imports and first-use code generation are not counted. Prints figures;
asserts nothing.

`--parts`: where a kart_manual step (no lidar, 10 s) goes, µs of CPU time per physics step by
part (kartci.sim.parts), and the anchor: f1tenth_gym's one car (single-track model, 1080-beam
lidar, 100 Hz; benchmarks/f1tenth_anchor.py) run by its own interpreter, round by round
alternately with kart_manual; skipped with the reason where there is none. The anchor's RTF
is its stepping loop alone, kart_manual's a whole run (build and log included).

    .venv/bin/python benchmarks/bench_kart.py [--repeats 3] [--parts] [--json OUT.json]
        [--anchor-python PATH]   (default $KARTCI_F1TENTH_PYTHON; make_f1tenth_env.sh makes one)
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from kartci import portable
from kartci.bench import Better, Record
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim import lidar, parts, simulate
from kartci.worlds.hall import HallWorld
from kartci.worlds.hall.world import Hall as World
from kartci.worlds.hall.world import blocks

RUNS: tuple[tuple[str, str, list[str]], ...] = (
    ("kart_manual, no lidar", "kart_manual", []),
    ("kart_manual, VLP-16 10 Hz", "kart_manual", ["agents.kart0.sensors.lidar.enabled=true"]),
    ("localization_lap", "localization_lap", []))
ANCHOR = Path(__file__).with_name("f1tenth_anchor.py")
NO_ANCHOR = ("no f1tenth_gym interpreter: pass --anchor-python or set KARTCI_F1TENTH_PYTHON "
             "(benchmarks/make_f1tenth_env.sh CHECKOUT makes one from a checkout of "
             "f1tenth/f1tenth_gym)")


def rtf(name: str, sets: list[str], out: Path) -> float:
    return rtfs(name, sets, out)[0]


def rtfs(name: str, sets: list[str], out: Path) -> tuple[float, float]:
    """Wall-clock and CPU real-time factors of one run (CPU: steadier on a shared machine)."""
    spec = load_scenario(name, sets, project=active_project())
    t0, c0 = time.perf_counter(), time.process_time()
    info = simulate(spec, out / "run.mcap")
    return (info.sim_time_s / (time.perf_counter() - t0),
            info.sim_time_s / (time.process_time() - c0))


def scan_ms(name: str, repeats: int) -> tuple[list[float], list[float], int]:
    spec = load_scenario("kart_replay", project=active_project())
    assert isinstance(spec.world, HallWorld)
    world = World(spec.world, 0.002)
    m = lidar.MODELS[name]
    az = m.azimuths(10.0)
    pos = np.array([8.0, 3.2, 1.281])
    fast, ref = [], []
    try:
        for _ in range(repeats):
            t0 = time.perf_counter()
            lidar.scan_fast(m, az, pos, 0.3, blocks(spec.world), spec.world.wall_height_m, 100.0)
            fast.append((time.perf_counter() - t0) * 1e3)
            t0 = time.perf_counter()
            lidar.scan_reference(world.client, m, az, pos, 0.3, 100.0)
            ref.append((time.perf_counter() - t0) * 1e3)
    finally:
        world.close()
    return fast, ref, len(az) * len(m.elevations_rad)


@dataclass(frozen=True)
class AnchorRun:
    """One round of the f1tenth_gym anchor: real-time factors of its stepping loop."""

    rtf: float
    cpu_rtf: float
    versions: dict[str, str]


def anchor_rtf(python: Path, steps: int = 2000) -> AnchorRun | str:
    """f1tenth_gym's one car stepped by `python` (its side venv: f110_gym's gym and numba
    never enter this process), or why it did not run. `-I`: this tree's PYTHONPATH stays out;
    without the variables `import kartci` set, its libm and numpy run native, as they do here
    (numpy came first) and for f1tenth_gym's users."""
    pin = portable.pin_vars()
    env = {k: v for k, v in os.environ.items() if k not in pin}
    done = subprocess.run([str(python), "-I", str(ANCHOR), "--steps", str(steps)],
                          capture_output=True, text=True, check=False, env=env)
    if done.returncode:
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        return f"{python} {ANCHOR.name} exited {done.returncode}: {last}"
    out = json.loads(done.stdout)
    return AnchorRun(float(out["rtf"]), float(out["cpu_rtf"]), out["versions"])


def step_parts(record: Record, repeats: int, out: Path, python: Path | None) -> None:
    """kart_manual (no lidar, 10 s) by part, µs of CPU time per physics step, and the
    f1tenth_gym anchor run by `python` after it in each round (none: skipped)."""
    spec = load_scenario("kart_manual", ["duration_s=10"], project=active_project())
    parts.measure(load_scenario("kart_manual", ["duration_s=0.5"],
                                project=active_project()), out / "warm-up.mcap")
    runs, kart, cpu, anchor = [], [], [], []
    skipped = None if python else NO_ANCHOR
    for _ in range(repeats):
        runs.append(parts.measure(spec, out / "parts.mcap"))
        wall, on_cpu = rtfs("kart_manual", ["duration_s=10"], out)
        kart.append(wall)
        cpu.append(on_cpu)
        a = anchor_rtf(python) if python and not skipped else skipped
        if isinstance(a, AnchorRun):
            anchor.append(a)
        else:
            skipped = a
    print(f"kart_manual, no lidar, 10 s: {runs[0].steps} steps; CPU µs per 2 ms step, "
          f"median of {repeats}")
    for label, us in parts.median_parts(runs).items():
        record.add(f"kart step: {label}", "us", [r.us_per_step[label] for r in runs])
        print(f"  {label:36s} {us:6.1f}")
    record.add("kart_manual 10 s RTF", "x", kart, Better.HIGHER)
    record.add("kart_manual 10 s CPU RTF", "x", cpu, Better.HIGHER)
    print(f"kart_manual, no lidar, 10 s: median RTF {statistics.median(kart):.1f}x, CPU RTF "
          f"{statistics.median(cpu):.1f}x  (" + ", ".join(f"{c:.1f}" for c in cpu) + ")")
    if skipped:
        print(f"f1tenth_gym anchor: skipped: {skipped}")
    elif anchor:
        report_anchor(record, kart, cpu, anchor)


def report_anchor(record: Record, kart: list[float], cpu: list[float],
                  anchor: list[AnchorRun]) -> None:
    """The anchor's RTFs and kart_manual's over them, round by round (each pair ran back to
    back, so a load that comes and goes hits both)."""
    versions = ", ".join(f"{k} {v}" for k, v in anchor[0].versions.items())
    for label, ours, theirs in (("RTF", kart, [a.rtf for a in anchor]),
                                ("CPU RTF", cpu, [a.cpu_rtf for a in anchor])):
        record.add(f"f1tenth_gym one car {label}", "x", theirs, Better.HIGHER)
        ratio = [k / a for k, a in zip(ours, theirs, strict=True)]
        record.add(f"kart_manual {label} / f1tenth_gym {label}", "x", ratio, Better.HIGHER)
        print(f"kart_manual {label} {statistics.median(ours):.1f}x, f1tenth_gym ({versions}) "
              f"{statistics.median(theirs):.1f}x: {statistics.median(ratio):.2f} of it  ("
              + ", ".join(f"{r:.2f}" for r in ratio) + ")")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--parts", action="store_true",
                        help="only kart_manual's step by part and the f1tenth_gym anchor")
    parser.add_argument("--json", type=Path, help="also write the figures to this file "
                        "(compare two with `kartci bench compare`)")
    parser.add_argument("--anchor-python", type=Path,
                        default=os.environ.get("KARTCI_F1TENTH_PYTHON") or None,
                        help="the Python of the f1tenth_gym side venv for --parts' anchor "
                        "(default: $KARTCI_F1TENTH_PYTHON; benchmarks/make_f1tenth_env.sh)")
    args = parser.parse_args()
    if args.anchor_python and not Path(args.anchor_python).is_file():
        parser.error(f"--anchor-python / KARTCI_F1TENTH_PYTHON: no such file: {args.anchor_python}")
    record = Record("bench_kart")
    if args.parts:
        with tempfile.TemporaryDirectory() as tmp:
            step_parts(record, args.repeats, Path(tmp), args.anchor_python)
        if args.json:
            record.save(args.json)
        return
    for name in ("vlp16", "hdl32e"):
        fast, ref, rays = scan_ms(name, max(5, args.repeats))
        f = record.add(f"{name} scan, fast model", "ms", fast)
        r = record.add(f"{name} scan, PyBullet rays", "ms", ref)
        print(f"{name}: {rays} rays per scan; fast model {f.median:.1f} ms, PyBullet rays "
              f"{r.median:.1f} ms (median)")
    with tempfile.TemporaryDirectory() as tmp:
        for label, name, sets in RUNS:
            rtf(name, [*sets, "duration_s=1"], Path(tmp))  # warm-up
            samples = [rtf(name, sets, Path(tmp)) for _ in range(args.repeats)]
            record.add(f"{label} RTF", "x", samples, Better.HIGHER)
            print(f"{label:28s} median RTF {statistics.median(samples):5.1f}x  ("
                  + ", ".join(f"{s:.1f}" for s in samples) + ")")

    if args.json:
        record.save(args.json)


if __name__ == "__main__":
    main()
