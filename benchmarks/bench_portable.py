"""What portable verdicts cost, and why each part of the pin is there (kartci.portable).

    .venv/bin/python benchmarks/bench_portable.py [--rounds 3] [--suite] [--json-dir DIR]
    .venv/bin/python benchmarks/bench_portable.py --bits

Timing: every figure through `kartci run` as a user runs it, once per environment per round,
the environments interleaved round by round so that all see the same machine load; medians:
- `native`: KARTCI_SIMD=native, the CPU's own kernels everywhere (the numbers before the pin);
- `numpy only`, `openblas only`, `libm only`: native plus one part of the pin;
- `pinned`: kartci's default (all three).
Figures: the real-time factor (run.json) of scenarios that stress each part, the MPCC's solve
time, `kartci --help` (the start-up, with the pinned command's one re-execution), and with
--suite the default suite at -j 2.

--bits prints, for this machine, which operations change their last bits with each choice
(sha256 of the results of 200,000 random inputs): the evidence for what the pin covers.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from kartci import portable
from kartci.bench import Better, Record

ROOT = Path(__file__).resolve().parents[1]
KARTCI = str(Path(sys.executable).with_name("kartci"))
SCENARIOS = (("mpcc_lap", "15"), ("localization_lap", "15"), ("line_straight", "20"))


def _clean() -> dict[str, str]:
    drop = (*portable.pin_vars(), "NPY_DISABLE_CPU_FEATURES", "KARTCI_PIN_REEXEC",
            portable.OPT_OUT)
    return {k: v for k, v in os.environ.items() if k not in drop}


def environments() -> dict[str, dict[str, str]]:
    """The environments compared: native, each part of the pin alone, and the whole pin."""
    pin = portable.pin_vars()
    native = {**_clean(), portable.OPT_OUT: "native"}
    part = {"numpy only": ("NPY_ENABLE_CPU_FEATURES",),
            "openblas only": ("OPENBLAS_CORETYPE", "OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"),
            "libm only": ("GLIBC_TUNABLES",)}
    out = {"native": native}
    for name, keys in part.items():
        out[name] = {**native, **{k: pin[k] for k in keys if k in pin}}
    out["pinned"] = _clean()
    return out


def _run(env: dict[str, str], args: list[str], out: Path) -> float:
    t0 = time.perf_counter()
    done = subprocess.run([KARTCI, "run", *args, "--out", str(out)], cwd=ROOT, env=env,
                          capture_output=True, text=True, check=False)
    if done.returncode not in (0, 1):
        sys.exit(f"kartci run {' '.join(args)}: exit {done.returncode}: "
                 f"{done.stderr.strip()[-300:]}")
    return time.perf_counter() - t0


def one_round(env: dict[str, str], samples: dict[str, list[float]], suite: bool) -> None:
    """Every figure once in `env`."""
    with tempfile.TemporaryDirectory() as tmp:
        for name, duration in SCENARIOS:
            out = Path(tmp) / name
            _run(env, [name, "--set", f"duration_s={duration}"], out)
            run = json.loads((out / name / "run.json").read_text())
            samples.setdefault(f"{name} RTF", []).append(float(run["real_time_factor"]))
            if name == "mpcc_lap":
                timing = json.loads((out / name / "metrics.json").read_text())["timing"]
                samples.setdefault("mpcc solve median", []).append(
                    float(timing["solve_ms_median"]["value"]))
        t0 = time.perf_counter()
        subprocess.run([KARTCI, "--help"], env=env, capture_output=True, check=True)
        samples.setdefault("kartci --help", []).append(time.perf_counter() - t0)
        if suite:
            samples.setdefault("default suite -j 2", []).append(
                _run(env, ["-j", "2"], Path(tmp) / "suite"))


BITS = """
import hashlib, json, math, numpy as np
rng = np.random.default_rng(0)
x = rng.uniform(-10, 10, 200000)
out = {}
for f in ("sin", "cos", "exp", "log", "tan", "arctan", "arctan2", "power", "sqrt"):
    g = getattr(np, f)
    y = g(x, x[::-1]) if f in ("arctan2", "power") else g(abs(x) if f in ("log", "sqrt") else x)
    out["np." + f] = y
a = rng.standard_normal((400, 400))
out["matmul 50"] = a[:50, :50] @ a[:50, :50]
out["solve 400"] = np.linalg.solve(a, a)
out["math.sin"] = np.array([math.sin(v) for v in x[:20000]])
print(json.dumps({k: hashlib.sha256(np.ascontiguousarray(v).tobytes()).hexdigest()[:8]
                  for k, v in out.items()}))
"""


def bits() -> None:
    """Which results change with each choice a library makes by CPU, on this machine."""
    native = {**_clean(), portable.OPT_OUT: "native"}
    pin = portable.pin_vars()
    cases = {"native": native,
             "numpy X86_V4 off": {**native, "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL "
                                  "AVX512_SPR"},
             "numpy baseline": {**native, "NPY_ENABLE_CPU_FEATURES": "X86_V2"},
             "OpenBLAS Haswell": {**native, "OPENBLAS_CORETYPE": "Haswell"},
             "OpenBLAS Nehalem": {**native, "OPENBLAS_CORETYPE": "Nehalem"},
             "OpenBLAS 1 thread": {**native, "OPENBLAS_NUM_THREADS": "1"},
             "libm SSE2": {**native, "GLIBC_TUNABLES": pin.get("GLIBC_TUNABLES", "")},
             "pinned": portable.pinned_env(_clean())}
    rows = {}
    for name, env in cases.items():
        done = subprocess.run([sys.executable, "-c", BITS], env=env, capture_output=True,
                              text=True, check=False)
        if done.returncode != 0:
            print(f"{name}: failed: {done.stderr.strip()[-200:]}")
            continue
        rows[name] = json.loads(done.stdout)
    ops = list(rows["native"])
    print("| operation | " + " | ".join(rows) + " |")
    print("|---" * (len(rows) + 1) + "|")
    for op in ops:
        ref = rows["native"][op]
        print(f"| {op} | " + " | ".join("same" if r[op] == ref else "differs"
                                        for r in rows.values()) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--suite", action="store_true", help="also time the default suite")
    parser.add_argument("--bits", action="store_true", help="print which results differ")
    parser.add_argument("--json-dir", type=Path, help="one benchmark JSON per environment")
    args = parser.parse_args()
    if args.bits:
        bits()
        return
    envs = environments()
    samples: dict[str, dict[str, list[float]]] = {name: {} for name in envs}
    for r in range(args.rounds):
        for name, env in envs.items():
            print(f"round {r + 1}/{args.rounds}: {name}", file=sys.stderr)
            one_round(env, samples[name], args.suite and r == 0)
    figures = list(samples["native"])
    print("| figure | " + " | ".join(envs) + " | pinned / native |")
    print("|---" * (len(envs) + 2) + "|")
    for fig in figures:
        med = {name: statistics.median(s[fig]) for name, s in samples.items()}
        cells = [f"{med[n]:.3g}" for n in envs]
        print(f"| {fig} | " + " | ".join(cells) + f" | {med['pinned'] / med['native']:.3f} |")
    if args.json_dir:
        for name in envs:
            record = Record(f"bench_portable {name}")
            for fig in figures:
                better = Better.HIGHER if fig.endswith("RTF") else Better.LOWER
                unit = "x" if fig.endswith("RTF") else ("ms" if "solve" in fig else "s")
                record.add(fig, unit, samples[name][fig], better)
            record.save(args.json_dir / f"portable-{name.replace(' ', '-')}.json")


if __name__ == "__main__":
    main()
