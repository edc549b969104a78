"""Bit-identical numbers on every x86-64 CPU: the environment kartci computes in.

Three libraries choose machine code by the CPU they run on, and each choice moves last bits
(measured on a Sapphire Rapids Xeon with `benchmarks/bench_portable.py --bits`):

- numpy picks ufunc loops at import: X86_V4's exp, log, tan and arctan differ from its
  baseline loops;
- OpenBLAS (numpy's and scipy's) picks kernels by core type at load (SkylakeX, Haswell,
  Sandybridge and Nehalem all differ on a 50 x 50 matmul) and splits large solves over threads;
- glibc's libm picks FMA variants of sin, cos, exp, log, atan2 and pow on CPUs with FMA and AVX2.

Each reads its choice from the environment once, when it loads, so kartci fixes that
environment: numpy's baseline loops (`NPY_ENABLE_CPU_FEATURES`), OpenBLAS's Nehalem kernels
(x86-64-v2, the level numpy itself requires) on one thread, libm's SSE2 variants
(`GLIBC_TUNABLES`). libm reads it when the process starts, numpy when it is imported: so
`import kartci` sets the environment (for numpy, if not yet imported, and for every process
started from here: `-j` workers, Ray's local workers, bridge children), the `kartci` command
re-executes itself once when it was not started with it, and a run asked of a Python process
that was not (the API, the pytest plugin) runs in a child process that is, started as its own
command (kartci.runner.pinned: never a re-import of the caller's `__main__`).
`KARTCI_SIMD=native` opts out (benchmarks); its runs are labelled so. `KARTCI_SIMD=pinned` (or
unset, or empty) is the default; any other value is an error, never silently the default.
"""

from __future__ import annotations

import importlib
import os
import platform as _platform
import sys
import warnings
from collections.abc import Mapping
from enum import StrEnum
from functools import cache
from pathlib import Path
from typing import Any

from kartci.errors import SpecError

OPT_OUT = "KARTCI_SIMD"  # "native": the CPU's own kernels (verdicts then depend on the CPU)
SIMD_VALUES = ("native", "pinned")  # what OPT_OUT may hold ("pinned", unset or empty: the pin)
_REEXEC = "KARTCI_PIN_REEXEC"  # set on the one re-execution, so a failed pin cannot loop
_TUNABLE = "glibc.cpu.hwcaps=-AVX2,-FMA,-FMA4,-AVX"  # libm's ifuncs: sse2 variants
_X86 = {
    "NPY_ENABLE_CPU_FEATURES": "X86_V2",  # any value: only the baseline; this one names it
    "OPENBLAS_CORETYPE": "Nehalem",
}
_ARM = {  # not verified on aarch64 hardware
    "NPY_ENABLE_CPU_FEATURES": "ASIMD",
    "OPENBLAS_CORETYPE": "ARMV8",
}
_THREADS = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
_DROP = ("NPY_DISABLE_CPU_FEATURES",)  # numpy refuses both variables at once


class Pin(StrEnum):
    """How this process computes."""

    PINNED = "pinned"  # started with kartci's environment: the same bits on every CPU
    UNPINNED = "unpinned"  # started without it, or numpy was imported first
    NATIVE = "native"  # the CPU's own kernels, asked for with KARTCI_SIMD=native


def opted_out(environ: Mapping[str, str]) -> bool:
    """Whether `environ` asks for the CPU's own kernels (KARTCI_SIMD=native); SpecError for a
    value that is neither of SIMD_VALUES: `Native` or a typo must not quietly mean the pin."""
    value = environ.get(OPT_OUT) or "pinned"
    if value not in SIMD_VALUES:
        import difflib  # start-up: only on this error

        close = difflib.get_close_matches(value.lower(), SIMD_VALUES, n=1)
        hint = f"did you mean '{close[0]}'?" if close else "unset means pinned"
        raise SpecError(f"{OPT_OUT}={value[:40]!r}: not native or pinned ({hint})")
    return value == "native"


def _arch() -> str:
    return _platform.machine().lower()


def pin_vars() -> dict[str, str]:
    """The variables kartci sets, for this machine's architecture (GLIBC_TUNABLES unmerged)."""
    arch = _arch()
    base = _X86 if arch in ("x86_64", "amd64") else _ARM if arch in ("aarch64", "arm64") else {}
    out = {**base, **_THREADS}
    if sys.platform.startswith("linux") and base is _X86:
        out["GLIBC_TUNABLES"] = _TUNABLE
    return out


def _tunables(current: str | None) -> str:
    """GLIBC_TUNABLES with kartci's hwcaps entry, other tunables kept."""
    kept = [t for t in (current or "").split(":") if t and not t.startswith("glibc.cpu.hwcaps=")]
    return ":".join([*kept, _TUNABLE])


def pinned_env(environ: Mapping[str, str]) -> dict[str, str]:
    """`environ` with kartci's pin applied (unchanged when it opts out)."""
    env = dict(environ)
    if opted_out(env):
        return env
    for key in _DROP:
        env.pop(key, None)
    for key, value in pin_vars().items():
        env[key] = _tunables(env.get(key)) if key == "GLIBC_TUNABLES" else value
    return env


