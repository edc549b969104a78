"""`kartci init`: make a folder (a team's repository) a kartci project.

Writes the project's configuration (`kartci.toml`, or a `[tool.kartci]` table appended to an
existing pyproject.toml), one short scenario, an empty `baselines/` with a README, the gate
workflow (`.github/workflows/kartci.yml`), `constraints.txt` pinning the installed versions of
kartci's dependencies, a README section and `.gitignore` lines for `reports/` and `.venv/`.
The gate installs the kartci that ran `init` (`install_source`: its git commit, its wheel's URL,
or its wheel file copied into `.kartci/wheels/`), so a team's first pull request installs a
kartci that exists, with no repository variable set.
Nothing is overwritten unless asked (`force`); every check is made before the first file is written.
The templates are in `kartci/data/init/`.
"""

from __future__ import annotations

import json
import re
import subprocess
import tomllib
from dataclasses import dataclass
from enum import Enum
from importlib import metadata
from pathlib import Path
from typing import Any, NoReturn
from urllib.parse import unquote, urlparse

from kartci import __version__
from kartci.atomic import check_target, write_bytes_atomic, write_text_atomic
from kartci.boundedio import JSON_MAX_BYTES, RefusedFileError, read_bytes
from kartci.errors import SpecError
from kartci.project import BUILTIN

TEMPLATES = BUILTIN / "init"
SCENARIO = "line_straight_quick"
WORKFLOW = Path(".github/workflows/kartci.yml")
README_MARK = "<!-- kartci -->"
VERSION_MARK = "__KARTCI_VERSION__"
REQUIREMENT_MARK = "__KARTCI_REQUIREMENT__"
WHEELS = Path(".kartci/wheels")  # a local wheel, copied into the project to be committed
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
    data: bytes | None = None  # a binary file's bytes (the copied wheel); `text` is then ""


@dataclass(frozen=True)
class Install:
    """How the gate and the README install kartci: a pip requirement, the wheel file `init`
    copies to `.kartci/wheels/` (the requirement then names the copy), and a warning when
    the requirement may install nothing (kartci ran from a folder, not from a release)."""

    requirement: str
    wheel: Path | None = None
    warning: str | None = None


# What a requirement may hold: it is written into a YAML plain scalar inside a GitHub
# expression's quoted literal, and into a README shell line; no quote, `${`, ` #` or newline.
_SAFE_REQUIREMENT = re.compile(r"[A-Za-z0-9 ._@+:/=<>!~,;\[\]#%?&*()-]+")


def checked_requirement(spec: str) -> str:
    """`spec` (`kartci init --kartci`) if it can be written into the workflow as it is."""
    spec = spec.strip()
    if not spec or not _SAFE_REQUIREMENT.fullmatch(spec) or " #" in spec:
        raise SpecError(f"--kartci {spec!r}: not a pip requirement the workflow can hold "
                        "(a version spec, a wheel's path or URL, or 'kartci @ git+URL@COMMIT'; "
                        "no quotes); nothing written")
    return spec


def install_source(explicit: str | None = None) -> Install:
    """The kartci the gate installs: `explicit` if given, else the one running now, read from
    how it was installed (PEP 610 direct_url.json; none means a package index)."""
    if explicit is not None:
        return Install(checked_requirement(explicit))
    try:
        direct_url = metadata.distribution("kartci").read_text("direct_url.json")
    except metadata.PackageNotFoundError:  # a checkout on sys.path, never installed
        direct_url = ""
    return install_from(direct_url, __version__)


def install_from(direct_url: str | None, version: str) -> Install:
    """The requirement for a kartci installed as `direct_url` (direct_url.json's text; None
    or "": from an index): its git commit, its https wheel with the recorded hash, its local
    wheel copied into the project; a folder (editable) falls back, with a warning naming what
    to set, to the release tag of its version in the folder's git origin, else to
    `kartci==version`."""
    index = f"kartci=={version}"
    if direct_url is None:
        return Install(index)
    data: Any = json.loads(direct_url) if direct_url.strip() else {}
    url = str(data.get("url", "")) if isinstance(data, dict) else ""
    vcs, archive = data.get("vcs_info"), data.get("archive_info")
    if isinstance(vcs, dict) and vcs.get("vcs") == "git" and vcs.get("commit_id"):
        return Install(checked_requirement(f"kartci @ git+{url}@{vcs['commit_id']}"))
    if isinstance(archive, dict) and url.startswith("https://"):
        hashes = archive.get("hashes") or {}
        sha = hashes.get("sha256") if isinstance(hashes, dict) else None
        if sha is None and str(archive.get("hash", "")).startswith("sha256="):
            sha = str(archive["hash"]).removeprefix("sha256=")
        return Install(checked_requirement(f"kartci @ {url}" + (f"#sha256={sha}" if sha
                                                                 else "")))
    if isinstance(archive, dict) and url.startswith("file://"):
        wheel = Path(unquote(urlparse(url).path))
        if wheel.suffix == ".whl" and wheel.is_file():
            return Install(f"./{(WHEELS / wheel.name).as_posix()}", wheel=wheel)
    folder = Path(unquote(urlparse(url).path)) if url.startswith("file://") else None
    release = _release_of_checkout(folder, version) if folder is not None else None
    fallback = release or index
    what = ("the release tag of this version in the folder's origin, not the folder's own "
            "code; it may not exist yet" if release else "which no package index may have")
    where = f" ({folder})" if folder is not None else ""
    return Install(fallback, warning=(
        f"kartci runs from a folder{where}, not a release: the gate installs {fallback}, "
        f"{what}. Set it: `kartci init --force --kartci SPEC` (a wheel, "
        "'kartci @ git+URL@COMMIT') or the repository variable KARTCI_REQUIREMENT"))


