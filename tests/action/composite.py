"""A composite action's steps, run here as GitHub runs them, as far as a test can: inputs with
their defaults, `${{ }}` expressions (contexts, literals, ==, !=, &&, ||, !, the status
functions), each `run:` step in bash -e -o pipefail with its `env:`, and step outputs through
$GITHUB_OUTPUT. Other actions are not run: setup-python is this interpreter, download-artifact
and upload-artifact are a plain hand-over of files in one folder (each upload is recorded), and
every other action's `with:` is recorded, expanded (the cache keys)."""

from __future__ import annotations

import os
import re
import subprocess
import tempfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

TOKEN = re.compile(r"\s+|'[^']*'|[A-Za-z_][\w.-]*(?:\(\))?|==|!=|&&|\|\||!|\(|\)")
STATUS = ("success()", "failure()", "cancelled()", "always()")


def evaluate(expr: str, ctx: Mapping[str, str], failed: bool = False) -> Any:
    """The value of a GitHub expression over `ctx` (dotted names; missing ones are '')."""
    out, pos = [], 0
    for m in TOKEN.finditer(expr):
        assert m.start() == pos, f"expression not emulated: {expr!r} at {pos}"
        pos = m.end()
        tok = m.group(0)
        if tok.isspace():
            continue
        if tok.startswith("'"):
            out.append(repr(tok[1:-1]))
        elif tok in STATUS:
            out.append(repr({"success()": not failed, "failure()": failed,
                             "cancelled()": False, "always()": True}[tok]))
        elif tok in ("true", "false"):
            out.append(repr(tok == "true"))
        elif re.fullmatch(r"[A-Za-z_][\w.-]*", tok):
            out.append(repr(ctx.get(tok, "")))
        else:
            out.append({"&&": " and ", "||": " or ", "!": " not "}.get(tok, tok))
    assert pos == len(expr), f"expression not emulated: {expr!r}"
    return eval("".join(out), {"__builtins__": {}})  # only the tokens checked above


def expand(text: str, ctx: Mapping[str, str]) -> str:
    """`${{ expr }}` in a string, each replaced by its value (booleans as true / false)."""
    def one(m: re.Match[str]) -> str:
        value = evaluate(m.group(1), ctx)
        return str(value).lower() if isinstance(value, bool) else str(value)

    return re.sub(r"\$\{\{\s*(.*?)\s*\}\}", one, text)


def runs(step: Mapping[str, Any], ctx: Mapping[str, str], failed: bool) -> bool:
    """Whether a step runs: its `if:` (with `${{ }}` or bare), `success() &&` implied unless
    it names a status function."""
    cond = str(step.get("if", "")).strip()
    if cond.startswith("${{"):
        cond = cond[3:-2].strip()
    if not cond:
        return not failed
    value = bool(evaluate(cond, ctx, failed))
    return value if any(s in cond for s in STATUS) else value and not failed


@dataclass
class Ran:
    """What one run of the action did."""

    steps: list[str] = field(default_factory=list)  # names (run) or action (uses), in order
    uploads: list[tuple[str, str]] = field(default_factory=list)  # (artifact name, path)
    uses: list[tuple[str, dict[str, str]]] = field(default_factory=list)  # (action, with:)
    outputs: dict[str, str] = field(default_factory=dict)  # the action's outputs
    code: int = 0  # the failed run step's exit code (0: none failed)
    stdout: str = ""


def run_action(action: Mapping[str, Any], with_: Mapping[str, str], github: Mapping[str, str],
               cwd: Path, env: Mapping[str, str],
               skip: Callable[[str], bool] = lambda name: False,
               contexts: Mapping[str, str] | None = None) -> Ran:
    """Run a composite action's steps in `cwd` as one job does; `with_` are its inputs (already
    expanded), `github` the github.* context, `contexts` other values by their dotted names
    (`strategy.job-index`, `runner.os`). A `run:` step named so that `skip(name)` is true is
    not run (an install the test environment already did)."""
    ctx: dict[str, str] = {**(contexts or {}), **{f"github.{k}": v for k, v in github.items()}}
    for name, spec in action["inputs"].items():
        ctx[f"inputs.{name}"] = expand(str(with_.get(name, spec.get("default", ""))), ctx)
    ran, failed = Ran(), False
    for step in action["runs"]["steps"]:
        if not runs(step, ctx, failed):
            continue
        uses = str(step.get("uses", "")).split("@")[0]
        if uses:
            ran.steps.append(uses)
            w = {k: expand(str(v), ctx) for k, v in step.get("with", {}).items()}
            ran.uses.append((uses, w))
            if uses == "actions/upload-artifact":
                assert not (w.get("if-no-files-found") == "error"
                            and not (cwd / w["path"]).exists()), w
                ran.uploads.append((w["name"], w["path"]))
            continue
        ran.steps.append(step["name"])
        if skip(step["name"]):
            continue
        code = _run_step(step, ctx, cwd, env, ran)
        if code:
            failed, ran.code = True, code
    ran.outputs = {k: expand(str(v["value"]), ctx) for k, v in action.get("outputs", {}).items()}
    return ran


def _run_step(step: Mapping[str, Any], ctx: dict[str, str], cwd: Path, env: Mapping[str, str],
              ran: Ran) -> int:
    assert step["shell"] == "bash" and "${{" not in step["run"], step["name"]
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "output"
        out.touch()
        step_env = {**env, "GITHUB_OUTPUT": str(out), "RUNNER_TEMP": tmp,
                    **{k: expand(str(v), ctx) for k, v in step.get("env", {}).items()}}
        p = subprocess.run(["bash", "--noprofile", "--norc", "-e", "-o", "pipefail", "-c",
                            step["run"]], cwd=cwd, env=step_env, capture_output=True, text=True,
                           timeout=600)
        ran.stdout += p.stdout + p.stderr
        for line in out.read_text().splitlines():
            key, _, value = line.partition("=")
            if "id" in step:
                ctx[f"steps.{step['id']}.outputs.{key}"] = value
    return p.returncode


def with_values(step: Mapping[str, Any], ctx: Mapping[str, str]) -> dict[str, str]:
    """A workflow step's `with:` for the action, expressions filled in from `ctx`."""
    return {k: expand(str(v), ctx) for k, v in step.get("with", {}).items()}


def environ(extra: Mapping[str, str] | None = None) -> dict[str, str]:
    """This process's environment plus `extra`."""
    return {**os.environ, **(extra or {})}
