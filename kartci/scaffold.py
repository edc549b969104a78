"""`kartci init`: make a folder (a team's repository) a kartci project.

Writes the project's configuration (`kartci.toml`, or a `[tool.kartci]` table appended to an
existing pyproject.toml), one short scenario, an empty `baselines/` with a README, the gate
workflow (`.github/workflows/kartci.yml`), `constraints.txt` pinning the installed versions of
kartci's dependencies, a README section and `.gitignore` lines for `reports/` and `.venv/`.
Nothing is overwritten unless asked (`force`); every check is made before the first file is written.
The templates are in `kartci/data/init/`.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from enum import Enum
from importlib import metadata
from pathlib import Path
from typing import NoReturn

from kartci import __version__
from kartci.atomic import check_target, write_text_atomic
from kartci.boundedio import JSON_MAX_BYTES, RefusedFileError, read_bytes
from kartci.errors import SpecError
from kartci.project import BUILTIN

TEMPLATES = BUILTIN / "init"
SCENARIO = "line_straight_quick"
WORKFLOW = Path(".github/workflows/kartci.yml")
README_MARK = "<!-- kartci -->"
VERSION_MARK = "__KARTCI_VERSION__"
# Always pinned, whatever kartci's metadata says: these move the numbers.
NUMERIC = ("casadi", "numpy", "pybullet", "scipy")


class Action(Enum):
    """What `init` does with a file."""

    CREATED = "created"
    OVERWRITTEN = "overwrote"
    APPENDED = "appended to"
    KEPT = "kept"


@dataclass(frozen=True)
class Step:
    """One file `init` writes: where (relative to the project), what, and how."""

    path: Path
    text: str
    action: Action


def template(name: str) -> str:
    """A template with kartci's version filled in."""
    return (TEMPLATES / name).read_text(encoding="utf-8").replace(VERSION_MARK, __version__)


def workflow_text() -> str:
    """The gate workflow as `init` writes it."""
    return template("kartci.yml")


