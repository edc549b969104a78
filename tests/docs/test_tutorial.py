"""docs/tutorial.md runs: its fenced blocks, in order, in an empty folder.

The info string of a block says what the test does with it:

- ```` ```bash tutorial ```` runs the block with bash (`-e -o pipefail`) in the folder the
  previous block ended in; `expect=N` wants exit code N from it (the failing command last);
- ```` ```LANG file=PATH ```` writes the block to PATH, relative to that folder;
- ```` ```LANG excerpt=PATH ```` must appear, line by line, in PATH of kartci's repository;
- ```` ```bash install ```` is not run: the test runs kartci from this checkout instead (a
  `kartci` on PATH that is `python -m kartci.cli` with this checkout on PYTHONPATH).

Any other code block is an error, so nothing in the tutorial goes untested. The environment
has no KARTCI_ROOT and no CI variables, as on a newcomer's machine.
"""

from __future__ import annotations

import importlib
import json
import re
import shlex
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import yaml
from helpers import kartci_shell_env

ROOT = Path(__file__).resolve().parents[2]
TUTORIAL = ROOT / "docs" / "tutorial.md"
FENCE = re.compile(r"^```([^\n`]*)\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
MODELINE = "# yaml-language-server: $schema="


@dataclass(frozen=True)
class Block:
    lang: str
    flags: frozenset[str]
    attrs: dict[str, str]
    text: str
    line: int

    @property
    def where(self) -> str:
        return f"{TUTORIAL.name}:{self.line}"


def blocks(markdown: str) -> list[Block]:
    out = []
    for m in FENCE.finditer(markdown):
        words = m.group(1).split()
        lang, rest = (words[0], words[1:]) if words else ("", [])
        attrs = dict(w.split("=", 1) for w in rest if "=" in w)
        flags = frozenset(w for w in rest if "=" not in w)
        out.append(Block(lang, flags, attrs, m.group(2),
                         markdown.count("\n", 0, m.start()) + 1))
    return out


BLOCKS = blocks(TUTORIAL.read_text(encoding="utf-8"))


def test_every_block_is_run_written_or_checked() -> None:
    assert BLOCKS
    for b in BLOCKS:
        known = ("tutorial" in b.flags or "install" in b.flags or "file" in b.attrs
                 or "excerpt" in b.attrs)
        assert known, f"{b.where}: a ```{b.lang} block the test neither runs nor checks"
        assert b.lang in ("bash", "yaml", "python", "toml"), b.where
        assert set(b.attrs) <= {"file", "expect", "excerpt"}, b.where


def test_excerpts_match_the_repository() -> None:
    excerpts = [b for b in BLOCKS if "excerpt" in b.attrs]
    assert excerpts
    for b in excerpts:
        text = (ROOT / b.attrs["excerpt"]).read_text(encoding="utf-8").splitlines()
        for line in b.text.splitlines():
            assert not line.strip() or line in text, f"{b.where}: {line!r} not in the file"


@pytest.mark.long(reason="the whole tutorial, in a shell")
def test_the_tutorial_runs(tmp_path: Path) -> None:
    env = kartci_shell_env(tmp_path)
    home = tmp_path / "work"
    home.mkdir()
    cwd = home
    state = tmp_path / "cwd"
    written: list[Path] = []
    for b in BLOCKS:
        if "file" in b.attrs:
            path = cwd / b.attrs["file"]
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(b.text, encoding="utf-8")
            written.append(path)
        elif "tutorial" in b.flags:
            script = (f"trap 'pwd > {shlex.quote(str(state))}' EXIT\n"
                      f"cd {shlex.quote(str(cwd))}\n{b.text}")
            p = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", script], env=env,
                               capture_output=True, text=True, timeout=300)
            expect = int(b.attrs.get("expect", "0"))
            said = f"{b.where}: exit {p.returncode}\n{b.text}\n{p.stdout[-3000:]}\n{p.stderr}"
            assert p.returncode == expect, said
            assert "Traceback" not in p.stdout + p.stderr, said
            cwd = Path(state.read_text(encoding="utf-8").strip())

    project = home / "my_robot_ci"
    assert cwd == project
    # (1) the built-in scenario's run and reports
    latest = project / "reports" / "latest"
    for name in ("report.html", "summary.md", "summary.json", "junit.xml"):
        assert (latest / name).is_file(), name
    # (2) the own scenario's baseline, (3)-(4) the own controller and metric set's
    for name in ("line_fast", "kart_cruise"):
        assert (project / "baselines" / f"{name}.json").is_file(), name
    cruise = json.loads((project / "baselines" / "kart_cruise.json").read_text("utf-8"))
    assert {"speed_std_mps", "heading_drift_rad", "progress_m"} <= set(cruise["metrics"])
    # (5) the shards merged into one report
    merged = json.loads((project / "reports" / "merged" / "summary.json").read_text("utf-8"))
    assert set(merged["scenarios"]) == {"line_fast", "kart_cruise"}
    assert merged["exit_code"] == 0
    # the editor schema knows the project's own plugins, and the scenarios point at it
    schema_file = project / ".kartci" / "scenario.schema.json"
    schema = json.loads(schema_file.read_text(encoding="utf-8"))
    text = json.dumps(schema)
    assert "`cruise`" in text and "`cruise_quality`" in text
    for path in written:
        if path.suffix != ".yaml":
            continue
        first = path.read_text(encoding="utf-8").splitlines()[0]
        assert first.startswith(MODELINE), path
        assert (path.parent / first.removeprefix(MODELINE)).resolve() == schema_file
        try:
            jsonschema: Any = importlib.import_module("jsonschema")
        except ImportError:  # pragma: no cover - jsonschema is in the dev extra
            continue
        jsonschema.Draft202012Validator(schema).validate(
            yaml.safe_load(path.read_text(encoding="utf-8")))


@pytest.mark.parametrize("block", [b for b in BLOCKS if b.lang == "python" and "file" in b.attrs],
                         ids=lambda b: b.attrs["file"])
def test_tutorial_python_compiles(block: Block) -> None:
    compile(block.text, block.attrs["file"], "exec")
