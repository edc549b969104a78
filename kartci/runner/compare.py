"""`kartci compare BASE_OUT HEAD_OUT`: two run folders, scenario by scenario, as results the
reports render (value = head, baseline = base; plots of both runs overlaid)."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

from kartci.core import RunFolder
from kartci.errors import SpecError
from kartci.plotting import overlay
from kartci.project import Project
from kartci.runner.jobs import REPEAT_PREFIX
from kartci.runner.outdir import check_inside
from kartci.runner.run import evaluate, scenario_folders
from kartci.verdict import load
from kartci.verdict.result import ScenarioResult
from kartci.verdict.runs import ALPHA, Samples, compare_runs


def samples(folder: RunFolder) -> Samples:
    """The judged run's metrics plus those of its repeats (`repeat_<k>/metrics.json`)."""
    repeats = sorted((RunFolder(p.parent) for p in
                      folder.path.glob(f"{REPEAT_PREFIX}*/{RunFolder.METRICS_NAME}")),
                     key=lambda r: int(re.sub(r"\D", "", r.name) or 0))
    out: Samples = {}
    for run in [folder, *repeats]:
        for name, m in run.read_metrics().items():
            entry = out.setdefault(name, {"unit": str(m.get("unit", "")), "values": []})
            entry["values"].append(m.get("value"))
    return out


def compare_outs(base_out: Path, head_out: Path, baselines: Path, proj: Project,
                 alpha: float = ALPHA) -> list[ScenarioResult]:
    """Head judged against base. Both must hold scored scenarios: an empty or unscorable side
    is bad input (exit 2), and a side whose run failed is an error for that scenario."""
    for d in (base_out, head_out):
        if not d.is_dir():
            raise SpecError(f"{d}: no such folder")
    base = {p.name: p for p in scenario_folders(base_out)}
    head = {p.name: p for p in scenario_folders(head_out)}
    for side, d, found in (("base", base_out, base), ("head", head_out, head)):
        check_inside(d, found)  # judging marks a bad folder: never through a symlink
        if not found:  # else every metric of the other side would be NEW, and pass
            logged = any(d.glob(f"*/{RunFolder.LOG_NAME}"))
            hint = (f"run `kartci report {d}` to score its logs" if logged
                    else "run `kartci run` first")
            raise SpecError(f"{side} {d}: no scored scenario folders; {hint}")
    return [_one(label, base.get(label), head.get(label), baselines, proj, alpha)
            for label in sorted(set(base) | set(head))]


def _one(label: str, b: RunFolder | None, h: RunFolder | None, baselines: Path, proj: Project,
         alpha: float) -> ScenarioResult:
    """A scenario in one run only: its metrics are all NEW (head) or MISSING (base)."""
    hr = evaluate(h, baselines, proj) if h is not None else None
    br = evaluate(b, baselines, proj) if b is not None else None
    for side, r in (("head", hr), ("base", br)):
        if r is not None and r.error:
            return ScenarioResult(label, r.description, error=f"{side}: {r.error}")
    for side, folder in (("head", h), ("base", b)):
        for rep in sorted(folder.path.glob(f"{REPEAT_PREFIX}*")) if folder else []:
            reason = RunFolder(rep).failed_reason()
            if reason is not None:  # its stale metrics must not count as a sample
                return ScenarioResult(label, "", error=f"{side}: {rep.name}: {reason}")
    verdicts = compare_runs(samples(b) if b else {}, samples(h) if h else {},
                            load(baselines / f"{label}.json"), alpha)
    first = hr or br
    assert first is not None
    plots = overlay(br.plots if br else None, hr.plots if hr else None)
    note = "" if hr and br else f" (only in {'head' if hr else 'base'})"
    return replace(first, description=first.description + note, verdicts=verdicts,
                   criteria=[], plots=plots)