def _canonical(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


_NAME = re.compile(r"^\s*([A-Za-z0-9][A-Za-z0-9._-]*)")
_EXTRA = re.compile(r";.*\bextra\s*==")


def dependency_pins(dist: str = "kartci") -> list[str]:
    """`name==version` for every installed package kartci needs (its requirements without
    extras, recursively), plus the numeric ones even when kartci's metadata is not installed
    (running from a source checkout)."""
    found: dict[str, str] = {}
    seen: set[str] = set()
    todo = [dist, *NUMERIC]
    while todo:
        name = todo.pop()
        key = _canonical(name)
        if key in seen:
            continue
        seen.add(key)
        try:
            version, requires = metadata.version(name), metadata.requires(name) or []
        except metadata.PackageNotFoundError:
            continue  # not installed here (an environment marker excluded it, or a checkout)
        if key != _canonical(dist):
            found[key] = version
        for req in requires:
            match = _NAME.match(req)
            if match is not None and not _EXTRA.search(req):
                todo.append(match.group(1))
    return [f"{n}=={v}" for n, v in sorted(found.items())]


def constraints_text() -> str:
    """constraints.txt: the pins of `dependency_pins`, with a note on why they are there."""
    pins = "\n".join(dependency_pins())
    return (f"# kartci {__version__}'s dependencies, pinned to the versions installed when "
            "`kartci init` ran.\n"
            "# numpy, scipy, pybullet and casadi move the numbers: without the pins a new "
            "release of one of\n"
            "# them could turn main red with no change here. The workflow installs kartci "
            "with\n"
            "# `pip install -c constraints.txt ...`; move a pin on purpose, with the "
            "baselines it changes.\n"
            f"{pins}\n")


def _config_step(folder: Path, conflicts: list[Path]) -> Step:
    """kartci.toml, or a [tool.kartci] table added to an existing pyproject.toml."""
    body = template("config.toml")  # not named kartci.toml: it would make this folder a project
    own, pyproject = folder / "kartci.toml", folder / "pyproject.toml"
    if own.exists() or not pyproject.is_file():
        if own.exists():
            conflicts.append(own)
        return Step(Path("kartci.toml"), body,
                    Action.OVERWRITTEN if own.exists() else Action.CREATED)
    old = _read(pyproject)
    try:
        data = tomllib.loads(old)
    except tomllib.TOMLDecodeError as err:
        raise SpecError(f"{pyproject}: not valid TOML ({err}); nothing written") from err
    tool = data.get("tool")
    if isinstance(tool, dict) and "kartci" in tool:
        conflicts.append(pyproject)  # never rewritten: it is the team's file
        return Step(Path("pyproject.toml"), old, Action.KEPT)
    sep = "" if old.endswith("\n\n") else "\n" if old.endswith("\n") else "\n\n"
    return Step(Path("pyproject.toml"), f"{old}{sep}[tool.kartci]\n{body}", Action.APPENDED)


def _appended(folder: Path, rel: str, new: str, present: str | None = None) -> Step:
    """A text file that is created, or extended unless it already holds `present`."""
    path = folder / rel
    if not path.exists():
        return Step(Path(rel), new, Action.CREATED)
    old = _read(path)
    if present is not None and present in old:
        return Step(Path(rel), old, Action.KEPT)
    sep = "" if not old or old.endswith("\n\n") else "\n" if old.endswith("\n") else "\n\n"
    return Step(Path(rel), f"{old}{sep}{new}", Action.APPENDED)


IGNORED = ("reports", ".venv")  # run output, and the venv the README's first line makes


def plan(folder: Path, force: bool = False) -> list[Step]:
    """What `init` would write into `folder`; raises SpecError (naming the first file) when
    it would overwrite a file and `force` is off."""
    if folder.exists() and not folder.is_dir():
        raise SpecError(f"{folder}: not a folder; nothing written")
    conflicts: list[Path] = []
    steps = [_config_step(folder, conflicts), *_template_steps(folder, conflicts),
             _readme_step(folder)]
    ignored = {ln.strip().strip("/") for ln in _lines(folder / ".gitignore")}
    missing = [name for name in IGNORED if name not in ignored]
    if missing:
        steps.append(_appended(folder, ".gitignore", "".join(f"{n}/\n" for n in missing)))
    _refuse_paths_in_the_way(folder, steps)
    if conflicts and not force:
        _refuse_conflicts(folder, conflicts)
    return steps


def _template_steps(folder: Path, conflicts: list[Path]) -> list[Step]:
    """The files written whole from templates: the scenario, the baselines README, the
    workflow and constraints.txt; each one already there is added to `conflicts`."""
    steps: list[Step] = []
    for rel, text in ((Path("scenarios") / f"{SCENARIO}.yaml", template(f"{SCENARIO}.yaml")),
                      (Path("baselines") / "README.md", template("baselines-README.md")),
                      (WORKFLOW, workflow_text()),
                      (Path("constraints.txt"), constraints_text())):
        exists = (folder / rel).exists() or (folder / rel).is_symlink()
        if exists:
            conflicts.append(folder / rel)
        steps.append(Step(rel, text, Action.OVERWRITTEN if exists else Action.CREATED))
    return steps


def _readme_step(folder: Path) -> Step:
    """kartci's README section, appended once; a new README gets the folder's name as title."""
    section = template("README-section.md")
    readme = _appended(folder, "README.md", section, README_MARK)
    if readme.action is Action.CREATED:
        readme = Step(readme.path, f"# {folder.resolve().name}\n\n{section}", readme.action)
    return readme


def _refuse_paths_in_the_way(folder: Path, steps: list[Step]) -> None:
    """A file where a step needs a folder, or a folder where it writes a file, fails here,
    before anything is written."""
    for step in steps:
        for rel in (*reversed(step.path.parents[:-1]), step.path):
            path = folder / rel
            if rel != step.path and path.exists() and not path.is_dir():
                raise SpecError(f"{path}: not a folder; nothing written")
            if rel == step.path and path.is_dir():
                raise SpecError(f"{path}: a folder, expected a file; nothing written")
            if rel == step.path and not path.is_symlink():  # a link is replaced, not followed
                check_target(path)


def _refuse_conflicts(folder: Path, conflicts: list[Path]) -> NoReturn:
    """The SpecError for files `init` would overwrite: the first by name, the rest counted."""
    first = conflicts[0].relative_to(folder)
    what = ("already has [tool.kartci]" if first == Path("pyproject.toml")
            else "already exists")
    more = f" (and {len(conflicts) - 1} more)" if len(conflicts) > 1 else ""
    raise SpecError(f"{folder / first} {what}{more}; nothing written "
                    "(`kartci init --force` overwrites kartci's files)")


def _read(path: Path) -> str:
    try:  # a FIFO would hang a plain read; a device never end
        return read_bytes(path, JSON_MAX_BYTES).decode("utf-8")
    except (OSError, UnicodeDecodeError) as err:
        why = ("not a UTF-8 text file" if isinstance(err, UnicodeDecodeError)
               else str(err) if isinstance(err, RefusedFileError) else err.strerror)
        raise SpecError(f"{path}: cannot read ({why}); nothing written") from err


def _lines(path: Path) -> list[str]:
    return _read(path).splitlines() if path.exists() else []


def init_project(folder: Path, force: bool = False) -> list[Step]:
    """Write a kartci project into `folder` (created if missing); returns what was done."""
    steps = plan(folder, force)
    for step in steps:
        if step.action is not Action.KEPT:
            _write_atomic(folder / step.path, step.text)
    return steps


def _write_atomic(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.is_symlink():  # a link is replaced by the file, never written through
        path.unlink()
    write_text_atomic(path, text)
