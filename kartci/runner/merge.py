"""Partial results of `kartci run --shard I/N` and joining them with `kartci merge`.

A shard writes its scenario folders into its OUT plus `shard.json` (which share it had and
which labels that share held), written before anything runs: a shard that died early is then
still seen as missing, not silently skipped.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from kartci.errors import SpecError
from kartci.results import ScenarioResult
from kartci.runner.run import evaluate, scenario_folders
from kartci.verdict import read_json, write_json_atomic

SHARD_NAME = "shard.json"


def write_marker(out: Path, index: int | None, total: int | None, labels: list[str]) -> None:
    """Mark OUT as shard `index` of `total` (or clear an old mark for a whole run)."""
    if index is None or total is None:
        (out / SHARD_NAME).unlink(missing_ok=True)
        return
    write_json_atomic(out / SHARD_NAME, {"index": index, "total": total,
                                         "scenarios": sorted(labels)})


def _shard_of(folder: Path) -> tuple[int, int, list[str]] | None:
    path = folder / SHARD_NAME
    if not path.exists():
        return None
    try:
        doc = read_json(path)
        index, total, labels = int(doc["index"]), int(doc["total"]), list(doc["scenarios"])
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise SpecError(f"{path}: malformed shard marker ({err})") from None
    return index, total, [str(x) for x in labels]


def _sources(dirs: list[Path]) -> dict[str, Path | None]:
    """label -> its folder in one of `dirs` (None: a shard listed it but has no folder)."""
    found: dict[str, Path | None] = {}
    shards: dict[int, int] = {}
    for d in dirs:
        if not d.is_dir():
            raise SpecError(f"{d}: no such folder")
        marker = _shard_of(d)
        if marker is None:
            labels = [p.name for p in scenario_folders(d)]
        else:
            index, total, labels = marker
            if index in shards:
                raise SpecError(f"{d}: shard {index}/{total} given twice")
            shards[index] = total
        for label in labels:
            if label in found:
                raise SpecError(f"{label}: in more than one of the folders to merge")
            found[label] = d / label if (d / label).is_dir() else None
    totals = set(shards.values())
    if len(totals) > 1:
        raise SpecError(f"shards of different splits: /{' /'.join(map(str, sorted(totals)))}")
    missing = sorted(set(range(1, next(iter(totals), 0) + 1)) - set(shards))
    if missing:
        raise SpecError(f"shard {', '.join(map(str, missing))} of {next(iter(totals))} missing")
    if not found:
        raise SpecError("nothing to merge: no scenario folders in " + ", ".join(map(str, dirs)))
    return found


def merge(dirs: list[Path], out: Path, baselines: Path) -> list[ScenarioResult]:
    """Copy every shard's scenario folders into OUT and judge them as one run would."""
    sources = _sources(dirs)
    out.mkdir(parents=True, exist_ok=True)
    results = []
    for label, src in sorted(sources.items()):
        if src is None:
            results.append(ScenarioResult(label, "", error="its shard wrote no result"))
            continue
        dst = out / label
        if src.resolve() != dst.resolve():
            shutil.rmtree(dst, ignore_errors=True)
            shutil.copytree(src, dst)
            _relocate_log(dst)
        results.append(evaluate(dst, baselines))
    write_marker(out, None, None, [])
    return results


def _relocate_log(folder: Path) -> None:
    for run_json in [folder / "run.json", *folder.glob("*/run.json")]:
        try:
            doc = json.loads(run_json.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        if isinstance(doc, dict) and "log" in doc:
            doc["log"] = str(run_json.parent / Path(str(doc["log"])).name)
            write_json_atomic(run_json, doc)
