"""What every command shares: the typer app, consoles, common options, the verdict printout and
the one way a command ends (reports written, exit code)."""

from __future__ import annotations

from functools import cache
from importlib.metadata import entry_points
from pathlib import Path
from typing import Annotated, Any, NoReturn

import typer
from rich.table import Table
from rich.text import Text
from typer.core import TyperCommand, TyperGroup

from kartci import __version__, project
from kartci.app.suite import write_reports
from kartci.command_options import AllowOutsideOpt as AllowOutsideOpt
from kartci.command_options import OutOpt as OutOpt
from kartci.command_options import SetOpt as SetOpt
from kartci.command_options import err_console as err_console
from kartci.command_options import out_console as out_console
from kartci.command_options import out_dir as out_dir
from kartci.core.loading import plugin_failure, stdout_to_stderr
from kartci.errors import KartciError, SpecError
from kartci.report.ci import (
    annotation_lines,
    append_step_summary,
    in_github_actions,
    scenario_files,
)
from kartci.report.tables import RUN, Wording, conditioning, delta, marked, num, tolerance
from kartci.runner.gate import strict_default
from kartci.verdict import Status
from kartci.verdict.criteria import ChangeKind
from kartci.verdict.result import ScenarioResult, exit_code

COMMANDS_GROUP = "kartci.commands"  # entry points: name -> "module:attr", a typer.Typer


class WithKindCommands(TyperGroup):
    """kartci's own commands, then those robot kinds and plugins bring through the entry-point
    group `kartci.commands`: their names come from the installed metadata, and a module is
    imported only when its commands are listed or run, so `kartci --help` and shell completion
    never load the plugin registry (the kinds' simulators, the MPCC)."""

    def list_commands(self, ctx: Any) -> list[str]:  # typer's own vendored click.Context
        """kartci's commands in their order, then the plugins', then the command groups."""
        own = super().list_commands(ctx)
        extra = sorted(set(plugin_commands()) - set(own))
        groups = [n for n in own if isinstance(self.commands[n], TyperGroup)]  # listed last
        return [*(n for n in own if n not in groups), *extra, *groups]

    def get_command(self, ctx: Any, cmd_name: str) -> Any:
        """kartci's own command of that name, else a plugin's."""
        return super().get_command(ctx, cmd_name) or plugin_commands().get(cmd_name)


@cache
def plugin_commands() -> dict[str, Any]:
    """Every command the installed `kartci.commands` entry points bring, by name; a plugin
    that fails to import is skipped here and named when its command is run."""
    found: dict[str, Any] = {}
    for ep in sorted(entry_points(group=COMMANDS_GROUP), key=lambda e: e.name):
        try:
            with stdout_to_stderr():
                found.update(typer.main.get_group(ep.load()).commands)
        except BaseException as err:  # a broken plugin must not take kartci's own commands down
            if not plugin_failure(err):
                raise
            found.setdefault(ep.name, _broken(ep.name, err))
    return found


def _broken(name: str, err: BaseException) -> TyperCommand:
    """A stand-in for a plugin's commands that failed to import: running it says why."""
    def fail() -> None:
        raise KartciError(f"the commands of plugin '{name}' ({COMMANDS_GROUP}) failed to "
                          f"import: {type(err).__name__}: {err}")
    return TyperCommand(name, callback=fail, help=f"(plugin '{name}' failed to import)")


# Help text is shown as written (rich_markup_mode=None): rich markup would eat `kartci[ray]`
# and `[default: ...]`.
app = typer.Typer(add_completion=True, pretty_exceptions_enable=False, no_args_is_help=True,
                  rich_markup_mode=None, cls=WithKindCommands,
                  help="Run robot scenarios headless, record them, score them against baselines.")
baseline_app = typer.Typer(help="Inspect and update stored baselines.", no_args_is_help=True,
                           rich_markup_mode=None)
app.add_typer(baseline_app, name="baseline")


def _print_version(value: bool) -> None:
    if value:
        typer.echo(f"kartci {__version__}")
        raise typer.Exit()


@app.callback()
def _options(version: Annotated[bool, typer.Option(
        "--version", callback=_print_version, is_eager=True,
        help="Print kartci's version and exit.")] = False) -> None:
    """Run robot scenarios headless, record them, score them against baselines."""


