"""benchmarks/bench_kart.py's f1tenth_gym anchor: run by another interpreter, read from its one
JSON line, skipped with the reason when that interpreter fails; the anchor script itself where
the side venv exists ($KARTCI_F1TENTH_PYTHON; benchmarks/make_f1tenth_env.sh)."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def _bench_kart() -> ModuleType:
    spec = importlib.util.spec_from_file_location("bench_kart", BENCHMARKS / "bench_kart.py")
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    sys.modules["bench_kart"] = module  # its dataclass looks its module up there
    spec.loader.exec_module(module)
    return module


def _fake_python(tmp_path: Path, body: str) -> Path:
    python = tmp_path / "python"
    python.write_text(f"#!/bin/sh\n{body}\n")
    python.chmod(0o755)
    return python


def test_the_anchor_is_read_from_its_interpreter(tmp_path: Path) -> None:
    out = {"rtf": 30.0, "cpu_rtf": 31.5, "versions": {"f110_gym": "0.2.1"}}
    python = _fake_python(tmp_path, f"echo '{json.dumps(out)}'")
    run = _bench_kart().anchor_rtf(python, steps=10)
    assert (run.rtf, run.cpu_rtf, run.versions) == (30.0, 31.5, {"f110_gym": "0.2.1"})


def test_a_failing_anchor_is_a_reason(tmp_path: Path) -> None:
    python = _fake_python(tmp_path, "echo 'Traceback' >&2; echo 'ModuleNotFoundError: f110_gym' >&2"
                          "; exit 1")
    assert _bench_kart().anchor_rtf(python) == (
        f"{python} f1tenth_anchor.py exited 1: ModuleNotFoundError: f110_gym")


def test_a_missing_anchor_python_is_one_line_and_exit_2(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "nope"
    monkeypatch.setattr(sys, "argv", ["bench_kart.py", "--parts", "--anchor-python", str(missing)])
    with pytest.raises(SystemExit) as exit_:
        _bench_kart().main()
    assert exit_.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        f"bench_kart.py: error: --anchor-python / KARTCI_F1TENTH_PYTHON: no such file: {missing}")


@pytest.mark.skipif(not os.environ.get("KARTCI_F1TENTH_PYTHON"),
                    reason="no f1tenth_gym side venv: benchmarks/make_f1tenth_env.sh CHECKOUT, "
                    "then set KARTCI_F1TENTH_PYTHON")
def test_the_anchor_steps_f1tenth_gyms_car() -> None:
    done = subprocess.run([os.environ["KARTCI_F1TENTH_PYTHON"], "-I",
                           str(BENCHMARKS / "f1tenth_anchor.py"), "--steps", "50"],
                          capture_output=True, text=True, check=True)
    out = json.loads(done.stdout)
    assert (out["steps"], out["timestep_s"], out["beams"]) == (50, 0.01, 1080)
    assert out["rtf"] > 0 and out["cpu_rtf"] > 0
