"""kartci's pytest plugin (entry point `pytest11: kartci`): scenarios as tests, and a fixture.

- `pytest scenarios/` collects every kartci scenario file there as one test item, named after
  the file (`-k line_straight`), marked `kartci` and with the scenario's `tags:` as markers
  (`-m "not slow"`). The item runs the scenario into a temporary folder, judges it against the
  project's baselines as `kartci run` does (a baseline accepted from an earlier version of the
  file is judged and called stale) and fails with the verdict table when a metric regressed or
  a criterion failed, as `kartci run` would exit 1. Scenario files are collected only under
  paths given on the command line and in the project's own scenario folders (`[tool.kartci]
  scenarios`), and only YAML with top-level `world:` and `agents:`: other YAML in a repository
  is left alone.
- The `kartci_run` fixture runs a scenario with overrides (and agent objects) for a test of
  your own: `result = kartci_run("line_straight", "duration_s=3")` returns a
  `kartci.RunResult`.

Options: `--kartci-out DIR` keeps the scenario items' runs in DIR/<scenario>/ (default: pytest's
temporary folders), `--kartci-baselines DIR` judges them against DIR (default: the project's
baselines), `--kartci-accept` stores each scenario item's run as its scenario's baseline instead
of judging it (`kartci.app.accept`, the function behind `kartci baseline update`; its criteria
still apply) and lists what changed at the end of the session, `--kartci-shard I/N` keeps only
share I of N of the scenario items (dealt as `kartci run --shard` deals them, by
`kartci.app.suite.shard_of`; with `--kartci-out`, DIR is marked as that share, so `kartci merge`
joins the shards' DIRs and names a share that never reported). Works with pytest-xdist
(`-n 2`): every run has its own folder.

Accepting is an option on the scenario items, not a method of the `kartci_run` fixture: it is a
decision about the scenario files as written, taken for a whole session as `kartci baseline
update` is after `kartci run`; a test's own runs carry overrides and agent objects, so they are
not the scenario's (a test that means to accept one calls `kartci.accept_baselines(result)`).

The plugin loads in every pytest session of an environment with kartci installed, so kartci
itself (pydantic, the simulator) is imported inside the hooks that need it, not here.
"""

from __future__ import annotations

import re
import tempfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import pytest

from kartci.errors import KartciError

if TYPE_CHECKING:
    from _pytest._code.code import TerminalRepr

    from kartci.api import RunResult

SCENARIO_KEYS = re.compile(r"^(world|agents)\s*:", re.MULTILINE)
_ROOTS = pytest.StashKey[tuple[Path, ...]]()
ACCEPTED = "kartci_accepted"  # user property: what --kartci-accept wrote, for the summary


def pytest_addoption(parser: pytest.Parser) -> None:
    """`--kartci-out`, `--kartci-baselines` and `--kartci-accept`."""
    group = parser.getgroup("kartci", "kartci scenarios")
    group.addoption("--kartci-out", metavar="DIR", default=None,
                    help="keep the scenario items' runs in DIR/<scenario>/ (default: pytest's "
                         "temporary folders)")
    group.addoption("--kartci-baselines", metavar="DIR", default=None,
                    help="judge scenario items against the baselines in DIR (default: the "
                         "project's baselines folder)")
    group.addoption("--kartci-accept", action="store_true", default=False,
                    help="store each scenario item's run as its baseline (as `kartci baseline "
                         "update`) instead of judging it; criteria still apply")
    group.addoption("--kartci-shard", metavar="I/N", default=None,
                    help="run share I of N of the scenario items (as `kartci run --shard`); "
                         "with --kartci-out, DIR is a partial result for `kartci merge`")