def complete_scenario(incomplete: str) -> list[tuple[str, str]]:
    """Shell completion of scenario names (with where each comes from); reads no file, and a
    broken project completes nothing rather than printing into the shell."""
    try:
        proj = project.current()
        found = proj.all_scenarios()
    except (KartciError, OSError):
        return []
    return [(name, proj.origin_of(path).value) for name, path in found.items()
            if name.startswith(incomplete)]


BaselinesOpt = Annotated[Path | None, typer.Option(
    help="Folder of baseline files (default: the project's baselines/).")]
StrictOpt = Annotated[bool | None, typer.Option(
    "--strict/--no-strict", help="Fail a scenario without a baseline, with a metric its "
    "baseline lacks, with a stale baseline (accepted from another scenario) or a tolerance "
    "loosened beyond the policy [default: strict when the CI environment variable is set].")]


def strict_mode(flag: bool | None) -> bool:
    """`--strict/--no-strict` as given, else the default (strict under CI)."""
    return strict_default() if flag is None else flag


def baselines_dir(path: Path | None, must_exist: bool = True) -> Path:
    """`--baselines` (a folder, when it must exist), else the project's baselines folder."""
    if path is not None and must_exist and not path.is_dir():
        raise SpecError(f"--baselines {path}: no such folder")
    return path or project.current().baselines


def print_verdicts(results: list[ScenarioResult], words: Wording) -> None:
    """The verdicts on the terminal. Every user text (names, errors) goes in as plain Text:
    rich would read `[...]` in it as markup and fail on `[/oops]`."""
    for r in results:
        if r.error:
            line = Text.assemble((r.name, "bold"), f": {marked(r.status)}: {r.error}")
            out_console.print(line, highlight=False)
            continue
        table = Table("metric", "value", words.base, "delta", "tolerance", "conditioning",
                      "verdict", title=Text(f"{r.name}: {marked(r.status)}"),
                      title_justify="left")
        for v in r.verdicts:
            table.add_row(Text(v.name), num(v.value, v.unit), num(v.baseline, v.unit), delta(v),
                          tolerance(v), conditioning(v), marked(v.status))
        moved = {c.name: c for c in r.criteria_changes}
        for c in r.criteria:
            change = moved.get(c.name)
            bound = c.bound if change is None else (
                f"{c.bound} (new)" if change.kind is ChangeKind.ADDED
                else f"{c.bound} (was {change.before})")
            table.add_row(Text(f"criterion {c.name}"), num(c.value), Text(bound), "", "", "",
                          marked(Status.PASS if c.ok else Status.FAILED))
        for gone in r.criteria_changes:
            if gone.kind is ChangeKind.REMOVED:
                table.add_row(Text(f"criterion {gone.name}"), "", Text(f"was {gone.before}"),
                              "", "", "", "REMOVED")
        out_console.print(table)
        for problem in r.problems:
            out_console.print(Text(f"{r.name}: FAILED: {problem}"), highlight=False)
        for warning in r.warnings:
            err_console.print(Text(f"kartci: warning: {r.name}: {warning}"), highlight=False)


def finish(results: list[ScenarioResult], out: Path, words: Wording = RUN,
           ci: bool = True, history: Path | None = None, html: bool = True,
           static: bool = True) -> NoReturn:
    """Write every report (the HTML ones with `html`, the static page with `static` too; see
    `kartci.app.suite.write_reports`), then `conclude`."""
    conclude(results, write_reports(results, out, words, history, html, static), words, ci,
             html)


def conclude(results: list[ScenarioResult], paths: dict[str, Path], words: Wording = RUN,
             ci: bool = True, html: bool = True) -> NoReturn:
    """Print the verdicts and (unless `ci` is off, as for a shard, whose merge reports for it)
    the CI outputs of reports written to `paths`; exit with the gating code."""
    print_verdicts(results, words)
    if ci:
        append_step_summary(paths["markdown"].read_text(encoding="utf-8"))
    if ci and in_github_actions():
        try:
            files = scenario_files(results, project.current())
        except KartciError:  # a broken configuration anchors no annotation, and fails no report
            files = {}
        for line in annotation_lines(results, files=files):
            typer.echo(line)
    code = exit_code(results)
    shown = paths["html" if html else "markdown"]
    out_console.print(f"report: {shown}  (exit {code})", highlight=False)
    raise typer.Exit(code)
