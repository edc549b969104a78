"""The scenario a baseline was accepted from, so that a run of a changed scenario is told its
baseline is stale instead of passing as "improved".

A baseline stores the resolved scenario as a flat map `dotted.field -> value` and the hash of
that map. Flat values rather than value hashes: the keys are most of the size either way, a
pull request's diff of the baseline then shows which fields were accepted with which values,
and a stale run can name the fields that moved. A data file a field names (a track CSV, a URDF,
a replayed log) adds a `FIELD#sha256` entry with the hash of its bytes, so that editing the
file in place makes the baseline stale as editing the scenario does.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Collection, Mapping
from contextlib import suppress
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from kartci.boundedio import open_regular
from kartci.project import BUILTIN, Project
from kartci.scenario.models import Scenario

# what neither the run nor its metrics depend on: criteria are checked from the run's own
# scenario on every run, a sweep only lists the other points (each point is its own scenario)
IGNORED = ("description", "criteria", "tags", "sweep")
SHOWN = 8  # changed fields named in one warning line


class Freshness(StrEnum):
    """Whether a baseline was accepted from the scenario that ran."""

    CURRENT = "current"
    STALE = "stale"  # the scenario changed since: fails a strict run
    UNHASHED = "unhashed"  # accepted before baselines recorded their scenario: a warning


def fields(scenario: Scenario, proj: Project, replaced: Mapping[str, str] | None = None
           ) -> dict[str, Any]:
    """The scenario as `kartci show` prints it (world and model files inlined), flat, with data
    file paths relative to the world, model or scenario folder they were found in (else to the
    project, or `<kartci>/...` for kartci's data), so the same scenario gives the same fields on
    every machine and checkout, and when a data folder moves; the file's bytes are hashed
    beside its path. `replaced`: agents driven by an object handed to the Python API (agent
    name -> class), as `replaced_agents.NAME`: their controller is not the scenario's. `proj`:
    the project whose folders the paths are made relative to."""
    folders = (*proj.world_path, *proj.model_path, *proj.scenario_path)  # the most specific first
    roots = (*(("", f) for f in folders), ("", proj.root), ("<kartci>", BUILTIN))
    out: dict[str, Any] = {}
    dumped = scenario.model_dump(mode="json")
    _flatten({k: v for k, v in dumped.items() if k not in IGNORED}, "", out, roots)
    files = {f"{k}#sha256": content_hash(Path(v)) for k, v in _flat_raw(dumped)
             if isinstance(v, str) and Path(v).is_absolute()}
    out.update({k: v for k, v in files.items() if v is not None})
    out.update({f"replaced_agents.{name}": cls for name, cls in (replaced or {}).items()})
    return dict(sorted(out.items()))


def _flat_raw(node: Any, prefix: str = "") -> list[tuple[str, Any]]:
    """(dotted key, value) of every leaf, values as dumped (absolute paths kept)."""
    if isinstance(node, dict) and node:
        return [kv for key, value in node.items() if not (not prefix and key in IGNORED)
                for kv in _flat_raw(value, f"{prefix}.{key}" if prefix else str(key))]
    return [(prefix, node)]


def content_hash(path: Path) -> str | None:
    """sha256 of a regular file's bytes; None for anything else (a folder, a missing file: the
    path field itself still records it)."""
    try:
        fd = open_regular(path, None)
    except (OSError, ValueError):
        return None
    with os.fdopen(fd, "rb") as f:
        return "sha256:" + hashlib.file_digest(f, "sha256").hexdigest()


def _flatten(node: Any, prefix: str, out: dict[str, Any],
             roots: tuple[tuple[str, Path], ...]) -> None:
    if isinstance(node, dict) and node:
        for key, value in node.items():
            _flatten(value, f"{prefix}.{key}" if prefix else str(key), out, roots)
    else:
        out[prefix] = _portable(node, roots)


def _portable(value: Any, roots: tuple[tuple[str, Path], ...]) -> Any:
    """A JSON value as stored: non-finite floats as text (baselines hold no NaN), absolute paths
    under a root relative to it."""
    if isinstance(value, float) and not math.isfinite(value):
        return repr(value)
    if isinstance(value, list):
        return [_portable(v, roots) for v in value]
    if isinstance(value, dict):
        return {k: _portable(v, roots) for k, v in value.items()}
    if isinstance(value, str) and Path(value).is_absolute():
        for prefix, root in roots:
            with suppress(ValueError):
                rel = Path(value).relative_to(root).as_posix()
                return f"{prefix}/{rel}" if prefix else rel
    return value


def digest(flat: Mapping[str, Any]) -> str:
    """The fields' hash: canonical JSON (sorted keys, floats as repr), the same in every
    process and on every machine."""
    text = json.dumps(flat, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return "sha256:" + hashlib.sha256(text.encode("ascii")).hexdigest()


def recorded(doc: Any) -> tuple[str | None, dict[str, Any]]:
    """The scenario hash and fields a baseline document holds (None and {} when absent)."""
    if not isinstance(doc, dict):
        return None, {}
    found = doc.get("scenario_hash")
    flat = doc.get("scenario_fields")
    return (found if isinstance(found, str) else None), (flat if isinstance(flat, dict) else {})


def changed(old: Mapping[str, Any], new: Mapping[str, Any]) -> list[str]:
    """The fields that differ, were added or were removed, sorted."""
    return sorted(k for k in {*old, *new} if k not in old or k not in new or old[k] != new[k])


@dataclass(frozen=True)
class Check:
    """A baseline's recorded scenario against the scenario that ran."""

    freshness: Freshness
    fields: tuple[str, ...] = ()  # the fields that changed (STALE)

    def message(self, baseline: Path) -> str | None:
        """The warning line, or None when the baseline is current."""
        if self.freshness is Freshness.UNHASHED:
            return (f"no scenario hash recorded in baseline {baseline.name}: a changed scenario "
                    "would pass unnoticed; `kartci baseline update` records it")
        if self.freshness is Freshness.CURRENT:
            return None
        names = ", ".join(self.fields[:SHOWN]) or "not recorded"
        more = f" and {len(self.fields) - SHOWN} more" if len(self.fields) > SHOWN else ""
        return (f"baseline is stale: scenario changed since it was accepted (fields: {names}"
                f"{more}); run it as accepted, or accept the change with `kartci baseline "
                "update`")


