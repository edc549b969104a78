"""The user's project: where its scenarios, worlds, robot models and baselines live.

kartci finds its project the way pytest finds its rootdir: the nearest folder, from the working
directory up, holding a `kartci.toml` or a `pyproject.toml` with a `[tool.kartci]` table; the
walk stops at a file-system boundary, as git's does. `KARTCI_ROOT` names the folder directly.
A configuration names code to import (plugins) and folders to read and write, so it is used
only when it and its folder are owned by the user running kartci (or root) and writable by no
one else, unless its folder is trusted (`KARTCI_SAFE_DIRECTORIES`, or `safe_directories` in the
user's own `~/.config/kartci/config.toml`; never the project's own file): git's answer to
CVE-2022-24765, where a `.git/` planted in a shared parent folder ran its hooks for whoever
worked below it. Without a configuration the working directory is the project (with the
default folder names), but nothing is written there by default: a command that writes needs
`--out` (`Project.found`). Data files are looked up in the project's folders first, then
in kartci's built-in ones (`SHIPPED`: the `scenarios/`, `models/` and `sims/` of kartci's own
repository, which is a kartci project like any team's, packaged into the wheel), so an empty
project can still run the built-in line tracker and go-kart.
"""

from __future__ import annotations

import grp
import os
import pwd
import stat
import tomllib
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from enum import Enum
from functools import lru_cache
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from kartci.boundedio import RefusedFileError, read_bytes
from kartci.core.loading import set_default_source
from kartci.errors import SpecError, did_you_mean

BUILTIN = Path(__file__).resolve().parent / "data"  # kartci's own files: init templates, report
PACKAGED = BUILTIN / "builtin"  # where the wheel carries the built-in folders (pyproject.toml)


def shipped_root() -> Path:
    """The folder holding the built-in `scenarios/`, `models/` and `sims/`: inside an installed
    wheel, else the top level of the source checkout kartci runs from (an editable install,
    PYTHONPATH), where kartci's repository keeps them as a team's project does."""
    return PACKAGED if PACKAGED.is_dir() else BUILTIN.parents[1]


SHIPPED = shipped_root()
BUILTIN_SCENARIOS = SHIPPED / "scenarios"  # the default suite
BUILTIN_MODELS = SHIPPED / "models"
BUILTIN_SIMS = SHIPPED / "sims"  # worlds
CONFIG_NAMES = ("kartci.toml", "pyproject.toml")
SAFE_ENV = "KARTCI_SAFE_DIRECTORIES"  # folders whose configuration is trusted (os.pathsep; "*")
CONFIG_MAX_BYTES = 4 << 20  # a pyproject.toml; large real ones (with lock-like tables) are < 100 KB
# A baseline tolerance may be this many times its metric's default before it counts as loosened:
# the same margin as the spread rule (3 x spread), wide enough for a default computed at an older
# baseline value (the committed baselines reach 1.8x), far below a tolerance set to get a PR green.
LOOSEN_FACTOR = 3.0


class Origin(Enum):
    """Where a scenario comes from."""

    PROJECT = "project"
    BUILTIN = "built-in"


