"""Reports: self-contained HTML, Markdown for pull requests, JUnit XML, summary JSON."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from kartci.atomic import write_json_atomic, write_text_atomic
from kartci.report.tables import COMPARE, RUN, Wording
from kartci.runner.outdir import FILES
from kartci.verdict.result import ScenarioResult, exit_code

if TYPE_CHECKING:
    from kartci.report.html import report_html
    from kartci.report.junit import junit_xml
    from kartci.report.markdown import summary_md


def __getattr__(name: str) -> Any:
    """The writers load on first use (report_html brings the figures), so a
    command that prints a table starts fast."""
    if name == "report_html":
        from kartci.report.html import report_html  # start-up: the figures, on first use
        return report_html
    if name == "junit_xml":
        from kartci.report.junit import junit_xml  # start-up, as report_html
        return junit_xml
    if name == "summary_md":
        from kartci.report.markdown import summary_md  # start-up, as report_html
        return summary_md
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def summary_json(results: list[ScenarioResult]) -> dict[str, Any]:
    """summary.json: the exit code and, per scenario, its status, metric verdicts, criteria,
    problems and warnings."""
    return {
        "exit_code": exit_code(results),
        "scenarios": {
            r.name: {
                "status": r.status.value,
                "error": r.error,
                "metrics": {v.name: {"value": v.value, "unit": v.unit, "baseline": v.baseline,
                                     "tolerance": v.tolerance, "direction": v.direction.value,
                                     "spread": v.spread, "conditioning": v.conditioning.value,
                                     "status": v.status.value} for v in r.verdicts},
                "criteria": {c.name: {"bound": c.bound, "value": c.value, "ok": c.ok}
                             for c in r.criteria},
                "criteria_changes": [{"name": c.name, "change": c.kind.value, "before": c.before,
                                      "after": c.after} for c in r.criteria_changes],
                "problems": list(r.problems),
                "warnings": list(r.warnings),
            } for r in results
        },
    }


def _history(results: list[ScenarioResult], folder: Path | None) -> tuple[list[str], Any] | None:
    """Earlier commits' summaries in `folder` (sorted by name, oldest first) and this run; None
    when there are none (no folder yet: the first run on main)."""
    from kartci.report.history import collect, load_summary  # start-up: pandas, when drawn

    earlier = sorted(folder.glob("*.json")) if folder is not None and folder.is_dir() else []
    if not earlier:
        return None
    return collect([*((p.stem, load_summary(p)) for p in earlier),
                    ("this run", summary_json(results))])


def write_all(results: list[ScenarioResult], out: Path, words: Wording = RUN,
              history: Path | None = None, html: bool = True,
              static: bool = True) -> dict[str, Path]:
    """report.html (interactive), report-static.html (SVG, no script), summary.md, summary.json
    and junit.xml in `out` (without `html`: no HTML, whose figures are most of the time a
    scored log's reports take; without `static`: no report-static.html, whose matplotlib is
    most of the rest). The old ones are removed
    first: a report that fails half-way leaves some missing, never an earlier one standing."""
    out.mkdir(parents=True, exist_ok=True)
    paths = {key: out / name for key, name in FILES.items()}
    for path in paths.values():
        path.unlink(missing_ok=True)
    # start-up: the writers (the figures; matplotlib for the static page) load when written
    from kartci.report.junit import junit_xml
    from kartci.report.markdown import summary_md

    if html:
        from kartci.report.html import report_html  # start-up: the figures, HTML only

        write_text_atomic(paths["html"], report_html(results, words,
                                                     history=_history(results, history),
                                                     static_page=static))
        if static:
            write_text_atomic(paths["static"], report_html(results, words, static=True))
    write_text_atomic(paths["markdown"], summary_md(results, words))
    write_json_atomic(paths["json"], summary_json(results))
    main = paths["html" if html else "markdown"]
    write_text_atomic(paths["junit"], junit_xml(results, str(main), words))
    return paths


__all__ = ["COMPARE", "FILES", "RUN", "Wording", "junit_xml", "report_html", "summary_json",
           "summary_md", "write_all"]