def defaulted(scenario: Scenario) -> frozenset[str]:
    """The flat fields at their parameter's declared default. A parameter added to kartci after
    a baseline was accepted appears there at its default, which by kartci's contract reproduces
    the old behaviour (the shipped scenarios' metrics stay byte-identical): it does not make the
    baseline stale."""
    out: set[str] = set()
    _defaults(scenario, "", out)
    return frozenset(out)


def _defaults(node: Any, prefix: str, out: set[str]) -> None:
    if isinstance(node, dict):
        for key, value in node.items():
            _defaults(value, f"{prefix}.{key}" if prefix else str(key), out)
    elif isinstance(node, BaseModel):
        for name, info in type(node).model_fields.items():
            value, key = getattr(node, name), f"{prefix}.{name}" if prefix else name
            if isinstance(value, (BaseModel, dict)):
                _defaults(value, key, out)
            elif not info.is_required() and _same(value, info.get_default(
                    call_default_factory=True)):
                out.add(key)


def _same(a: Any, b: Any) -> bool:
    try:
        return bool(type(a) is type(b) and a == b)
    except ValueError:  # an array's truth value
        return False


def check(doc: Any, flat: Mapping[str, Any], defaults: Collection[str] = frozenset()
          ) -> Check:
    """A baseline document's recorded scenario against the fields of the one that ran;
    `defaults` (`defaulted`): fields at their declared default, which may be new since."""
    found, old = recorded(doc)
    if found is None:
        return Check(Freshness.UNHASHED)
    if found == digest(flat):
        return Check(Freshness.CURRENT)
    moved = [k for k in changed(old, flat) if not (k not in old and k in defaults)]
    return Check(Freshness.STALE, tuple(moved)) if moved or not old else Check(
        Freshness.CURRENT)
