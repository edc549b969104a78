"""MPCC figures for both methods in one run: the Ipopt reference and real-time iterations (RTI).

- first build (generate C + compile) and cached start of each method's compiled code;
- closed-loop solve time (median, p95) on mpcc_lap and the real-time factor of mpcc_lap and
  multi_agent, each variant (Ipopt, RTI, RTI with one QP per step), `--repeat`
  times interleaved (ipopt, rti, rti-1qp, ipopt, ...);
- the RTI QPs of a mpcc_lap run solved again by HPIPM through its own interface and by every
  QP solver through CasADi's (HPIPM, OSQP, qpOASES, DAQP): time per QP and failures on
  identical problems, and the linearisation's own time (CasADi call, C entry point);
- with `--suite`, the default suite's wall time from a warm cache.

    .venv/bin/python benchmarks/bench_mpcc.py [--repeat 3] [--variants rti,rti-1qp]
        [--suite] [--json OUT.json]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import casadi as ca
import numpy as np

from kartci.bench import Better, Record
from kartci.logs import tables
from kartci.project import current as active_project
from kartci.robots.gokart.mpcc.cache import get_solver
from kartci.robots.gokart.mpcc.direct import OcpQp
from kartci.robots.gokart.mpcc.model import SingleTrack
from kartci.robots.gokart.mpcc.params import MpccController, MpccMethod, QpSolver
from kartci.robots.gokart.mpcc.rti import QP_TOL, ConicQp, qp_options, stages
from kartci.scenario import load_scenario
from kartci.sim import simulate

ROOT = Path(__file__).resolve().parents[1]
METHODS = (MpccMethod.IPOPT, MpccMethod.RTI)


def _spec(method: MpccMethod) -> tuple[MpccController, SingleTrack]:
    agent = load_scenario("mpcc_lap", [f"agents.kart0.controller.method={method}"]
                          , project=active_project()).agents["kart0"]
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


# the closed-loop variants: Ipopt, RTI as shipped (three QPs per step), RTI with one QP
VARIANTS = {"ipopt": ["method=ipopt"], "rti": ["method=rti"],
            "rti-1qp": ["method=rti", "sqp_iterations=1"]}


def closed_loop(record: Record, repeat: int, variants: list[str]) -> None:
    """Solve times on mpcc_lap and real-time factors of mpcc_lap and multi_agent, each
    variant in turn within every round."""
    solve: dict[str, list[float]] = {v: [] for v in variants}
    rtf: dict[tuple[str, str], list[float]] = {}
    for _ in range(repeat):
        for name in ("mpcc_lap", "multi_agent"):
            for variant in variants:
                scenario = load_scenario(name, [f"agents.kart0.controller.{s}"
                                                for s in VARIANTS[variant]],
                                                project=active_project())
                with tempfile.TemporaryDirectory() as tmp:
                    log = Path(tmp) / "run.mcap"
                    t0 = time.perf_counter()
                    simulate(scenario, log)
                    wall = time.perf_counter() - t0
                    if name == "mpcc_lap":
                        ms = tables(log)["/kart0/mpcc/stats"]["solve_ms"].to_numpy()
                        solve[variant].extend(ms.tolist())
                rtf.setdefault((name, variant), []).append(scenario.duration_s / wall)
    for variant in variants:
        ms = np.array(solve[variant])
        record.add(f"{variant} mpcc_lap closed-loop solve time", "ms", ms.tolist(),
                   note=f"all solves of {repeat} run(s); aim <= 2 ms median, <= 3 ms p95")
        print(f"{variant}: solve time over {len(ms)} closed-loop solves (mpcc_lap): median "
              f"{np.median(ms):.2f} ms, p95 {np.percentile(ms, 95):.2f} ms, max {ms.max():.1f}")
    for (name, variant), values in rtf.items():
        record.add(f"{variant} {name} real-time factor", "x", values, better=Better.HIGHER,
                   note="aim: mpcc_lap >= 8x, multi_agent >= 4x")
        print(f"{variant}: {name} real-time factor median {np.median(values):.2f}x "
              f"({', '.join(f'{v:.2f}' for v in values)})")


def _recorded_qps(count: int) -> list[list[np.ndarray]]:
    """`count` QPs, evenly spaced, from the first 20 s of an RTI run on the hall track: the
    arguments HPIPM's direct interface was given (`OcpQp.solve`, without its output)."""
    scenario = load_scenario("mpcc_lap", ["agents.kart0.controller.method=rti",
                                          "duration_s=20"], project=active_project())
    seen: list[list[np.ndarray]] = []
    real = OcpQp.solve

    def recording(self: OcpQp, *qp: np.ndarray) -> tuple[bool, int]:
        seen.append([np.array(a) for a in qp[:-1]])
        return real(self, *qp)

    OcpQp.solve = recording  # type: ignore[method-assign,assignment]
    try:
        with tempfile.TemporaryDirectory() as tmp:
            simulate(scenario, Path(tmp) / "run.mcap")
    finally:
        OcpQp.solve = real  # type: ignore[method-assign]
    return [seen[i] for i in np.linspace(0, len(seen) - 1, count).astype(int)]


