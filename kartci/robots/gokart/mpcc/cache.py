"""Build the MPCC solver once and keep its compiled form on disk.

The key hashes everything the compiled code depends on (the horizon, the vehicle model, the
solver, CasADi's version and this package's source), so a second run compiles nothing and a
changed model never loads a stale binary. Builds are written under a temporary name and renamed
into place, so parallel runs that race to build the same solver each get a whole file.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as ca

from kartci.cachedir import cache_dir
from kartci.errors import RunError
from kartci.robots.gokart.mpcc.model import SingleTrack
from kartci.robots.gokart.mpcc.ocp import Layout, build
from kartci.robots.gokart.mpcc.params import MpccController, MpccMethod
from kartci.robots.gokart.mpcc.rti import Rti, linearisation

SOURCES = {MpccMethod.IPOPT: ("model.py", "ocp.py", "cache.py"),
           MpccMethod.RTI: ("model.py", "ocp.py", "cache.py", "rti.py")}


def solver_key(spec: MpccController, model: SingleTrack) -> str:
    """The cache key: a hash of CasADi's version, the method and its sources, the spec fields
    compiled into it (horizon, step, RK4 substeps, modelling choices) and the kart's parameters.
    The QP solver and all limits and weights are runtime inputs, not in the key."""
    here = Path(__file__).parent
    h = hashlib.sha256()
    h.update(f"{ca.CasadiMeta.version()} {spec.method}".encode())
    for name in SOURCES[spec.method]:
        h.update((here / name).read_bytes())
    compiled = spec.model_dump(include={"horizon_steps", "step_s", "rk4_substeps", "vehicle"})
    h.update(repr(sorted(compiled.items())).encode())
    h.update(model.key().encode())
    return h.hexdigest()[:16]


@dataclass(frozen=True)
class Built:
    """A solver ready to use, its decision-vector layout, and how it was obtained."""

    solver: ca.Function | None  # Ipopt, warm-started from the previous solution
    cold: ca.Function | None  # the same NLP with Ipopt's default start, for retries
    rti: Rti | None  # the RTI mode's linearisation and QP solver
    layout: Layout
    compiled: bool  # False when no C compiler was found: the SX graph is interpreted
    setup_s: float  # wall time to get the solver: compile on a miss, load on a hit
    cache_hit: bool


def _options(spec: MpccController, warm: bool = True) -> dict[str, Any]:
    start = ({"warm_start_init_point": "yes", "warm_start_bound_push": 1e-6,
              "warm_start_mult_bound_push": 1e-6, "mu_init": 1e-3} if warm else {})
    return {"print_time": False,
            "ipopt": {"print_level": 0, "sb": "yes", "max_iter": spec.max_iterations,
                      "tol": 1e-4, "acceptable_tol": 1e-3, "linear_solver": "mumps", **start}}


def _compiler() -> str | None:
    return shutil.which(os.environ.get("CC", "gcc")) or shutil.which("cc")


def get_solver(spec: MpccController, model: SingleTrack) -> Built:
    """The solver of the spec's method for this kart: from the cache, else compiled into it (or
    interpreted when compiling is off or impossible)."""
    t0 = time.perf_counter()
    nlp, layout = build(spec, model)
    cc = _compiler() if spec.compile else None
    hit = False
    if spec.method is MpccMethod.RTI:
        lin = linearisation(nlp, spec.horizon_steps)
        lib: Path | None = None
        if cc is not None:
            lib, hit = _cached(spec, model, [lin], cc)
            lin = _load(lambda: ca.external(lin.name(), str(lib)), str(lib))
        return Built(None, None, Rti(lin, spec, lib), layout, cc is not None,
                     time.perf_counter() - t0, hit)
    source: Any = nlp
    label = "(interpreted)"
    if cc is not None:
        gen = ca.nlpsol("mpcc", "ipopt", nlp, _options(spec))
        source, hit = _cached(spec, model, [gen.oracle(), *(
            gen.get_function(name) for name in gen.get_function())], cc)
        source = label = str(source)
    solver = _load(lambda: ca.nlpsol("mpcc", "ipopt", source, _options(spec)), label)
    cold = _load(lambda: ca.nlpsol("mpcc_cold", "ipopt", source, _options(spec, warm=False)),
                 label)
    return Built(solver, cold, None, layout, cc is not None, time.perf_counter() - t0, hit)


def _cached(spec: MpccController, model: SingleTrack, functions: list[ca.Function],
            cc: str) -> tuple[Path, bool]:
    """The library of `functions` in the cache, compiled into it on a miss; and whether it hit."""
    lib = cache_dir() / "mpcc" / f"mpcc_{spec.method}_{solver_key(spec, model)}.so"
    hit = lib.exists()
    if not hit:
        _compile(functions, lib, cc)
    return lib, hit


def _load(make: Callable[[], ca.Function], source: str) -> ca.Function:
    try:
        return make()
    except RuntimeError as err:
        raise RunError(f"MPCC solver {source} does not load ({err}); delete it to "
                       "rebuild") from err


def _compile(functions: list[ca.Function], lib: Path, cc: str) -> None:
    """C code for the solver's derivative functions, compiled into `lib`."""
    lib.parent.mkdir(parents=True, exist_ok=True)
    tmp = lib.parent / f".build_{os.getpid()}_{lib.stem}"
    tmp.mkdir(exist_ok=True)
    try:
        cg = ca.CodeGenerator("mpcc_nlp.c", {"with_header": False})
        for f in functions:
            cg.add(f)
        cg.generate(f"{tmp}/")
        out = tmp / lib.name
        # no fused multiply-adds: a compiler whose default target has FMA (x86-64-v3 distros,
        # aarch64) would otherwise round differently from one whose default has not
        run = subprocess.run([cc, "-O1", "-ffp-contract=off", "-fPIC", "-shared",
                              str(tmp / "mpcc_nlp.c"), "-o", str(out), "-lm"],
                             capture_output=True, text=True, check=False)
        if run.returncode != 0:
            raise RunError(f"compiling the MPCC solver failed: {run.stderr.strip()[:300]}")
        os.replace(out, lib)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
