"""Loading plugins: every installed entry point of kartci's groups and the project's plugin
modules, imported once per process into the registries (`kartci.core.registry`). A plugin that
fails is recorded, never raised here, and fails only what names it.

The project (its root and `plugins` list) is handed in as a `PluginSource`; without one, the
source `kartci.project` installs when imported (`set_default_source`: the project held for the
work at hand, `kartci.project.held`, else the working directory's) is asked, so the contracts
never import the project module."""

from __future__ import annotations

import contextlib
import importlib
import os
import sys
import traceback
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from functools import cache
from importlib.metadata import EntryPoints, entry_points
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from kartci.errors import PluginError, SpecError

if TYPE_CHECKING:
    from kartci.core.registry import Registry


class PluginSource(Protocol):
    """What loading needs of a project (`kartci.project.Project` is one)."""

    @property
    def root(self) -> Path:
        """The project's folder (its plugin modules are imported from there)."""
        ...

    @property
    def plugins(self) -> Sequence[str]:
        """The Python modules to import for their `register(...)` calls."""
        ...

    @property
    def config_file(self) -> Path | None:
        """The file that configures it, for messages (None: no file)."""
        ...


_DEFAULT: list[Callable[[], PluginSource]] = []


def set_default_source(source: Callable[[], PluginSource]) -> None:
    """What `load()` asks for the project when it is given none (kartci.project installs its
    `current`: the project of the working directory)."""
    _DEFAULT[:] = [source]


def _default() -> PluginSource | None:
    return _DEFAULT[0]() if _DEFAULT else None


def _registries() -> tuple[Registry[Any], ...]:
    # the registries import this module to fill themselves on first use
    from kartci.core.registry import REGISTRIES

    return REGISTRIES


@dataclass(frozen=True)
class BrokenPlugin:
    """A plugin that failed to load: reported once by its name, and only what names it fails
    (pluggy's way: the rest of the run goes on)."""

    name: str  # the entry point's name, or the project's plugin module
    where: str  # "entry point module:attr of dist 1.0, group kartci.controllers" or the config
    error: str  # "ValueError: boom": the plugin's own exception, one line
    trace: str = ""  # its traceback, written into the folder of each scenario that needs it

    @property
    def message(self) -> str:
        """One line: which plugin, from where, and its error."""
        return f"plugin '{self.name}' ({self.where}) failed to load: {self.error}"

    def failure(self) -> PluginError:
        """The error of a scenario that needs this plugin."""
        return PluginError(self.message, self.trace)


@contextlib.contextmanager
def stdout_to_stderr() -> Iterator[None]:
    """While a plugin's code is imported, whatever it prints goes to stderr, at Python's level
    (`print`) and the file descriptor's (a C extension, a child process): kartci's own stdout
    carries machine-readable output (`kartci schema > schema.json`, `kartci show`) that one
    chatty `import` must not corrupt."""
    sys.stdout.flush()
    try:
        saved: int | None = os.dup(1)
    except OSError:  # no stdout at all: nothing to protect
        saved = None
    try:
        if saved is not None:
            os.dup2(2, 1)
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        sys.stderr.flush()
        if saved is not None:
            os.dup2(saved, 1)
            os.close(saved)


def plugin_failure(err: BaseException) -> bool:
    """Whether `err`, raised by a plugin's own code while it loads, is that plugin's failure:
    every exception, `SystemExit` (a module calling `sys.exit(0)` at import must not end kartci
    with a green exit and no output) and `GeneratorExit` included; only `KeyboardInterrupt` is
    not, since a real Ctrl-C landing during an import cannot be told from one a plugin raises,
    and Ctrl-C must always stop kartci (exit 130, never a green one)."""
    return not isinstance(err, KeyboardInterrupt)


def _broken(name: str, where: str, err: BaseException) -> BrokenPlugin:
    text = " ".join(str(err).split())
    return BrokenPlugin(name, where, f"{type(err).__name__}: {text}" if text else
                        type(err).__name__, "".join(traceback.format_exception(err)))