def pytest_configure(config: pytest.Config) -> None:
    """Register the `kartci` marker every scenario item carries."""
    config.addinivalue_line("markers", "kartci: a kartci scenario file run as a test")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """With `--kartci-shard I/N`: deselect the scenario items of the other shares (other tests
    stay), and with `--kartci-out` mark DIR as that share of the items collected."""
    given = config.getoption("kartci_shard")
    if not given:
        return
    # late, these two: the runner (the simulator), only when scenario items are sharded
    from kartci.app.suite import shard_of
    from kartci.runner.jobs import parse_shard

    try:
        part = parse_shard(given)
    except KartciError:
        raise pytest.UsageError(f"--kartci-shard {given!r}: expected I/N with 1 <= I <= N, "
                                "e.g. 1/4") from None
    names = [item.name for item in items if isinstance(item, ScenarioItem)]
    mine = shard_of(names, part)
    dropped = [i for i in items if isinstance(i, ScenarioItem) and i.name not in mine]
    if dropped:
        config.hook.pytest_deselected(items=dropped)
        items[:] = [i for i in items if i not in dropped]
    kept = config.getoption("kartci_out")
    if kept:
        from kartci.runner.merge import write_marker  # late: as above

        out = Path(kept).resolve()
        out.mkdir(parents=True, exist_ok=True)
        write_marker(out, *part, sorted(mine))


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    """With `--kartci-accept`: what each scenario item wrote into its baseline (the reports
    carry it, so xdist workers' items are listed too)."""
    texts = [value for reports in terminalreporter.stats.values() for r in reports
             if getattr(r, "when", None) == "call"
             for name, value in getattr(r, "user_properties", ()) if name == ACCEPTED]
    if texts:
        terminalreporter.write_sep("-", "kartci baselines accepted")
        for text in texts:
            terminalreporter.write_line(str(text))


def _roots(config: pytest.Config) -> tuple[Path, ...]:
    """Where scenario files are collected: the paths given on the command line, and the
    project's own scenario folders (the same in every xdist worker)."""
    roots = config.stash.get(_ROOTS, None)
    if roots is not None:
        return roots
    found: list[Path] = []
    if config.args_source is pytest.Config.ArgsSource.ARGS:
        here = config.invocation_params.dir
        for arg in config.args:
            found.append((here / arg.split("::", 1)[0]).resolve())
    try:
        from kartci import project  # late: pydantic, once a session meets a YAML file

        found += [p.resolve() for p in project.current().scenarios]
    except KartciError:
        pass  # a broken [tool.kartci] table: only explicit paths (the items will say why)
    config.stash[_ROOTS] = roots = tuple(found)
    return roots


def _is_scenario(path: Path) -> bool:
    """A YAML file with `world:` and `agents:` at its top level."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return False
    return {m.group(1) for m in SCENARIO_KEYS.finditer(text)} == {"world", "agents"}


def pytest_collect_file(file_path: Path, parent: pytest.Collector) -> ScenarioFile | None:
    """A kartci scenario file under a collected root becomes a `ScenarioFile`."""
    if file_path.suffix not in (".yaml", ".yml"):
        return None
    path = file_path.resolve()
    if not any(path == r or r in path.parents for r in _roots(parent.config)):
        return None
    if not _is_scenario(path):
        return None
    node: ScenarioFile = ScenarioFile.from_parent(parent, path=file_path)
    return node


def _tags(path: Path) -> list[str]:
    """The scenario's `tags:` as marker names (anything but letters, digits and _ becomes _);
    a file that does not parse has none (its item reports the problem when it runs)."""
    from kartci.scenario.yamlio import read_yaml  # late: PyYAML, once a scenario file is found

    try:
        data = read_yaml(path)
    except KartciError:
        return []
    tags = data.get("tags")
    if not isinstance(tags, list | tuple):
        return []
    out = []
    for tag in tags:
        name = re.sub(r"\W", "_", str(tag))
        out.append(f"_{name}" if name[:1].isdigit() else name)
    return [t for t in dict.fromkeys(out) if t]


class ScenarioFile(pytest.File):
    """One scenario file: one test item, named after the file."""

    def collect(self) -> Iterator[ScenarioItem]:
        """The file's one item, marked `kartci` and with the scenario's tags."""
        item: ScenarioItem = ScenarioItem.from_parent(self, name=self.path.stem)
        item.add_marker("kartci")
        for tag in _tags(self.path):
            self.config.addinivalue_line("markers", f"{tag}: kartci scenario tag")
            item.add_marker(tag)
        yield item


class ScenarioFailedError(Exception):
    """A scenario ran but regressed or failed a criterion; carries its result."""

    def __init__(self, result: RunResult) -> None:
        """Fail with `result`'s verdict table."""
        super().__init__(result.table())
        self.result = result


