"""CI outputs: the GitHub job summary and `::error` / `::warning` annotations.

GitHub shows at most 1 MiB of summary per step and 10 annotations of each kind per step, so
both put the worst news first and say what they left out.
"""

from __future__ import annotations

import os
from pathlib import Path

from kartci.errors import KartciError
from kartci.project import Project
from kartci.report.tables import delta, num, regression_size
from kartci.verdict import Status
from kartci.verdict.result import ScenarioResult

SUMMARY_LIMIT_BYTES = 1_000_000  # under GitHub's 1 MiB per step, with room for the note
MAX_ANNOTATIONS = 10


def truncate(markdown: str, limit: int = SUMMARY_LIMIT_BYTES) -> str:
    """Whole lines up to `limit` bytes, then a note of how many lines were cut."""
    data = markdown.encode("utf-8")
    if len(data) <= limit:
        return markdown
    lines = markdown.splitlines(keepends=True)
    kept, size = [], 0
    for line in lines:
        size += len(line.encode("utf-8"))
        if size > limit - 200:
            break
        kept.append(line)
    note = (f"\n> Truncated: {len(lines) - len(kept)} more lines; the full summary is "
            "summary.md in the report artifact.\n")
    return "".join(kept) + note


def append_step_summary(markdown: str) -> Path | None:
    """Append to $GITHUB_STEP_SUMMARY when it is set (GitHub Actions)."""
    path = os.environ.get("GITHUB_STEP_SUMMARY")
    if not path:
        return None
    with Path(path).open("a", encoding="utf-8") as f:
        f.write(truncate(markdown))
    return Path(path)


def _escape(text: str, prop: bool = False) -> str:
    text = text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")
    return text.replace(":", "%3A").replace(",", "%2C") if prop else text


def scenario_files(results: list[ScenarioResult], proj: Project, root: Path | None = None
                   ) -> dict[str, str]:
    """Each scenario's YAML file (found by name in `proj`) relative to `root` (the repository:
    $GITHUB_WORKSPACE, else the working directory), for annotations anchored to it; a scenario
    found elsewhere (installed with kartci) or not at all gets none."""
    base = (root or Path(os.environ.get("GITHUB_WORKSPACE") or Path.cwd())).resolve()
    out = {}
    for r in results:
        try:
            path = proj.find_scenario(r.name.split("@", 1)[0]).resolve()
        except KartciError:
            continue
        if path.is_relative_to(base):
            out[r.name] = path.relative_to(base).as_posix()
    return out


def annotation_lines(results: list[ScenarioResult], limit: int = MAX_ANNOTATIONS,
                     files: dict[str, str] | None = None) -> list[str]:
    """Workflow commands for errors, failed criteria, regressions (::error) and missing
    metrics (::warning), largest first, each anchored to its scenario's file when `files` names
    it; past `limit`, one plain line says how many more."""
    where = files or {}
    items: list[tuple[float, str, str, str]] = []  # (-size, kind, title, message)
    for r in results:
        if r.error:
            items.append((-float("inf"), "error", f"kartci {r.name}: error", r.error))
            continue
        for problem in r.problems:
            items.append((-1e300, "error", f"kartci {r.name}: failed", problem))
        for c in r.criteria:
            if not c.ok:
                items.append((-1e300, "error", f"kartci {r.name}: criterion failed",
                               f"{c.name} {c.bound}: got {num(c.value)}"))
        for v in r.verdicts:
            if v.status in (Status.REGRESSED, Status.MISSING):
                kind = "error" if v.status is Status.REGRESSED else "warning"
                items.append((-regression_size(v), kind, f"kartci {r.name}: {v.name} "
                              f"{v.status.value}", f"{v.name}: {num(v.value, v.unit)} vs "
                              f"{num(v.baseline, v.unit)} (delta {delta(v)}, tolerance "
                              f"{num(v.tolerance)})"))
    items.sort(key=lambda x: x[0])
    lines = [f"::{kind} {_anchor(where, title)}title={_escape(title, True)}::{_escape(msg)}"
             for _, kind, title, msg in items[:limit]]
    if len(items) > limit:
        lines.append(f"kartci: {len(items) - limit} more problems not annotated; see the job "
                     "summary or report.html")
    return lines


def _anchor(files: dict[str, str], title: str) -> str:
    """`file=...,line=1,` for the scenario a title names (titles start `kartci <name>:`)."""
    name = title.removeprefix("kartci ").split(":", 1)[0]
    path = files.get(name)
    return f"file={_escape(path, True)},line=1," if path else ""


def in_github_actions() -> bool:
    """True inside a GitHub Actions job (GITHUB_ACTIONS=true)."""
    return os.environ.get("GITHUB_ACTIONS") == "true"
