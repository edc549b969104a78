"""Judging one run folder: its metrics against its baseline and its scenario's criteria, with
every warning a reader must see. The one judging path of `kartci run` (the runner, in each
worker) and of the Python API (`kartci.run`, the pytest plugin)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from enum import StrEnum
from typing import Any

from kartci import portable
from kartci.core import Metric, RunFolder, definitions
from kartci.errors import SpecError, did_you_mean, one_line
from kartci.project import Project
from kartci.scenario.models import Scenario
from kartci.verdict import criteria, fingerprint
from kartci.verdict.baseline import (
    Baseline,
    MetricVerdict,
    apply_tolerance_policy,
    check_criteria,
    compare,
    ill_conditioned,
    loose_tolerance_messages,
    read_baseline,
    read_json,
)
from kartci.verdict.result import ScenarioResult

UNPINNED = ("this Python process was not started pinned (numpy or the process came before "
            "`import kartci`) and agent objects run here: last bits may differ from `kartci run`; "
            "see kartci.portable")


class Stale(StrEnum):
    """What judging does with a baseline accepted from another scenario than the one that ran
    (kartci.verdict.fingerprint)."""

    # judge against it, say it is stale, fail a strict run: `kartci run`, where the scenario
    # changed under its baseline and the gate must notice (issue 24)
    WARN = "warn"
    # do not compare: every metric NEW, "no comparable baseline": the Python API, whose
    # overrides and agent objects make another scenario on purpose (issue 29)
    SKIP = "skip"


def judge_folder(folder: RunFolder, scenario: Scenario, baseline: Baseline | None,
                 proj: Project, stale: Stale = Stale.WARN) -> ScenarioResult:
    """The result of the complete run in `folder` (made from `scenario`), judged against
    `baseline` (None: the scenario has none) by `proj`'s tolerance policy. Raises KartciError
    for an unreadable metrics file or run record."""
    values = folder.read_metrics()
    record = folder.read_run_record()
    replaced = {str(k): str(v) for k, v in (record.get("replaced_agents") or {}).items()}
    baseline, check, notes = _comparable(baseline, fingerprint.fields(scenario, proj, replaced),
                                         fingerprint.defaulted(scenario), stale)
    verdicts, doubts, strict = trusted(compare(values, None if baseline is None
                                               else baseline.metrics), baseline, check, proj)
    platform = record.get("platform") or {}
    warnings = [str(w) for w in record.get("warnings") or [] if isinstance(w, str)]
    made_on = None if baseline is None else baseline.provenance.get("platform")
    note = portable.mismatch(made_on, platform) if made_on else None
    warnings += [note] if note else []
    warnings += ill_conditioned(verdicts)
    warnings += [UNPINNED] if platform.get("simd") == portable.Pin.UNPINNED.value else []
    moved = criteria.changes(None if baseline is None else baseline.doc, scenario.criteria)
    warnings += [c.text() for c in moved]
    strict += [c.text() for c in moved if c.kind is criteria.ChangeKind.REMOVED]
    return ScenarioResult(
        folder.name, scenario.description, verdicts, check_criteria(values, scenario.criteria),
        None, record, warnings=tuple(one_line(w) for w in [*warnings, *notes, *doubts]),
        strict_warnings=tuple(one_line(w) for w in strict), criteria_changes=tuple(moved),
        scenario=scenario,
        folder=folder.path, metrics=read_all_metrics(folder),
        baseline=None if baseline is None else baseline.path)


def _comparable(baseline: Baseline | None, fields: Mapping[str, Any], defaults: frozenset[str],
                stale: Stale) -> tuple[Baseline | None, fingerprint.Check | None, list[str]]:
    """The baseline to judge against (None: none, or not comparable), its recorded scenario
    checked against `fields` (the scenario that ran), and why it is not compared."""
    if baseline is None:
        return None, None, []
    check = fingerprint.check(baseline.doc, fields, defaults)
    if check.freshness is fingerprint.Freshness.STALE and stale is Stale.SKIP:
        return None, None, [not_comparable(baseline, check)]
    return baseline, check, []


def not_comparable(baseline: Baseline, check: fingerprint.Check) -> str:
    """Why a baseline made from another scenario is not compared, and what to do instead."""
    names = ", ".join(check.fields[:fingerprint.SHOWN]) or "not recorded"
    more = (f" and {len(check.fields) - fingerprint.SHOWN} more"
            if len(check.fields) > fingerprint.SHOWN else "")
    return (f"no comparable baseline: {baseline.path.name} was accepted from another scenario "
            f"(fields: {names}{more}), so its metrics are not compared (verdicts new); compare "
            "two runs instead (kartci.compare(base, head)), or accept this one "
            "(kartci.accept_baselines(result))")


def trusted(verdicts: list[MetricVerdict], baseline: Baseline | None,
            check: fingerprint.Check | None, proj: Project
            ) -> tuple[list[MetricVerdict], list[str], list[str]]:
    """How far `baseline` can be trusted (`check`: its recorded scenario against the one that
    ran): the verdicts with each stored tolerance checked against the policy bound, the warnings
    a reader must see, and those of them a strict run fails on (a stale baseline, a loosened
    tolerance not allowed by the project's configuration)."""
    if baseline is None or check is None:
        return verdicts, [], []
    label = baseline.path.stem
    allowed = dict(proj.allow_loose_tolerances)  # "scenario:metric" -> reason
    kept = {name for name in baseline.metrics if f"{label}:{name}" in allowed}
    verdicts = apply_tolerance_policy(verdicts, baseline.metrics, proj.loosen_factor, kept)
    loose = loose_tolerance_messages(verdicts, label, proj.loosen_factor)
    note = check.message(baseline.path)
    stale = [] if note is None else [note]
    strict = [*(stale if check.freshness is fingerprint.Freshness.STALE else []), *loose]
    return verdicts, [*stale, *loose], strict


def read_all_metrics(folder: RunFolder) -> dict[str, Metric]:
    """Every metric of metrics.json, the deterministic and the timing ones, by name."""
    doc = read_json(folder.metrics)
    return {name: _metric(name, m) for part in ("metrics", "timing")
            for name, m in (doc.get(part) or {}).items() if isinstance(m, Mapping)}


def _metric(name: str, entry: Mapping[str, Any]) -> Metric:
    value = entry.get("value")
    extra = {k: v for k, v in entry.items() if k not in ("value", "unit")}
    return Metric(name, math.nan if value is None else float(value), str(entry.get("unit", "")),
                  extra)


def check_allowed(proj: Project) -> None:
    """Every `[tool.kartci.allow_loose_tolerances]` entry names a scenario (or a sweep point
    or another baseline file of the project) and a metric kartci knows: a misspelt entry
    allows nothing, and a strict run then fails on the tolerance it meant to allow, for a
    reason nobody sees. SpecError (one line, with the nearest name) on the first bad entry.
    Called by each command that judges, before it runs or writes anything."""
    if not proj.allow_loose_tolerances:
        return
    scenarios = set(proj.all_scenarios())
    labels = {p.stem for p in proj.baselines.glob("*.json")} if proj.baselines.is_dir() else set()
    defs = definitions()
    where = (f"{proj.config_file}: " if proj.config_file else "") + \
        "[tool.kartci.allow_loose_tolerances]"
    for key, _reason in proj.allow_loose_tolerances:
        label, _, name = key.partition(":")
        shown = one_line(key)[:80]
        if label not in labels and label.partition("@")[0] not in scenarios:
            raise SpecError(f'{where} "{shown}": no scenario or baseline named '
                            f'"{one_line(label)[:60]}"{did_you_mean(label, scenarios | labels)}')
        baseline = read_baseline(proj.baselines / f"{label}.json") if label in labels else None
        stored = set(baseline.metrics) if baseline is not None else set()
        if name not in defs and name.rpartition(".")[2] not in defs and name not in stored:
            raise SpecError(f'{where} "{shown}": no metric named "{one_line(name)[:60]}"'
                            f"{did_you_mean(name, set(defs) | stored)}")
