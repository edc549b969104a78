"""Bit-identical numbers on every x86-64 CPU (kartci.portable): the pinned environment, who gets
it, and metrics byte-identical under every SIMD level, OpenBLAS core type and thread count the
machine offers. The full matrix over the shipped kart scenarios is opt-in (KARTCI_LONG=1)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from kartci import portable
from kartci.portable import Pin

PY = sys.executable
KARTCI = str(Path(PY).with_name("kartci"))
ROOT = Path(__file__).resolve().parents[2]
X86 = portable._arch() in ("x86_64", "amd64")


def _clean_env(**extra: str) -> dict[str, str]:
    """The environment of a shell that never heard of kartci's pin."""
    env = {k: v for k, v in os.environ.items()
           if k not in (*portable.pin_vars(), "NPY_DISABLE_CPU_FEATURES", "KARTCI_PIN_REEXEC",
                        portable.OPT_OUT, "PYTEST_XDIST_WORKER")}
    return {**env, **extra}


def _state(code: str, env: dict[str, str]) -> str:
    run = subprocess.run([PY, "-c", code], env=env, capture_output=True, text=True, check=True)
    return run.stdout.strip().splitlines()[-1]


def test_the_test_process_itself_is_pinned() -> None:
    """conftest restarts an unpinned pytest: the exact-baseline tests compute here."""
    assert portable.state() is Pin.PINNED


def test_pinned_env_merges_glibc_tunables_and_drops_the_disable_list() -> None:
    env = portable.pinned_env({"GLIBC_TUNABLES": "glibc.malloc.check=3:glibc.cpu.hwcaps=-AVX2",
                               "NPY_DISABLE_CPU_FEATURES": "X86_V4", "PATH": "/bin"})
    assert "NPY_DISABLE_CPU_FEATURES" not in env and env["PATH"] == "/bin"
    assert env["OPENBLAS_NUM_THREADS"] == "1"
    if X86 and sys.platform.startswith("linux"):
        assert env["GLIBC_TUNABLES"].split(":") == ["glibc.malloc.check=3",
                                                   "glibc.cpu.hwcaps=-AVX2,-FMA,-FMA4,-AVX"]
        assert env["NPY_ENABLE_CPU_FEATURES"] == "X86_V2"
        assert env["OPENBLAS_CORETYPE"] == "Nehalem"
    assert portable.pinned_env({"KARTCI_SIMD": "native"}) == {"KARTCI_SIMD": "native"}


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/environ")
def test_a_process_knows_whether_it_was_started_pinned() -> None:
    code = "import kartci.portable as p; print(p.state().value)"
    assert _state(code, _clean_env()) == "unpinned"  # libm chose at start, without the pin
    assert _state(code, portable.pinned_env(_clean_env())) == "pinned"
    assert _state(code, _clean_env(KARTCI_SIMD="native")) == "native"
    # started pinned, but numpy loaded before the pin was put back: not pinned
    first = "import os; os.environ.pop('NPY_ENABLE_CPU_FEATURES'); import numpy; " + code
    assert _state(first, portable.pinned_env(_clean_env())) == "unpinned"


def _metrics(folder: Path) -> str:
    """The deterministic metrics of a run folder, as bytes to compare."""
    return json.dumps(json.loads((folder / "metrics.json").read_text())["metrics"],
                      sort_keys=True)


def _same_log(a: Path, b: Path) -> None:
    """Every message of the two run logs bit for bit (wall-clock fields aside): stronger than
    the metrics, which a short run's last-bit differences may not reach."""
    done = subprocess.run([KARTCI, "diff", str(a), str(b)], capture_output=True, text=True,
                          check=False)
    assert done.returncode == 0, done.stdout[-1500:] + done.stderr[-500:]


def _run(out: Path, env: dict[str, str], *args: str) -> None:
    done = subprocess.run([KARTCI, "run", *args, "--out", str(out)], env=env,
                          capture_output=True, text=True, check=False, cwd=ROOT)
    assert done.returncode in (0, 1), done.stderr[-2000:]


def _levels(every: bool) -> dict[str, dict[str, str]]:
    """Dispatch levels and OpenBLAS / libm choices this machine offers, as a user's environment:
    each one alone (`every`), or the lowest levels together with the other libraries' foreign
    choices (the quick check: three runs)."""
    import numpy  # noqa: F401  (loaded, so its dispatch table is known)

    _, dispatch, features = portable._numpy_cpu()
    on = [n for n in dispatch if features.get(n)]
    out = {"all enabled": _clean_env()}
    if any(n.startswith(("X86_V4", "AVX512")) for n in on):
        out["X86_V4 and AVX512 off"] = _clean_env(NPY_DISABLE_CPU_FEATURES=" ".join(
            n for n in dispatch if n.startswith(("X86_V4", "AVX512"))))
    if "X86_V3" in on:
        out["X86_V3 off too"] = _clean_env(NPY_DISABLE_CPU_FEATURES=" ".join(dispatch))
    if X86:
        foreign = {"OPENBLAS_CORETYPE": "Haswell", "OPENBLAS_NUM_THREADS": "2",
                   "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA"}
        if every:
            out["OpenBLAS Haswell, 2 threads"] = _clean_env(OPENBLAS_CORETYPE="Haswell",
                                                            OPENBLAS_NUM_THREADS="2")
            out["OpenBLAS SkylakeX"] = _clean_env(OPENBLAS_CORETYPE="SkylakeX")
            out["libm without FMA"] = _clean_env(GLIBC_TUNABLES="glibc.cpu.hwcaps=-AVX2,-FMA")
        else:
            lowest = list(out)[-1]
            out[lowest] = {**out[lowest], **foreign}
    return out


