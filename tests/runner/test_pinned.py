"""A Python process that was not started pinned runs its kartci runs in a pinned child started
as its own command: a script without `if __name__ == "__main__":` runs its body once, not once
more per run, and an error inside the child is the caller's same exception."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import kartci
from kartci import portable

SHORT = ["duration_s=1", "criteria={}", "metrics.line_tracking.transient_s=0.3"]
TOO_SHORT = [*SHORT, "metrics.line_tracking.transient_s=2"]  # fails after the run, when scored

# a user's script as the issue found it: kartci.run at top level, no __main__ guard
SCRIPT = f"""\
import pathlib
import sys

import kartci

here = pathlib.Path(sys.argv[1])
with open(here / "body.txt", "a") as marks:  # once per execution of this file's body
    marks.write("ran\\n")
first = kartci.run("line_straight", overrides={SHORT!r}, out=here / "first")
second = kartci.run("line_straight", overrides={SHORT!r}, out=here / "second")
print(first.folder.is_dir(), second.folder.is_dir(), first.metrics == second.metrics)
try:
    kartci.run("line_straight", overrides={TOO_SHORT!r}, out=here / "third")
except kartci.KartciError as err:
    print(type(err).__module__, type(err).__qualname__, err, sep=" | ")
"""


@pytest.fixture(scope="module")
def unpinned_script(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str, str]:
    """The script run as a user runs it, in a process not started with kartci's pinned
    environment (so its runs go to the pinned child): its folder, stdout and stderr."""
    here = tmp_path_factory.mktemp("script")
    (here / "runs.py").write_text(SCRIPT)
    env = {k: v for k, v in os.environ.items() if k not in portable.pin_vars()}
    p = subprocess.run([sys.executable, "runs.py", str(here)], capture_output=True, text=True,
                       env=env, timeout=300, cwd=here)
    assert p.returncode == 0, p.stderr
    return here, p.stdout, p.stderr


def test_a_script_without_a_main_guard_runs_its_body_once_however_many_runs_it_asks(
        unpinned_script: tuple[Path, str, str]) -> None:
    here, stdout, stderr = unpinned_script
    assert (here / "body.txt").read_text() == "ran\n"
    assert stdout.splitlines()[0] == "True True True"
    assert "Traceback" not in stderr


def test_an_error_in_the_pinned_child_is_the_exception_the_run_raises_in_process(
        unpinned_script: tuple[Path, str, str], tmp_path: Path) -> None:
    _, stdout, _ = unpinned_script
    assert portable.state() is portable.Pin.PINNED  # this pytest runs in process
    with pytest.raises(kartci.KartciError) as here:
        kartci.run("line_straight", overrides=TOO_SHORT, out=tmp_path)
    err = here.value
    assert stdout.splitlines()[1:] == [
        f"{type(err).__module__} | {type(err).__qualname__} | {err}"]
    assert type(err).__qualname__ == "SpecError"