def qp_solvers(record: Record, count: int) -> None:
    """The same recorded QPs through HPIPM's own interface and each solver through CasADi's
    (HPIPM, OSQP, qpOASES, DAQP): time per QP and failures; the linearisation called as a
    CasADi function and through its C entry point."""
    qps = _recorded_qps(count)
    base, kart = _spec(MpccMethod.RTI)
    rti = get_solver(base, kart).rti
    assert rti is not None
    h, a = rti.lin.sparsity_out("hess_f"), rti.lin.sparsity_out("jac_g")
    direct = OcpQp(stages(base.horizon_steps), h, a, base.max_iterations, QP_TOL)
    solvers: dict[str, Callable[..., tuple[bool, int]]] = {"hpipm, direct": direct.solve}
    for solver in QpSolver:
        spec = base.model_copy(update={"qp_solver": solver})
        conic = ca.conic("bench", solver.value, {"h": h, "a": a}, qp_options(spec))
        solvers[f"{solver}, CasADi conic"] = ConicQp(conic, h, a).solve
    for label, solve in solvers.items():
        ms, failed = [], 0
        for qp in qps:
            out = np.empty(len(qp[2]))
            t0 = time.perf_counter()
            ok, _ = solve(qp[0], qp[1], qp[2], qp[3], qp[4], qp[5], qp[6], out)
            ms.append((time.perf_counter() - t0) * 1e3)
            failed += not ok
        record.add(f"RTI QP solve time, {label}", "ms", ms,
                   note=f"{len(qps)} QPs recorded on mpcc_lap; {failed} failed")
        print(f"QP solver {label}: median {np.median(ms):.2f} ms, p95 "
              f"{np.percentile(ms, 95):.2f} ms, {failed}/{len(qps)} failed")
    w, p = np.zeros(rti.lin.size1_in(0)), np.ones(rti.lin.size1_in(1))
    for label, lin in (("CasADi call", rti.lin), ("C entry point", rti.evaluate)):
        lin_ms = []
        for _ in range(200):
            t0 = time.perf_counter()
            lin(w, p)
            lin_ms.append((time.perf_counter() - t0) * 1e3)
        record.add(f"RTI linearisation (compiled C: g, jacobian, gradient, Hessian), {label}",
                   "ms", lin_ms)
        print(f"RTI linearisation, {label}: median {np.median(lin_ms):.3f} ms")


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
    parser.add_argument("--variants", default=",".join(VARIANTS), help="closed-loop "
                        f"variants, comma-separated, of: {', '.join(VARIANTS)}")
    parser.add_argument("--qps", type=int, default=40, help="recorded QPs per QP solver")
    parser.add_argument("--suite", action="store_true", help="also time the default suite")
    args = parser.parse_args()
    record = Record("bench_mpcc")
    setup_times(record)
    closed_loop(record, args.repeat, args.variants.split(","))
    qp_solvers(record, args.qps)
    if args.suite:
        suite_time(record)
    if args.json:
        record.save(args.json)


if __name__ == "__main__":
    main()