_SCP_URL = re.compile(r"^[\w.-]+@([\w.-]+):(.+)$")  # git@github.com:owner/kartci.git


def _release_of_checkout(folder: Path, version: str) -> str | None:
    """`kartci @ git+https://<origin>@v<version>` for a git checkout of kartci whose `origin`
    is a remote repository (https, ssh or scp-like; credentials and keys left out); None
    otherwise."""
    try:
        got = subprocess.run(["git", "-C", str(folder), "remote", "get-url", "origin"],
                             capture_output=True, text=True, timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return None  # no git here
    url = got.stdout.strip() if got.returncode == 0 else ""
    scp = _SCP_URL.match(url)
    if scp is not None:
        url = f"https://{scp.group(1)}/{scp.group(2)}"
    parts = urlparse(url)
    if parts.scheme not in ("https", "ssh") or not parts.hostname:
        return None  # a local path or something pip cannot fetch from CI
    # CI fetches over https, with no key and no credential: the host and the path only
    host = parts.hostname + (f":{parts.port}" if parts.port and parts.scheme == "https" else "")
    try:
        return checked_requirement(f"kartci @ git+https://{host}{parts.path}@v{version}")
    except SpecError:
        return None


def template(name: str, install: Install | None = None) -> str:
    """A template with kartci's version and the requirement that installs it filled in."""
    requirement = (install or Install(f"kartci=={__version__}")).requirement
    return ((TEMPLATES / name).read_text(encoding="utf-8").replace(VERSION_MARK, __version__)
            .replace(REQUIREMENT_MARK, requirement))


def workflow_text(install: Install | None = None) -> str:
    """The gate workflow as `init` writes it (installing `kartci==<version>` by default)."""
    return template("kartci.yml", install)


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


def plan(folder: Path, force: bool = False, install: Install | None = None) -> list[Step]:
    """What `init` would write into `folder`, the gate installing `install` (default
    `install_source()`); raises SpecError (naming the first file) when it would overwrite a
    file and `force` is off."""
    if folder.exists() and not folder.is_dir():
        raise SpecError(f"{folder}: not a folder; nothing written")
    install = install or install_source()
    conflicts: list[Path] = []
    steps = [_config_step(folder, conflicts), *_template_steps(folder, conflicts, install),
             _readme_step(folder, install)]
    if install.wheel is not None:
        steps.append(_wheel_step(folder, install.wheel, conflicts))
    ignored = {ln.strip().strip("/") for ln in _lines(folder / ".gitignore")}
    missing = [name for name in IGNORED if name not in ignored]
    if missing:
        steps.append(_appended(folder, ".gitignore", "".join(f"{n}/\n" for n in missing)))
    _refuse_paths_in_the_way(folder, steps)
    if conflicts and not force:
        _refuse_conflicts(folder, conflicts)
    return steps


def _template_steps(folder: Path, conflicts: list[Path], install: Install) -> list[Step]:
    """The files written whole from templates: the scenario, the baselines README, the
    workflow and constraints.txt; each one already there is added to `conflicts`."""
    steps: list[Step] = []
    for rel, text in ((Path("scenarios") / f"{SCENARIO}.yaml", template(f"{SCENARIO}.yaml")),
                      (Path("baselines") / "README.md", template("baselines-README.md")),
                      (WORKFLOW, workflow_text(install)),
                      (Path("constraints.txt"), constraints_text())):
        exists = (folder / rel).exists() or (folder / rel).is_symlink()
        if exists:
            conflicts.append(folder / rel)
        steps.append(Step(rel, text, Action.OVERWRITTEN if exists else Action.CREATED))
    return steps


def _wheel_step(folder: Path, wheel: Path, conflicts: list[Path]) -> Step:
    """The wheel kartci was installed from, copied to `.kartci/wheels/` for the gate; the
    same bytes already there are kept, other bytes are a conflict."""
    rel = WHEELS / wheel.name
    try:
        data = wheel.read_bytes()
    except OSError as err:
        raise SpecError(f"{wheel}: cannot read kartci's wheel ({err.strerror}); nothing "
                        "written (`kartci init --kartci SPEC` names another)") from err
    if (folder / rel).is_file() and (folder / rel).read_bytes() == data:
        return Step(rel, "", Action.KEPT, data)
    exists = (folder / rel).exists() or (folder / rel).is_symlink()
    if exists:
        conflicts.append(folder / rel)
    return Step(rel, "", Action.OVERWRITTEN if exists else Action.CREATED, data)


def _readme_step(folder: Path, install: Install) -> Step:
    """kartci's README section, appended once; a new README gets the folder's name as title."""
    section = template("README-section.md", install)
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


def init_project(folder: Path, force: bool = False,
                 install: Install | None = None) -> list[Step]:
    """Write a kartci project into `folder` (created if missing), the gate installing
    `install` (default `install_source()`); returns what was done."""
    steps = plan(folder, force, install)
    for step in steps:
        if step.action is not Action.KEPT:
            _write_atomic(folder / step.path, step)
    return steps


def _write_atomic(path: Path, step: Step) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.is_symlink():  # a link is replaced by the file, never written through
        path.unlink()
    if step.data is not None:
        write_bytes_atomic(path, step.data)
    else:
        write_text_atomic(path, step.text)