class ScenarioItem(pytest.Item):
    """Run one scenario, judge it against the project's baselines, fail on a bad verdict."""

    def _out(self) -> Path:
        kept = self.config.getoption("kartci_out")
        if kept:
            return Path(kept).resolve()
        factory = getattr(self.config, "_tmp_path_factory", None)  # pytest's tmp_path base
        if factory is not None:
            path: Path = factory.mktemp(f"kartci-{self.name}", numbered=True)
            return path
        return Path(tempfile.mkdtemp(prefix=f"kartci-{self.name}-"))

    def runtest(self) -> None:
        """Run the scenario; raise `ScenarioFailedError` when it does not pass. With
        `--kartci-accept`, store the run as the scenario's baseline first and fail on its
        criteria only."""
        # late, these three: kartci (pydantic, the simulator) only when a scenario item runs
        from kartci import project
        from kartci.app.accept import accept
        from kartci.app.run import run_scenario
        from kartci.verdict.judging import Stale

        given = self.config.getoption("kartci_baselines")
        baselines = None if given is None else Path(given)
        # the file as written, judged as `kartci run` judges it: a baseline accepted from an
        # earlier version of the scenario is stale (a warning), not "not comparable"
        proj = project.current()
        result = run_scenario(self.path, out=self._out(), project=proj, baselines=baselines,
                              stale=Stale.WARN)
        self.user_properties.append(("kartci_log", str(result.log)))
        if self.config.getoption("kartci_accept"):
            [accepted] = accept(result.folder.parent, proj, [result.folder.name],
                                baselines=baselines)
            text = "\n".join([*accepted.lines(), *(f"warning: {w}" for w in accepted.warnings)])
            self.user_properties.append((ACCEPTED, text))
            if not all(c.ok for c in result.criteria):
                raise ScenarioFailedError(result)
            return
        if not result.passed:
            raise ScenarioFailedError(result)  # the table is the failure text
        self.add_report_section("call", "kartci", result.table())  # shown with -rP

    def repr_failure(self, excinfo: pytest.ExceptionInfo[BaseException],
                     style: Any = None) -> str | TerminalRepr:
        """The verdict table for a bad verdict, one line for a kartci error (bad input, a
        failed run), a traceback for anything else (a crashing controller)."""
        if isinstance(excinfo.value, ScenarioFailedError):
            return str(excinfo.value)
        if isinstance(excinfo.value, KartciError):
            return f"{self.path}: {type(excinfo.value).__name__}: {excinfo.value}"
        return super().repr_failure(excinfo, style=style)

    def reportinfo(self) -> tuple[Path, int | None, str]:
        """Where the item comes from, for pytest's reports."""
        return self.path, None, f"kartci scenario {self.name}"


class KartciRun(Protocol):
    """The `kartci_run` fixture's type: annotate a test's argument with it for mypy."""

    def __call__(self, scenario: str | Path, *overrides: str,
                 agents: Mapping[str, object] | None = None,
                 baselines: str | Path | None = None) -> RunResult:
        """Run `scenario` with `dotted.key=value` overrides; see `kartci.run`."""
        ...


@pytest.fixture
def kartci_run(tmp_path: Path) -> KartciRun:
    """Run a scenario for your own asserts: `kartci_run("line_straight", "duration_s=3",
    agents={"lt0": MyController()})` returns a `kartci.RunResult`. Each call runs into its own
    folder under the test's `tmp_path`; baselines default to the project's."""
    from kartci import api  # late: the simulator, only when a test asks for the fixture

    calls = 0

    def run(scenario: str | Path, *overrides: str, agents: Mapping[str, object] | None = None,
            baselines: str | Path | None = None) -> RunResult:
        nonlocal calls
        calls += 1
        return api.run(scenario, overrides=overrides, out=tmp_path / f"kartci-{calls}",
                       agents=agents, baselines=baselines)

    return run
