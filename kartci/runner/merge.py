"""Partial results of `kartci run --shard I/N` and joining them with `kartci merge`.

A shard writes its scenario folders into its OUT plus `shard.json` (which share it had and
which labels that share held), written before anything runs: a shard that died early is then
still seen as missing, not silently skipped.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from kartci.core import UNFINISHED, RunFolder
from kartci.errors import SpecError
from kartci.project import Project
from kartci.runner.gate import require_baselines
from kartci.runner.outdir import check_inside, valid_label
from kartci.runner.run import evaluate, scenario_folders
from kartci.verdict import read_json, write_json_atomic
from kartci.verdict.judging import check_allowed
from kartci.verdict.result import ScenarioResult

SHARD_NAME = "shard.json"


def write_marker(out: Path, index: int | None, total: int | None, labels: list[str]) -> None:
    """Mark OUT as shard `index` of `total` (or clear an old mark for a whole run)."""
    if index is None or total is None:
        (out / SHARD_NAME).unlink(missing_ok=True)
        return
    write_json_atomic(out / SHARD_NAME, {"index": index, "total": total,
                                         "scenarios": sorted(labels)})


def _shard_of(folder: Path) -> tuple[int, int, list[str]] | None:
    """A shard's marker, checked as untrusted input (a CI artifact anyone could have made):
    the message names what is wrong, never the file's contents."""
    path = folder / SHARD_NAME
    if not path.exists() and not path.is_symlink():
        return None
    if path.is_symlink() or not path.is_file():
        raise SpecError(f"{path}: not a regular file")
    try:
        doc = read_json(path)
        index, total, labels = doc["index"], doc["total"], doc["scenarios"]
    except (OSError, ValueError, KeyError, TypeError, UnicodeDecodeError):
        raise SpecError(f"{path}: malformed shard marker (expected JSON with index, total "
                        "and scenarios)") from None
    if not (isinstance(index, int) and isinstance(total, int) and 1 <= index <= total):
        raise SpecError(f"{path}: malformed shard marker (index and total: 1 <= index <= total)")
    if not isinstance(labels, list) or not all(valid_label(x) for x in labels):
        raise SpecError(f"{path}: malformed shard marker (scenarios must be folder names: "
                        "no path separators, no '..')")
    return index, total, [str(x) for x in labels]


def _labels(d: Path) -> list[str]:
    """The labels a folder to merge holds: its shard marker's, which must match the scenario
    folders present (a listed folder may be absent: that shard died before writing it)."""
    present = {p.name for p in scenario_folders(d)}
    bad = sorted(x for x in present if not valid_label(x))
    if bad:
        raise SpecError(f"{d}: a scenario folder with an unusable name ({len(bad)} found)")
    marker = _shard_of(d)
    if marker is None:
        return sorted(present)
    extra = sorted(present - set(marker[2]))
    if extra:
        raise SpecError(f"{d}: scenario folders not listed in {SHARD_NAME}: {', '.join(extra)}")
    return marker[2]


def _sources(dirs: list[Path]) -> dict[str, Path | None]:
    """label -> its folder in one of `dirs` (None: a shard listed it but has no folder)."""
    found: dict[str, Path | None] = {}
    shards: dict[int, int] = {}
    for d in dirs:
        if not d.is_dir():
            raise SpecError(f"{d}: no such folder")
        marker = _shard_of(d)
        if marker is not None:
            index, total, _ = marker
            if index in shards:
                raise SpecError(f"{d}: shard {index}/{total} given twice")
            shards[index] = total
        for label in _labels(d):
            if label in found:
                raise SpecError(f"{label}: in more than one of the folders to merge")
            src = d / label
            found[label] = src if src.is_dir() and not src.is_symlink() else None
    totals = set(shards.values())
    if len(totals) > 1:
        raise SpecError(f"shards of different splits: /{' /'.join(map(str, sorted(totals)))}")
    missing = sorted(set(range(1, next(iter(totals), 0) + 1)) - set(shards))
    if missing:
        raise SpecError(f"shard {', '.join(map(str, missing))} of {next(iter(totals))} missing")
    if not found:
        raise SpecError("nothing to merge: no scenario folders in " + ", ".join(map(str, dirs)))
    return found


def _check_tree(src: Path) -> None:
    """Only plain folders and files: a symlink in an artifact could pull outside files in."""
    for p in [src, *src.rglob("*")]:
        if p.is_symlink() or not (p.is_dir() or p.is_file()):
            raise SpecError(f"{src}: holds a symlink or special file ({p.relative_to(src)}); "
                            "refusing to merge it")


def merge(dirs: list[Path], out: Path, baselines: Path, proj: Project,
          strict: bool = False) -> list[ScenarioResult]:
    """Copy every shard's scenario folders into OUT and judge them as one run would. Labels
    and folders are checked first (shard artifacts are untrusted); nothing is written outside
    OUT, and a folder is replaced only by a complete copy. Until then, OUT's older folder of
    each label is marked unfinished: an interrupted merge leaves none passing as merged."""
    check_allowed(proj)
    sources = _sources(dirs)
    for src in sources.values():
        if src is not None:
            _check_tree(src)
    out.mkdir(parents=True, exist_ok=True)
    check_inside(out, sources)
    for label, src in sources.items():
        dst = RunFolder(out / label)
        if dst.path.is_dir() and (src is None or src.resolve() != dst.path.resolve()):
            dst.mark_failed(label, UNFINISHED)
    root = out.resolve()
    results = []
    for label, src in sorted(sources.items()):
        if src is None:
            results.append(ScenarioResult(label, "", error="its shard wrote no result"))
            continue
        dst = RunFolder(out / label)
        if dst.path.resolve().parent != root:
            raise SpecError(f"{label}: would be written outside {out}")
        if src.resolve() != dst.path.resolve():
            _replace_tree(src, dst.path)
        result = evaluate(dst, baselines, proj)
        results.append(require_baselines(result, out, baselines) if strict else result)
    write_marker(out, None, None, [])
    return results


def _replace_tree(src: Path, dst: Path) -> None:
    """Copy `src` to `dst` via a temporary folder beside it: the old folder goes only once the
    copy is complete, and stale run artifacts (a run's staging folder) are left out."""
    tmp = Path(tempfile.mkdtemp(prefix=f".{dst.name}.", suffix=".merge", dir=dst.parent))
    try:
        stages = shutil.ignore_patterns(f"{RunFolder.STAGE_PREFIX}*")
        shutil.copytree(src, tmp / "new", ignore=stages)
        _relocate_log(RunFolder(tmp / "new"), dst)
        if dst.is_symlink() or dst.is_file():
            dst.unlink()
        elif dst.exists():
            dst.rename(tmp / "old")
        (tmp / "new").rename(dst)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _relocate_log(folder: RunFolder, final: Path) -> None:
    """Point run.json's `log` at where the folder will be (`final`)."""
    for run_json in [folder.run_record, *folder.path.glob(f"*/{RunFolder.RUN_RECORD_NAME}")]:
        try:
            doc = read_json(run_json)
        except (OSError, ValueError):
            continue
        if isinstance(doc, dict) and "log" in doc:
            where = final / run_json.parent.relative_to(folder.path)
            doc["log"] = str(where / Path(str(doc["log"])).name)
            write_json_atomic(run_json, doc)