def _across_levels(tmp_path: Path, name: str, duration_s: float,
                   every: bool = False) -> dict[str, str]:
    """Each level's metrics; every level's log equals the first's."""
    got = {}
    for i, (label, env) in enumerate(_levels(every).items()):
        out = tmp_path / f"level{i}"
        _run(out, env, name, "--set", f"duration_s={duration_s:g}")
        got[label] = _metrics(out / name)
        if i:
            _same_log(tmp_path / "level0" / name, out / name)
    return got


def test_the_command_gives_the_same_metrics_under_every_level(tmp_path: Path) -> None:
    """`kartci run` started from any environment re-executes itself pinned: the MPCC lap's
    log and metrics are the same bytes whatever numpy, OpenBLAS or libm would pick on this CPU
    (unpinned, its log differs from the first message: tests/logs/test_diff.py)."""
    got = _across_levels(tmp_path, "mpcc_lap", 2.0)
    assert len(set(got.values())) == 1, got


@pytest.mark.long(reason="runs under several pins, workers and an unpinned Python")
def test_workers_and_an_unpinned_python_compute_as_the_command(tmp_path: Path) -> None:
    """-j workers, and the API in a Python that imported numpy before kartci (its run goes to
    a pinned child), give the command's bytes."""
    _run(tmp_path / "one", _clean_env(), "kart_wall", "mpcc_lap", "--set", "duration_s=1")
    _run(tmp_path / "two", _clean_env(), "kart_wall", "mpcc_lap", "--set", "duration_s=1",
         "-j", "2")
    code = ("import numpy, kartci, sys; r = kartci.run('mpcc_lap', overrides=['duration_s=1'], "
            "out=sys.argv[1]); print(r.folder)")
    subprocess.run([PY, "-c", code, str(tmp_path / "api")], env=_clean_env(), check=True,
                   capture_output=True, cwd=ROOT)
    for name in ("kart_wall", "mpcc_lap"):
        assert _metrics(tmp_path / "one" / name) == _metrics(tmp_path / "two" / name)
        _same_log(tmp_path / "one" / name, tmp_path / "two" / name)
    assert _metrics(tmp_path / "api" / "mpcc_lap") == _metrics(tmp_path / "one" / "mpcc_lap")
    _same_log(tmp_path / "one" / "mpcc_lap", tmp_path / "api" / "mpcc_lap")
    run = json.loads((tmp_path / "api" / "mpcc_lap" / "run.json").read_text())
    assert run["platform"]["simd"] == "pinned"


KART_SCENARIOS = ["obstacle_avoidance", "perception_obstacles", "mpcc_lap", "multi_agent",
                  "localization_lap"]


@pytest.mark.long(reason="every kart scenario under every SIMD level")
@pytest.mark.parametrize("name", KART_SCENARIOS)
def test_kart_scenarios_are_byte_identical_under_every_level(name: str, tmp_path: Path) -> None:
    got = _across_levels(tmp_path, name, 12.0, every=True)
    assert len(set(got.values())) == 1, got


def test_agent_objects_in_an_unpinned_python_run_there_and_say_so(tmp_path: Path) -> None:
    """Objects cannot leave the caller's process: the run happens there, and the result warns
    that its last bits may differ from `kartci run`."""
    code = """
import sys, numpy as np
import kartci
from kartci.logs import header, msg

class Straight:
    period_s = 0.06
    inputs = ("line_sensor",)
    def on_message(self, topic, message): pass
    def step(self, t_ns):
        return [("wheel_cmd", msg("sensor_msgs/msg/JointState", header=header(t_ns, "base_link"),
                 name=[], position=np.zeros(0), effort=np.zeros(0),
                 velocity=np.array([3.0, 3.0])))]

r = kartci.run("line_straight", overrides=["duration_s=1", "metrics.line_tracking.transient_s=0.5"],
               agents={"lt0": Straight()}, out=sys.argv[1])
print(repr(r.warnings))
"""
    done = subprocess.run([PY, "-c", code, str(tmp_path)], env=_clean_env(), cwd=ROOT,
                          capture_output=True, text=True, check=True)
    assert "not started pinned" in done.stdout
    run = json.loads((tmp_path / "line_straight" / "run.json").read_text())
    assert run["platform"]["simd"] == "unpinned"