class ProjectConfig(BaseModel):
    """`[tool.kartci]` in pyproject.toml, or the whole of kartci.toml. Paths are relative to
    the file's folder."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    scenarios: tuple[str, ...] = Field(("scenarios",), description="folders of scenario YAML")
    worlds: tuple[str, ...] = Field(("worlds",), description="folders of world YAML and tracks")
    models: tuple[str, ...] = Field(("models",), description="folders of robot models: "
                                    "<name>/params.yaml with its URDF")
    baselines: str = Field("baselines", description="folder of baseline files")
    reports: str = Field("reports", description="folder for run outputs")
    plugins: tuple[str, ...] = Field((), description="Python modules to import for their "
                                     "controllers, robots, worlds and metrics")
    builtin_scenarios: bool = Field(False, description="run kartci's built-in scenarios too "
                                    "when `kartci run` is given no names")
    loosen_factor: float = Field(LOOSEN_FACTOR, ge=1.0, le=1e6, description="a baseline "
                                 "tolerance wider than this many times its metric's default "
                                 "(and than 3x its spread) is loosened: flagged, and a failure "
                                 "in CI unless allowed below")
    allow_loose_tolerances: dict[str, str] = Field({}, description="loosened tolerances allowed "
                                                   "anyway: `\"SCENARIO:METRIC\" = \"reason\"`")

    @field_validator("allow_loose_tolerances")
    @classmethod
    def _named_with_a_reason(cls, value: dict[str, str]) -> dict[str, str]:
        for key, reason in value.items():
            scenario, _, metric = key.partition(":")
            missing = ("no metric" if not metric.strip() else "no scenario"
                       if not scenario.strip() else None)
            if missing is not None:
                raise ValueError(f"{key[:80]!r} names {missing}: expected \"SCENARIO:METRIC\" "
                                 "= \"reason\"")
            if not reason.strip():
                raise ValueError(f"{key[:80]!r}: an empty reason; say why its tolerance may "
                                 "stay loose")
        return value


@dataclass(frozen=True)
class Project:
    """Where things are; a plain value, so it travels to worker processes and Ray tasks."""

    root: Path
    config_file: Path | None
    scenarios: tuple[Path, ...]
    worlds: tuple[Path, ...]
    models: tuple[Path, ...]
    baselines: Path
    reports: Path
    plugins: tuple[str, ...] = ()
    builtin_scenarios: bool = False
    loosen_factor: float = LOOSEN_FACTOR
    allow_loose_tolerances: tuple[tuple[str, str], ...] = ()  # ("scenario:metric", reason)
    # a configuration was found (or KARTCI_ROOT named the folder): False means the working
    # directory stands in, and no default output folder is written there (`default_output`)
    found: bool = True

    def default_output(self, what: str) -> Path:
        """`<reports>/<what>`, the default output folder of a command (see `writable`)."""
        return self.writable(self.reports / what, "--out DIR")

    def writable(self, folder: Path, option: str) -> Path:
        """`folder`, one of the project's, as the default place to write; a SpecError naming
        `option` (what to pass instead) when no project was found: `kartci run` started in `/`
        or a home folder must not create `reports/` (or `baselines/`) there without a word."""
        if not self.found:
            raise SpecError(f"no kartci project found in {shown(self.root)} or a folder above "
                            f"it (no kartci.toml, no pyproject.toml with [tool.kartci]): pass "
                            f"{option} to say where to write, or make a project with "
                            "`kartci init`")
        return folder

    @property
    def scenario_path(self) -> tuple[Path, ...]:
        """Scenario folders in search order: the project's own, then the built-in ones."""
        return _unique((*self.scenarios, BUILTIN_SCENARIOS))

    @property
    def world_path(self) -> tuple[Path, ...]:
        """World folders in search order: the project's own, then the built-in ones."""
        return _unique((*self.worlds, BUILTIN_SIMS))

    @property
    def model_path(self) -> tuple[Path, ...]:
        """Robot model folders in search order: the project's own, then the built-in ones."""
        return _unique((*self.models, BUILTIN_MODELS))

    @property
    def data_roots(self) -> tuple[Path, ...]:
        """The folders a data file may come from: the project's own and kartci's built-in data.
        A file outside them (an absolute path, a `..`, a symlink leaving them) could be any file
        on the machine, and a file that fails to parse ends up named in CI artifacts."""
        return _unique((self.root, *self.scenario_path, *self.world_path, *self.model_path,
                        BUILTIN))

    def contained(self, path: Path, what: str, allow_outside: bool = False) -> Path:
        """`path` with symlinks resolved; a SpecError when that leaves `data_roots`, unless
        `allow_outside` (the user's `--allow-outside-paths`)."""
        try:
            real = path.resolve()
        except (OSError, RuntimeError, ValueError) as err:  # a loop, a long name, a NUL
            raise SpecError(f"{what}: {shown(path)}: cannot be resolved ({err})") from err
        if allow_outside or any(real.is_relative_to(root) for root in self.data_roots):
            return real
        plain = str(real) == os.path.normpath(path.absolute())  # only `..` and `.` in it
        link = "" if plain else f" (a link to {shown(real)})"
        raise SpecError(f"{what}: {shown(path)}{link} is outside the project and kartci's data "
                        "(pass --allow-outside-paths to use it)")

    def own_scenarios(self) -> list[Path]:
        """The project's own scenario files (and the built-in ones when asked for), by name;
        a name found twice is taken from the first folder."""
        folders = self.scenario_path if self.builtin_scenarios else _unique(self.scenarios)
        return list(_yaml_files(folders).values())

    def all_scenarios(self) -> dict[str, Path]:
        """Every scenario reachable by name: the project's, then the built-in ones."""
        return _yaml_files(self.scenario_path)

    def origin_of(self, path: Path) -> Origin:
        """A scenario file in one of the project's own scenario folders, or a built-in one."""
        own = {p.resolve() for p in self.scenarios}
        return Origin.PROJECT if path.parent.resolve() in own else Origin.BUILTIN

    def find_scenario(self, name: str) -> Path:
        """A scenario's file by name; a SpecError naming close matches when there is none."""
        known = self.all_scenarios()
        if name in known:
            return known[name]
        short = name if len(name) <= 80 else name[:77] + "..."
        raise SpecError(f"unknown scenario '{short}'{did_you_mean(name, known)}; "
                        "see `kartci list`")

    def find_world(self, name: str, allow_outside: bool = False) -> Path:
        """`winti/hall` -> the first `<world folder>/winti/hall.yaml` on the search path."""
        return self._find(self.world_path, f"{name}.yaml", f"world {name!r}", allow_outside,
                          (name, "*/*.yaml", lambda p: p.with_suffix("")))

    def find_model(self, name: str, allow_outside: bool = False) -> Path:
        """`NAME` -> the first `<model folder>/NAME/params.yaml` on the search path."""
        return self._find(self.model_path, f"{name}/params.yaml", f"robot model {name!r}",
                          allow_outside, (name, "*/params.yaml", lambda p: p.parent))

    def world_file(self, rel: str, allow_outside: bool = False) -> Path:
        """A data file named relative to the world folders (a track CSV, a mesh)."""
        return self._find(self.world_path, rel, f"world data file {rel!r}", allow_outside)

    def model_file(self, rel: str, allow_outside: bool = False) -> Path:
        """A data file named relative to the model folders (a URDF, a joystick mapping)."""
        return self._find(self.model_path, rel, f"model data file {rel!r}", allow_outside)

    def _find(self, path: tuple[Path, ...], rel: str, what: str, allow_outside: bool,
              near: Near | None = None) -> Path:
        """The first `<folder>/rel` on `path` that is a file; a symlink found there must stay
        within `data_roots` (unless `allow_outside`); `near`: how to name a close match."""
        what = what if len(what) <= 120 else what[:117] + "..."  # never echo a huge name
        if Path(rel).is_absolute() or ".." in Path(rel).parts:
            raise SpecError(f"{what}: expected a name relative to the search path "
                            "(no absolute path, no '..')")
        for folder in path:
            candidate = folder / rel
            try:
                if candidate.is_file():
                    self.contained(candidate, what, allow_outside)
                    return candidate
            except OSError as err:  # a name too long for the file system, say
                raise SpecError(f"{what}: cannot be a file name ({err.strerror})") from err
        where = ", ".join(str(p) for p in path)
        raise SpecError(f"{what} not found{_near(path, near)} (searched {where})")