def _entry_point_source(ep: Any) -> str:
    where = _distribution(ep)
    return f"{ep.module} (entry point{where})" if where else ep.module


def _distribution(ep: Any) -> str:
    """' of dist 1.0' for an entry point that knows its distribution."""
    dist = getattr(ep, "dist", None)
    return f" of {dist.name} {dist.version}" if dist is not None else ""


_LOADED: set[str] = set()  # "entry points" and the roots whose project plugins are imported
BROKEN_MODULES: dict[str, BrokenPlugin] = {}  # project plugin modules that failed, by module
_NAMED: set[tuple[str, str]] = set()  # (group, name): entry points imported by `load_named`


@cache
def _installed(group: str) -> EntryPoints:
    """A group's installed entry points, read once (a read scans every distribution: ~10 ms)."""
    return entry_points(group=group)


def load_named(reg: Registry[Any], name: str) -> bool:
    """Import only the entry points named `name` in `reg`'s group; True when that registered
    it. Start-up: importing every plugin costs ~0.2 s (the bridge's Zenoh, every robot kind)
    where a command names two or three. Only without project plugin modules: one of those
    may register or replace any name, so with them every plugin loads, in `load`'s order.
    A caller's own registry (a subset, a test's) is never filled from entry points."""
    proj = _default()
    if (all(reg is not r for r in _registries()) or "entry points" in _LOADED
            or (proj is not None and proj.plugins)):
        return False
    if (reg.group, name) not in _NAMED:
        _NAMED.add((reg.group, name))
        for ep in sorted(_installed(reg.group).select(name=name), key=lambda e: e.name):
            load_entry_point(reg, ep)
    return name in reg.items and name not in reg.broken


def load(project: PluginSource | None = None) -> None:
    """Import every installed plugin (entry points) and the project's plugin modules, once.
    Without `project`, the default source's (the project its caller holds active: a runner job,
    a scenario's validation, a session hold the one handed to them). A plugin
    that fails (any exception, SystemExit too) is recorded in `broken()`, never raised here:
    only the scenarios that name it fail (`Registry.get`); `plugin_failure` says what counts.
    What the plugins print while they load goes to stderr (`stdout_to_stderr`)."""
    if "entry points" not in _LOADED:
        _LOADED.add("entry points")
        for reg in _registries():
            for ep in sorted(_installed(reg.group), key=lambda e: e.name):
                if (reg.group, ep.name) not in _NAMED:
                    load_entry_point(reg, ep)
    proj = project or _default()
    if proj is None or str(proj.root) in _LOADED or not proj.plugins:
        return
    key = str(proj.root)
    _LOADED.add(key)
    if str(proj.root) not in sys.path:  # plugin modules kept in the project folder
        sys.path.insert(0, str(proj.root))
    config = proj.config_file.name if proj.config_file is not None else "the project"
    with stdout_to_stderr():
        for module in proj.plugins:
            try:
                importlib.import_module(module)
            except BaseException as err:  # a team's module: its own error, named, not "internal"
                if not plugin_failure(err):
                    raise
                BROKEN_MODULES[module] = _broken(module, f"plugin module of {config}", err)


def load_entry_point(reg: Registry[Any], ep: Any) -> None:
    """Register one entry point's object; a failure is recorded under its name."""
    where = f"entry point {ep.value}{_distribution(ep)}, group {reg.group}"
    try:
        with stdout_to_stderr():
            item = ep.load()
        if getattr(item, "name", None) != ep.name:
            raise SpecError(f"entry point '{ep.name}' must name an object whose name is "
                            f"'{ep.name}'")
        reg.register(item, source=_entry_point_source(ep))
    except BaseException as err:  # a broken plugin takes down only the scenarios that name it
        if not plugin_failure(err):
            raise
        reg.broken[ep.name] = _broken(ep.name, where, err)
