"""MPCC figures for both methods in one run: the Ipopt reference and real-time iterations (RTI).

- first build (generate C + compile) and cached start of each method's compiled code;
- closed-loop solve time (median, p95) on mpcc_lap and the real-time factor of mpcc_lap and
  multi_agent, each method, `--repeat` times interleaved (ipopt, rti, ipopt, rti, ...);
- the RTI QPs of a mpcc_lap run solved again by every QP solver tried (HPIPM, OSQP, qpOASES,
  DAQP): time per QP and failures on identical problems, and the linearisation's own time;
- with `--suite`, the default suite's wall time from a warm cache.

    .venv/bin/python benchmarks/bench_mpcc.py [--repeat 3] [--suite] [--json OUT.json]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from kartci.bench import Better, Record
from kartci.logs import tables
from kartci.robots.gokart.mpcc.cache import get_solver
from kartci.robots.gokart.mpcc.model import SingleTrack
from kartci.robots.gokart.mpcc.params import MpccController, MpccMethod, QpSolver
from kartci.robots.gokart.mpcc.rti import _qp_options
from kartci.scenario import load_scenario
from kartci.sim import simulate

ROOT = Path(__file__).resolve().parents[1]
METHODS = (MpccMethod.IPOPT, MpccMethod.RTI)


def _spec(method: MpccMethod) -> tuple[MpccController, SingleTrack]:
    agent = load_scenario("mpcc_lap", [f"agents.kart0.controller.method={method}"]
                          ).agents["kart0"]
    assert isinstance(agent.controller, MpccController)
    return agent.controller, SingleTrack.of(agent.model)  # type: ignore[arg-type]


def setup_times(record: Record) -> None:
    """Compile into an empty cache, then load from it five times."""
    for method in METHODS:
        spec, kart = _spec(method)
        with tempfile.TemporaryDirectory() as cache:
            os.environ["KARTCI_CACHE_DIR"] = cache
            first = get_solver(spec, kart)
            cached = [get_solver(spec, kart).setup_s for _ in range(5)]
            del os.environ["KARTCI_CACHE_DIR"]
        record.add(f"{method} first build (generate C + compile)", "s", [first.setup_s])
        record.add(f"{method} cached start", "ms", [c * 1e3 for c in cached])
        print(f"{method}: first build {first.setup_s:.1f} s, cached start median "
              f"{np.median(cached) * 1e3:.0f} ms")


def closed_loop(record: Record, repeat: int) -> None:
    """Solve times on mpcc_lap and real-time factors of mpcc_lap and multi_agent."""
    solve: dict[str, list[float]] = {m: [] for m in METHODS}
    rtf: dict[tuple[str, str], list[float]] = {}
    for _ in range(repeat):
        for name in ("mpcc_lap", "multi_agent"):
            for method in METHODS:
                scenario = load_scenario(name, [f"agents.kart0.controller.method={method}"])
                with tempfile.TemporaryDirectory() as tmp:
                    log = Path(tmp) / "run.mcap"
                    t0 = time.perf_counter()
                    simulate(scenario, log)
                    wall = time.perf_counter() - t0
                    if name == "mpcc_lap":
                        ms = tables(log)["/kart0/mpcc/stats"]["solve_ms"].to_numpy()
                        solve[method].extend(ms.tolist())
                rtf.setdefault((name, method), []).append(scenario.duration_s / wall)
    for method in METHODS:
        ms = np.array(solve[method])
        record.add(f"{method} mpcc_lap closed-loop solve time", "ms", ms.tolist(),
                   note=f"all solves of {repeat} run(s); aim <= 3 ms median, <= 5 ms p95")
        print(f"{method}: solve time over {len(ms)} closed-loop solves (mpcc_lap): median "
              f"{np.median(ms):.2f} ms, p95 {np.percentile(ms, 95):.2f} ms, max {ms.max():.1f}")
    for (name, mode), values in rtf.items():
        record.add(f"{mode} {name} real-time factor", "x", values, better=Better.HIGHER,
                   note="aim: mpcc_lap >= 8x, multi_agent >= 4x")
        print(f"{mode}: {name} real-time factor median {np.median(values):.2f}x "
              f"({', '.join(f'{v:.2f}' for v in values)})")


def _recorded_qps(count: int) -> list[dict[str, Any]]:
    """`count` QPs, evenly spaced, from the first 20 s of an RTI run on the hall track."""
    scenario = load_scenario("mpcc_lap", ["agents.kart0.controller.method=rti",
                                          "duration_s=20"])
    seen: list[dict[str, Any]] = []
    real = ca.conic

    def recording(*args: Any) -> Any:  # the run's QP solver, recording what it is given
        qp = real(*args)

        class Recorder:
            def __call__(self, **qp_args: Any) -> Any:
                seen.append({k: ca.DM(v) for k, v in qp_args.items()})
                return qp(**qp_args)

            def stats(self) -> Any:
                return qp.stats()
        return Recorder()

    ca.conic = recording  # type: ignore[assignment]
    try:
        with tempfile.TemporaryDirectory() as tmp:
            simulate(scenario, Path(tmp) / "run.mcap")
    finally:
        ca.conic = real
    return [seen[i] for i in np.linspace(0, len(seen) - 1, count).astype(int)]


def qp_solvers(record: Record, count: int) -> None:
    """The same recorded QPs through each QP solver: time per QP and failures."""
    qps = _recorded_qps(count)
    base, kart = _spec(MpccMethod.RTI)
    rti = get_solver(base, kart).rti
    assert rti is not None
    sparsity = {"h": rti.lin.sparsity_out("hess_f"), "a": rti.lin.sparsity_out("jac_g")}
    for solver in QpSolver:
        spec = base.model_copy(update={"qp_solver": solver})
        qp = ca.conic("bench", solver.value, sparsity, _qp_options(spec))
        ms, failed = [], 0
        for args in qps:
            t0 = time.perf_counter()
            qp(**args)
            ms.append((time.perf_counter() - t0) * 1e3)
            failed += not qp.stats().get("success", False)
        record.add(f"RTI QP solve time, {solver}", "ms", ms,
                   note=f"{len(qps)} QPs recorded on mpcc_lap; {failed} failed")
        print(f"QP solver {solver}: median {np.median(ms):.2f} ms, p95 "
              f"{np.percentile(ms, 95):.2f} ms, {failed}/{len(qps)} failed")
    w, p = np.zeros(rti.lin.size1_in(0)), np.ones(rti.lin.size1_in(1))
    lin_ms = []
    for _ in range(200):
        t0 = time.perf_counter()
        rti.lin(w, p)
        lin_ms.append((time.perf_counter() - t0) * 1e3)
    record.add("RTI linearisation (compiled C: g, jacobian, gradient, Hessian)", "ms", lin_ms)
    print(f"RTI linearisation: median {np.median(lin_ms):.3f} ms")


def suite_time(record: Record) -> None:
    """The default suite's wall time, one job, from a warm solver cache."""
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        kartci = str(Path(sys.executable).with_name("kartci"))
        subprocess.run([kartci, "run", "--out", tmp], cwd=ROOT, check=False,
                       capture_output=True)
        wall = time.perf_counter() - t0
        record.add("default suite -j 1, warm solver cache", "s", [wall])
        print(f"default suite, warm solver cache: {wall:.0f} s wall")


def main() -> None:
    """Run the figures and print them; `--json` also writes them."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--json", type=Path, help="also write the figures to this file "
                        "(compare two with `kartci bench compare`)")
    parser.add_argument("--repeat", type=int, default=1, help="closed-loop runs per method "
                        "and scenario (interleaved)")
    parser.add_argument("--qps", type=int, default=40, help="recorded QPs per QP solver")
    parser.add_argument("--suite", action="store_true", help="also time the default suite")
    args = parser.parse_args()
    record = Record("bench_mpcc")
    setup_times(record)
    closed_loop(record, args.repeat)
    qp_solvers(record, args.qps)
    if args.suite:
        suite_time(record)
    if args.json:
        record.save(args.json)


if __name__ == "__main__":
    main()