def child_vars() -> dict[str, str]:
    """The variables a process started elsewhere needs (a Ray worker on a cluster)."""
    env = pinned_env(os.environ)
    if opted_out(env):
        return {OPT_OUT: "native"}
    return {key: env[key] for key in pin_vars()}


def prepare() -> None:
    """Pin os.environ (at `import kartci`): numpy, if imported later, and every child process
    started from here compute as kartci's own processes do. A bad KARTCI_SIMD is pinned here
    (an import does not fail) and refused by `state`, before anything computes."""
    try:
        pinned = pinned_env(os.environ)
    except SpecError:
        pinned = pinned_env({k: v for k, v in os.environ.items() if k != OPT_OUT})
    for key in _DROP:
        if key not in pinned:
            os.environ.pop(key, None)
    os.environ.update(pinned)


@cache
def _started_env() -> dict[str, str] | None:
    """The environment this process was started with (Linux), or None where unknown; it never
    changes, so it is read once."""
    try:
        raw = Path("/proc/self/environ").read_bytes()
    except OSError:
        return None
    pairs = (item.split(b"=", 1) for item in raw.split(b"\0") if b"=" in item)
    return {k.decode(errors="replace"): v.decode(errors="replace") for k, v in pairs}


def _holds(env: Mapping[str, str]) -> bool:
    """`env` carries the pin (other glibc tunables may sit beside kartci's)."""
    for key, value in pin_vars().items():
        have = env.get(key) or ""
        if key == "GLIBC_TUNABLES":
            items = have.split(":")
            if any(i.startswith("glibc.cpu.hwcaps=") and i != _TUNABLE for i in items) or (
                    _TUNABLE not in items):
                return False
        elif have != value:
            return False
    return not any(key in env for key in _DROP)


def _numpy_pinned() -> bool:
    """numpy not imported yet (it will load pinned), or loaded with no dispatch above baseline."""
    if "numpy" not in sys.modules:
        return True
    _, dispatch, features = _numpy_cpu()
    return not any(features.get(name) for name in dispatch)


def _numpy_cpu() -> tuple[list[str], list[str], dict[str, bool]]:
    """numpy's baseline features, its dispatch targets, and which features are on."""
    umath: Any = importlib.import_module("numpy._core._multiarray_umath")
    return (list(umath.__cpu_baseline__), list(umath.__cpu_dispatch__),
            dict(umath.__cpu_features__))


def state() -> Pin:
    """Whether this process computes with kartci's pinned environment (SpecError: a bad
    KARTCI_SIMD)."""
    if opted_out(os.environ):
        return Pin.NATIVE
    started = _started_env()
    if not _holds(started if started is not None else os.environ):
        return Pin.UNPINNED
    return Pin.PINNED if _numpy_pinned() else Pin.UNPINNED


def warn_unpinned() -> None:
    """A run about to happen in this process, which is not pinned: say that its last bits may
    differ from `kartci run`'s (a Python warning, once per place)."""
    if state() is Pin.UNPINNED:
        warnings.warn("this process was not started with kartci's pinned environment (numpy "
                      "or the process came before `import kartci`): a run here may differ in "
                      "its last bits from `kartci run`; see kartci.portable", RuntimeWarning,
                      stacklevel=3)


def reexec(args: list[str]) -> None:
    """A process started without the pin becomes a pinned one (same pid): `python ARGS` with
    the pinned environment, before it computes anything; once only (a process whose pin did
    not take goes on unpinned, and its run.json says so)."""
    if state() is not Pin.UNPINNED or os.environ.get(_REEXEC):
        return
    env = pinned_env(os.environ)
    env[_REEXEC] = "1"
    argv = [sys.executable, *args]
    sys.stdout.flush()
    sys.stderr.flush()
    try:
        os.execve(sys.executable, argv, env)
    except OSError:
        return  # runs unpinned; run.json says so


def _version(dist: str) -> str:
    from importlib import metadata  # start-up: +30 ms on `import kartci`, read at run time

    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "absent"


def _dispatch() -> str:
    """numpy's active loops: its baseline and the dispatched levels in use."""
    baseline, dispatch, features = _numpy_cpu()
    return " ".join([*baseline, *(n for n in dispatch if features.get(n))])


def describe() -> dict[str, str]:
    """Where numbers were made: architecture, pin, numpy's active loops, OpenBLAS's kernels, and
    the versions of what computes them."""
    return {"arch": _arch(), "simd": state().value, "numpy_loops": _dispatch(),
            "openblas_core": os.environ.get("OPENBLAS_CORETYPE", "cpu"),
            "python": _platform.python_version(),
            **{dist: _version(dist) for dist in ("numpy", "scipy", "pybullet", "casadi")}}


# what must agree for bit-identical metrics; the python version does not move them
BIT_KEYS = ("arch", "simd", "numpy", "scipy", "pybullet", "casadi")


def mismatch(made: Mapping[str, str] | None, now: Mapping[str, str]) -> str | None:
    """A note when a baseline was made where bits differ from this run's, else None."""
    if not made:
        return None
    diff = [f"{k} {made.get(k, '?')} (this run: {now.get(k, '?')})" for k in BIT_KEYS
            if made.get(k) != now.get(k)]
    if not diff:
        return None
    return ("baseline made elsewhere: " + ", ".join(diff) + "; last bits may differ, judged "
            "within tolerances")