# (the name looked up, the glob of every known one in a search folder, that file -> its name)
Near = tuple[str, str, Callable[[Path], Path]]


def _near(path: tuple[Path, ...], near: Near | None) -> str:
    """' (did you mean 'x'?)' when a name on the search path is close to the one not found."""
    if near is None:
        return ""
    name, pattern, name_of = near
    known = {name_of(p.relative_to(folder)).as_posix() for folder in path if folder.is_dir()
             for p in folder.glob(pattern)}
    hint = did_you_mean(name, known)
    return hint if hint.startswith(" (did you mean") else ""


def shown(path: Path, limit_chars: int = 200) -> str:
    """A path for a message: one printable line (non-printable characters escaped), cut to
    `limit_chars` (a world or model name from a `--set`, up to 64 KB, becomes part of a path)."""
    text = str(path) if str(path).isprintable() else repr(str(path))[1:-1]
    return text if len(text) <= limit_chars else text[: limit_chars - 1] + "…"


def _unique(paths: tuple[Path, ...]) -> tuple[Path, ...]:
    seen: dict[Path, None] = {}
    for p in paths:
        seen.setdefault(p.resolve(), None)
    return tuple(seen)


def _yaml_files(folders: tuple[Path, ...]) -> dict[str, Path]:
    out: dict[str, Path] = {}
    for folder in folders:
        if not folder.is_dir():
            continue
        for p in sorted(folder.glob("*.yaml")):
            out.setdefault(p.stem, p)
    return dict(sorted(out.items()))


