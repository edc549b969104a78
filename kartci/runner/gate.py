"""Strict baselines: in CI, a scenario without a baseline, a metric its baseline lacks, a
baseline accepted from another scenario (stale) or a tolerance loosened beyond the policy is a
failure, not a quiet NEW or a warning that lets anything through."""

from __future__ import annotations

import os
import shlex
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

from kartci.errors import RunError
from kartci.verdict import Status
from kartci.verdict.result import ScenarioResult

NOT_JUDGED = "selected but never judged (strict mode: a run that judged fewer scenarios than it " \
    "selected never passes)"


def strict_default() -> bool:
    """Strict when running in CI (`CI` set, as CI services do) unless told otherwise."""
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def require_baselines(result: ScenarioResult, out: Path, baselines: Path) -> ScenarioResult:
    """The result with a problem for every metric judged NEW, saying how to accept it, and its
    strict warnings (a stale baseline, a loosened tolerance) made problems."""
    if result.error is not None:
        return result
    if result.strict_warnings:
        result = replace(result, problems=(*result.problems, *result.strict_warnings),
                         warnings=tuple(w for w in result.warnings
                                        if w not in result.strict_warnings), strict_warnings=())
    new = [v.name for v in result.verdicts if v.status is Status.NEW]
    path = baselines / f"{result.name}.json"
    has_file = path.exists() or path.is_symlink()
    if not new and (has_file or not result.verdicts):
        return result
    accept = (f"accept this run's values with `kartci baseline update {shlex.quote(str(out))} "
              f"{shlex.quote(result.name)}`")
    if not has_file:
        problem = f"no baseline {path} (strict mode); {accept}"
    else:
        problem = f"not in the baseline (strict mode): {', '.join(new)}; {accept}"
    return replace(result, problems=(*result.problems, problem))


Complete = Callable[[list[ScenarioResult]], list[ScenarioResult]]


@contextmanager
def judging_all(selected: Sequence[str], strict: bool) -> Iterator[Complete]:
    """The invariant of a strict (CI) run: it never exits 0 having judged fewer scenarios than
    it selected, whatever cut it short. The enclosed work passes its results through the
    yielded function, which adds an ERROR result for every selected label left without one;
    a `SystemExit` that would end the command green (code 0 or None: a plugin's `sys.exit()`)
    becomes a RunError (exit 2). Outside strict mode both pass through unchanged."""
    def complete(results: list[ScenarioResult]) -> list[ScenarioResult]:
        if not strict:
            return results
        have = {r.name for r in results}
        return [*results, *(ScenarioResult(label, "", error=NOT_JUDGED)
                             for label in dict.fromkeys(selected) if label not in have)]

    try:
        yield complete
    except SystemExit as err:
        if not strict or err.code not in (0, None):
            raise
        raise RunError(f"the run ended early (SystemExit({err.code!r}) inside it) with "
                       f"{len(selected)} selected scenario(s) not all judged; in strict mode "
                       "(as under CI) that never passes") from err