def user_config_file() -> Path:
    """The user's own kartci configuration: `$XDG_CONFIG_HOME/kartci/config.toml`, else
    `~/.config/kartci/config.toml`. It holds what a project must not decide for itself
    (`safe_directories`)."""
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base) / "kartci" / "config.toml"


def _safe_directories() -> list[str]:
    """The trusted folders: KARTCI_SAFE_DIRECTORIES, then the user config's `safe_directories`
    (which must itself pass the ownership check: it decides what else is trusted)."""
    listed = [p for p in os.environ.get(SAFE_ENV, "").split(os.pathsep) if p]
    path = user_config_file()
    if not path.is_file():
        return listed
    why = _untrusted(path)
    if why is not None:
        raise SpecError(f"{shown(path)}: {why}; kartci ignores no part of it, so fix it first")
    try:
        data = tomllib.loads(read_bytes(path, CONFIG_MAX_BYTES).decode("utf-8"))
    except (OSError, RefusedFileError, UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise SpecError(f"{shown(path)}: cannot read ({err})") from err
    value = data.get("safe_directories", [])
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise SpecError(f"{shown(path)}: safe_directories: expected a list of folder paths")
    return [*listed, *value]


def _name(uid: int) -> str:
    try:
        return pwd.getpwuid(uid).pw_name
    except KeyError:
        return f"uid {uid}"


def _private_group(gid: int, owner: int) -> bool:
    """The owner's own group (a group named as the owner, no other members): Debian's and
    Ubuntu's user private groups, where umask 002 makes every file group-writable."""
    try:
        group = grp.getgrgid(gid)
    except KeyError:
        return False
    name = _name(owner)
    return group.gr_name == name and set(group.gr_mem) <= {name}


def _untrusted(path: Path) -> str | None:
    """Why `path` (a file or folder) cannot be trusted, or None: it must be owned by the user
    running kartci or by root, and writable by no one else (group-writable only for the
    owner's private group)."""
    st = path.stat()
    me = os.geteuid()
    if st.st_uid not in (me, 0):
        return (f"is owned by {_name(st.st_uid)}, not by {_name(me)}, who runs kartci"
                f"{'' if me == 0 else ', nor by root'}")
    if st.st_mode & stat.S_IWOTH or (st.st_mode & stat.S_IWGRP
                                     and not _private_group(st.st_gid, st.st_uid)):
        who = "others" if st.st_mode & stat.S_IWOTH else "its group"
        return f"is writable by {who} (mode {stat.S_IMODE(st.st_mode):04o})"
    return None


def check_trusted(config: Path) -> None:
    """A SpecError, one line naming the file, its owner and how to trust it, unless the
    configuration `config` and its folder pass `_untrusted` or the folder is listed as safe."""
    folder = config.parent
    try:
        why, what = _untrusted(config), shown(config)
        if why is None:
            why, what = _untrusted(folder), f"{shown(folder)} (the folder of {config.name})"
    except OSError as err:
        raise SpecError(f"{shown(config)}: cannot check its owner ({err.strerror})") from err
    if why is None:
        return
    safe = _safe_directories()
    real = folder.resolve()
    if "*" in safe or any(Path(p).expanduser().resolve() == real for p in safe):
        return
    raise SpecError(f"{what} {why}: its plugins and paths would act as you, so it is not used; "
                    f"if you trust it, run with {SAFE_ENV}={shown(real)} or add it to "
                    f"safe_directories in {shown(user_config_file())}")


@lru_cache(maxsize=16)
def _parsed(raw: bytes) -> dict[str, Any]:
    """A configuration file's TOML, parsed once per content: an API caller loading scenarios
    one by one finds the project for each, and parsing pyproject.toml was two thirds of a
    scenario's load. Callers do not mutate it."""
    return tomllib.loads(raw.decode("utf-8"))


def _config_in(folder: Path) -> tuple[Path, dict[str, object]] | None:
    """The kartci table of a folder's kartci.toml or pyproject.toml, if it has one (and it is
    trusted: `check_trusted`)."""
    for name in CONFIG_NAMES:
        path = folder / name
        if not path.exists():  # not is_file(): a FIFO or a folder here is named, not skipped
            continue
        try:  # bounded: a FIFO would hang the read, a 1 GB file fill the memory
            data = _parsed(read_bytes(path, CONFIG_MAX_BYTES))
        except RefusedFileError as err:
            raise SpecError(f"{path}: {err}") from err
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
            raise SpecError(f"{path}: cannot read ({err})") from err
        if name == "kartci.toml":
            check_trusted(path)
            return path, data
        tool = data.get("tool")
        if isinstance(tool, dict) and isinstance(tool.get("kartci"), dict):
            check_trusted(path)
            return path, tool["kartci"]
    return None


def find_project(start: Path | None = None) -> Project:
    """The project for a working directory (default: the current one); KARTCI_ROOT wins."""
    env = os.environ.get("KARTCI_ROOT")
    if env:
        root = Path(env).resolve()
        if not root.is_dir():
            raise SpecError(f"KARTCI_ROOT={env}: no such folder")
        found = _config_in(root)
    else:
        here = (start or Path.cwd()).resolve()
        found, root = None, here
        device = here.stat().st_dev
        for folder in (here, *here.parents):
            if folder.stat().st_dev != device:  # another file system: not this project's
                break
            found = _config_in(folder)
            if found is not None:
                root = folder
                break
    path, table = found if found is not None else (None, {})
    try:
        cfg = ProjectConfig.model_validate(table)
    except ValidationError as err:
        first = err.errors()[0]
        key = ".".join(str(p) for p in first["loc"])
        raise SpecError(f"{path}: [tool.kartci] {key}: {first['msg']}") from err
    return Project(root, path, tuple(root / s for s in cfg.scenarios),
                   tuple(root / w for w in cfg.worlds), tuple(root / m for m in cfg.models),
                   root / cfg.baselines, root / cfg.reports, cfg.plugins, cfg.builtin_scenarios,
                   cfg.loosen_factor, tuple(sorted(cfg.allow_loose_tolerances.items())),
                   found=found is not None or bool(env))


_CURRENT: Project | None = None


def current() -> Project:
    """The active project: one set by `activate` (a worker given its parent's project), else
    the one found from the working directory."""
    return _CURRENT if _CURRENT is not None else find_project()


def activate(project: Project | None) -> None:
    """Make `project` the active one in this process (None: find it from the working dir)."""
    global _CURRENT
    _CURRENT = project


set_default_source(current)  # what plugin loading asks when no project is handed in


@contextmanager
def held(project: Project | None = None) -> Iterator[Project]:
    """`project` (None: the active one, looked up once) active for the enclosed work, where
    plugin loading asks for it (`kartci.core.loading`'s default source): a run in the project
    its scenario carries, and found once, not for every registry lookup."""
    before = _CURRENT
    activate(project if project is not None else current())
    try:
        yield current()
    finally:
        activate(before)
