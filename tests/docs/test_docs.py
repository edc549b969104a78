"""The documentation site (docs/): it builds strictly, a broken reference fails it, its examples
run, and its generated reference shows every command, option, metric and scenario field.

What runs on a page (docs/index.md says the same to its readers):

- every ```` ```console ```` block, in order, in one empty folder per page: a `$ ` line is a
  command (ending in `\\` continues it); a `# exit N` comment wants exit code N, else 0; every
  other non-empty line must appear in what that command printed (whitespace, the tables'
  box drawing and emoji collapsed);
- a ```` ```{code-block} LANG ```` with `:caption: PATH` and `:class: file` is written to PATH;
- a ```` ```{code-block} python ```` with `:class: run` runs with Python in that folder;
- a command or Python block that cannot run here (a real team's ROS 2 install, a remote Ray
  cluster, GitHub itself) is a ```` ```{code-block} bash ```` (or python) with `:class: shown`
  and `:caption: Not run by the tests: REASON`, so the page says why. Any other shell or Python
  block fails `test_every_command_block_runs_or_says_why_not`.

Building the site takes about 20 s here (one build, shared by the reference checks); the pages
in QUICK_PAGES run their examples in the default tier, the others (more than ~10 s each) and
the broken-reference builds are `long` (`KARTCI_LONG=1`, which .ci/run's second pytest sets).
"""

from __future__ import annotations

import html
import os
import re
import shutil
import subprocess
import sys
import tomllib
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import typer
from helpers import kartci_shell_env

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
FENCE = re.compile(r"^(?P<ticks>```+)(?P<info>[^\n`]*)\n(?P<body>.*?)^(?P=ticks)[ \t]*$",
                   re.MULTILINE | re.DOTALL)
OPTION = re.compile(r"^:([\w-]+):[ \t]*(.*)$")
EXIT = re.compile(r"#\s*exit\s+(\d+)\s*$")
# the tables' box drawing and the verdicts' emoji: a table cell reads as its words
BOX = re.compile("[\u2500-\u257f\u2600-\u27bf\ufe0f\U0001f000-\U0001ffff]")



@dataclass(frozen=True)
class Block:
    """One fenced block of a page: its language, directive options, text and line."""

    page: Path
    line: int
    lang: str
    options: dict[str, str] = field(default_factory=dict)
    text: str = ""

    @property
    def where(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"

    @property
    def classes(self) -> set[str]:
        return set(self.options.get("class", "").split())


def blocks(page: Path) -> list[Block]:
    text = page.read_text(encoding="utf-8")
    out = []
    for m in FENCE.finditer(text):
        info = m.group("info").strip()
        body = m.group("body")
        options: dict[str, str] = {}
        if info.startswith("{code-block}"):
            lang = info.removeprefix("{code-block}").strip()
            lines = body.splitlines(keepends=True)
            while lines and (opt := OPTION.match(lines[0].rstrip("\n"))):
                value = opt.group(2).strip()
                quoted = len(value) > 1 and value[0] == value[-1] and value[0] in "'\""
                options[opt.group(1)] = value[1:-1] if quoted else value  # as MyST reads it
                lines.pop(0)
            body = "".join(lines).lstrip("\n")
        else:
            lang = info.split()[0] if info else ""
        out.append(Block(page, text.count("\n", 0, m.start()) + 1, lang, options, body))
    return out


def pages() -> list[Path]:
    return sorted(p for p in DOCS.rglob("*.md") if "_build" not in p.parts)


def runnable(page: Path) -> list[Block]:
    return [b for b in blocks(page) if b.lang == "console" or "file" in b.classes
            or (b.lang == "python" and "run" in b.classes)]


RUN_PAGES = [p for p in pages() if runnable(p)]
# pages whose examples take under ~10 s on a loaded 2-core machine: run in the default tier
QUICK_PAGES = {"howto/project.md", "howto/real-logs.md", "howto/ros2-dds.md"}
# pages whose blocks another test runs or checks
OWN_TESTS = {"tutorial.md": "tests/docs/test_tutorial.py runs or checks every block"}
# fenced blocks that hold commands or Python: each runs or says why it cannot
CODE_LANGS = {"", "bash", "sh", "shell", "console", "python", "pycon"}
SHOWN = "Not run by the tests: "


# --- quick checks of the blocks ------------------------------------------------------------

@dataclass(frozen=True)
class Command:
    text: str
    expect: int
    output: tuple[str, ...]


def commands(block: Block) -> list[Command]:
    """A console block's commands, each with its exit code and expected output lines."""
    out: list[Command] = []
    lines = block.text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        assert line.startswith("$ "), f"{block.where}: output before any command: {line!r}"
        cmd = line[2:]
        while cmd.endswith("\\") and i + 1 < len(lines):
            i += 1
            cmd = cmd[:-1] + " " + lines[i].strip()
        i += 1
        expected: list[str] = []
        while i < len(lines) and not lines[i].startswith("$ "):
            if lines[i].strip() and lines[i].strip() != "...":
                expected.append(" ".join(lines[i].split()))
            i += 1
        m = EXIT.search(cmd)
        out.append(Command(cmd, int(m.group(1)) if m else 0, tuple(expected)))
    return out


def test_the_site_has_runnable_pages() -> None:
    names = {p.relative_to(DOCS).as_posix() for p in RUN_PAGES}
    assert {"getting-started.md", "howto/scenario.md", "howto/python.md"} <= names
    assert QUICK_PAGES - names == set()


@pytest.mark.parametrize("page", RUN_PAGES, ids=lambda p: p.relative_to(DOCS).as_posix())
def test_runnable_blocks_are_well_formed(page: Path) -> None:
    for b in runnable(page):
        if b.lang == "console":
            assert commands(b), f"{b.where}: a console block without a command"
        elif "file" in b.classes:
            assert b.options.get("caption"), f"{b.where}: a file block names no path"
            assert not Path(b.options["caption"]).is_absolute(), b.where
        else:
            compile(b.text, b.where, "exec")


def _name(page: Path) -> str:
    return page.relative_to(DOCS).as_posix()


def test_every_command_block_runs_or_says_why_not() -> None:
    """A command or Python example either runs in the tests or is marked shown-not-run with the
    reason on the page: nothing is left unchecked by accident."""
    unmarked = []
    for page in pages():
        if _name(page) in OWN_TESTS:
            continue
        run = runnable(page)
        for b in blocks(page):
            if b in run:
                assert "shown" not in b.classes, f"{b.where}: runs and is marked shown"
            elif b.lang in CODE_LANGS:
                reason = b.options.get("caption", "").removeprefix(SHOWN)
                if ("shown" not in b.classes or reason == b.options.get("caption")
                        or len(reason) < 20):
                    unmarked.append(b.where)
    assert unmarked == []


def test_the_blocks_are_parsed_as_the_site_renders_them() -> None:
    """The parser above sees a shown block's caption and class, and a console block's
    commands, exit codes and expected lines."""
    page = DOCS / "howto" / "ray.md"
    shown = [b for b in blocks(page) if "shown" in b.classes]
    assert shown and all(b.options["caption"].startswith(SHOWN) for b in shown)
    block = Block(page, 1, "console", {}, "$ kartci run a \\\n   --set x=1  # exit 1\nsaid  it\n")
    assert commands(block) == [Command("kartci run a  --set x=1  # exit 1", 1, ("said it",))]


# --- the pages' examples run ---------------------------------------------------------------

def _environment(tmp_path: Path) -> dict[str, str]:
    """The shell's environment with `python` this interpreter (its environment has kartci's
    pytest plugin), tables as wide as the expected lines and `$KARTCI_SOURCE` this checkout."""
    env = kartci_shell_env(tmp_path, str(Path(sys.executable).parent))
    env["COLUMNS"] = "200"  # not a terminal's 80
    env["KARTCI_SOURCE"] = str(ROOT)  # the checkout a page copies examples/ from
    return env


def run_page(page: Path, tmp_path: Path) -> None:
    """Every runnable block of `page`, in order, in `tmp_path/work`."""
    env = _environment(tmp_path)
    work = tmp_path / "work"
    work.mkdir()
    for b in runnable(page):
        if "file" in b.classes:
            path = work / b.options["caption"]
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(b.text, encoding="utf-8")
            continue
        steps = ([Command(b.text, 0, ())] if b.lang == "python" else commands(b))
        for c in steps:
            argv = [sys.executable, "-c", c.text] if b.lang == "python" else ["bash", "-c",
                                                                              c.text]
            p = subprocess.run(argv, cwd=work, env=env, capture_output=True, text=True,
                               timeout=600)
            said = " ".join(BOX.sub(" ", p.stdout + "\n" + p.stderr).split())
            where = f"{b.where}: {c.text}\nexit {p.returncode}\n{p.stdout[-3000:]}\n{p.stderr}"
            assert p.returncode == c.expect, where
            assert "Traceback" not in p.stdout + p.stderr, where
            for line in c.output:
                assert line in said, f"{where}\nexpected in the output: {line!r}"


def _tiered(page: Path) -> object:
    """A page in QUICK_PAGES runs in the default tier, any other only with KARTCI_LONG=1."""
    if _name(page) in QUICK_PAGES:
        return pytest.param(page, id=_name(page))
    return pytest.param(page, id=_name(page), marks=pytest.mark.long(
        reason="a page whose examples take more than 10 s"))


@pytest.mark.parametrize("page", [_tiered(p) for p in RUN_PAGES])
def test_page_examples_run(page: Path, tmp_path: Path) -> None:
    run_page(page, tmp_path)


# --- the strict build --------------------------------------------------------------------------

def build(src: Path, out: Path) -> subprocess.CompletedProcess[str]:
    """`sphinx-build -W --keep-going -n -b html SRC OUT`, as .ci/run runs it."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)}
    return subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-n", "-q",
                           "-b", "html", str(src), str(out)], env=env, capture_output=True,
                          text=True, timeout=900)


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    p = build(DOCS, out)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr
    assert not p.stderr.strip(), p.stderr  # -q: anything on stderr is a warning
    return out


def _copy_docs(tmp_path: Path) -> Path:
    """docs/ and the CHANGELOG it includes, copied as they lie beside each other."""
    shutil.copytree(DOCS, tmp_path / "docs", ignore=shutil.ignore_patterns("_build"))
    shutil.copy(ROOT / "CHANGELOG.md", tmp_path / "CHANGELOG.md")
    return tmp_path / "docs"


@pytest.mark.long(reason="builds the site or runs every page")
@pytest.mark.parametrize(("broken", "warning"), [
    ("[the next step](howto/no-such-page.md)", "howto/no-such-page.md"),
    ("{py:func}`kartci.no_such_function`", "kartci.no_such_function"),
])
def test_a_broken_link_or_reference_fails_the_build(tmp_path: Path, broken: str,
                                                     warning: str) -> None:
    docs = _copy_docs(tmp_path)
    page = docs / "getting-started.md"
    page.write_text(page.read_text(encoding="utf-8") + f"\nSee {broken}.\n", encoding="utf-8")
    p = build(docs, tmp_path / "out")
    assert p.returncode != 0
    problems = [line for line in p.stderr.splitlines() if "WARNING" in line or "ERROR" in line]
    assert len(problems) == 1, p.stderr
    assert "getting-started.md" in problems[0] and warning in problems[0], problems


# --- the generated reference is complete ------------------------------------------------------

def _literals(page: Path) -> set[str]:
    """Every inline literal's text on a built page (docutils splits them at spaces)."""
    text = page.read_text(encoding="utf-8")
    return {html.unescape(m) for m in re.findall(r'<span class="pre">([^<]*)</span>', text)}


def _commands(command: typer.core.TyperGroup | object, path: str,
              ctx: object = None) -> Iterator[tuple[str, object]]:
    """Walk the click group typer builds, independently of the docs extension's walk."""
    cmd: object = command
    context = cmd.context_class(cmd, info_name=path.rsplit(" ", 1)[-1],  # type: ignore[attr-defined]
                                parent=ctx)
    yield path, cmd
    for name in getattr(cmd, "list_commands", lambda _: [])(context):
        sub = cmd.get_command(context, name)  # type: ignore[attr-defined]
        if not sub.hidden:
            yield from _commands(sub, f"{path} {name}", context)


def test_every_command_and_option_is_in_the_reference(site: Path) -> None:
    from kartci.cli import app

    page = (site / "reference" / "cli.html").read_text(encoding="utf-8")
    shown = _literals(site / "reference" / "cli.html")
    walked = list(_commands(typer.main.get_command(app), "kartci"))
    assert len(walked) > 20
    for path, cmd in walked:
        assert f'id="cli-{path.replace(" ", "-")}"' in page, path
        for param in cmd.params:  # type: ignore[attr-defined]
            if param.hidden:
                continue
            names = ([param.name.upper()] if param.param_type_name == "argument"
                     else [*param.opts, *param.secondary_opts])
            for name in names:
                assert name in shown or f"{name}..." in shown, f"{path} {name}"


def test_every_file_a_page_asks_for_is_named_before_it() -> None:
    """A block the tests write to a file (`file=NAME`) is preceded by text naming NAME: the
    site does not show the info string, and a reader must know where the text goes."""
    unnamed = []
    for page in pages():
        lines = page.read_text(encoding="utf-8").splitlines()
        for i, line in enumerate(lines):
            found = re.match(r"^```\S+ file=(\S+)", line)
            if found is None:
                continue
            before = [ln for ln in lines[:i] if ln.strip()][-1:]
            if not before or f"`{found.group(1)}`" not in before[0]:
                unnamed.append(f"{page.name}:{i + 1} {found.group(1)}")
    assert unnamed == []


def test_every_command_is_at_a_glance() -> None:
    """"Commands at a glance" has a row for every command a user can run (a kind's own
    commands included): a new command without one fails here, not in a user's search."""
    from kartci.cli import app

    text = (DOCS / "reference" / "commands.md").read_text(encoding="utf-8")
    rows = {m.group(1) for m in re.finditer(r"^\| `kartci ([a-z0-9_-]+)", text, re.MULTILINE)}
    rows |= {name for line in text.splitlines() if line.startswith("| `kartci ")
             for name in re.findall(r"kartci ([a-z0-9_-]+)", line.split("|")[1])}
    top = [path.split(" ")[1] for path, _ in _commands(typer.main.get_command(app), "kartci")
           if path.count(" ") == 1]
    assert len(top) > 20
    assert [name for name in top if name not in rows] == []


def test_every_registered_metric_is_in_the_reference(site: Path) -> None:
    from kartci import core

    shown = _literals(site / "reference" / "metrics.html")
    sets = core.METRICS.all()
    assert len(sets) >= 9
    for mset in sets:
        assert mset.name in shown, mset.name
        for name, d in mset.defs.items():
            assert name in shown, f"{mset.name}.{name}"
            assert d.description.split("`")[0][:40] in html.unescape(
                (site / "reference" / "metrics.html").read_text(encoding="utf-8")), name


def _properties(node: object) -> Iterator[str]:
    """Every property name anywhere in a JSON Schema."""
    if isinstance(node, dict):
        props = node.get("properties")
        if isinstance(props, dict):
            yield from props
        for value in node.values():
            yield from _properties(value)
    elif isinstance(node, list):
        for value in node:
            yield from _properties(value)


def test_every_scenario_field_is_in_the_reference(site: Path) -> None:
    from kartci.scenario.schema import scenario_schema

    shown = _literals(site / "reference" / "schema.html")
    fields = set(_properties(scenario_schema()))
    assert len(fields) > 150
    assert sorted(fields - shown) == []


def test_every_profile_and_project_field_is_in_the_reference(site: Path) -> None:
    from kartci.project import ProjectConfig
    from kartci.realdata.profile import Profile

    for page, model in (("profile", Profile), ("project", ProjectConfig)):
        shown = _literals(site / "reference" / f"{page}.html")
        fields = set(_properties(model.model_json_schema()))
        assert len(fields) > 5, page
        assert sorted(fields - shown) == [], page


def test_every_builtin_scenario_is_in_the_reference(site: Path) -> None:
    from kartci import project

    shown = _literals(site / "reference" / "scenarios.html")
    names = {p.stem for p in project.BUILTIN_SCENARIOS.glob("*.yaml")}
    assert len(names) > 15
    assert sorted(names - shown) == []


def test_the_changelog_and_the_kept_pages_are_in_the_site(site: Path) -> None:
    for page in ("changelog.html", "tutorial.html", "line_tracker_study.html",
                 "getting-started.html"):
        assert (site / page).is_file(), page
    assert "Unreleased" in (site / "changelog.html").read_text(encoding="utf-8")


# --- the [docs] extra -------------------------------------------------------------------------

AUTO = re.compile(r"^\.\. (currentmodule|auto\w+):: (\S+)", re.MULTILINE)


def _kartci_requires() -> list[str]:
    """kartci's requirements as pyproject.toml has them now (installed metadata may be older)."""
    table = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    return [*table["dependencies"], *(f'{r}; extra == "{extra}"' for extra, reqs in
                                      table["optional-dependencies"].items() for r in reqs)]


def _closure(names: set[str], extras: tuple[str, ...] = ()) -> set[str]:
    """Distributions `names` need, themselves included (their extras' only for kartci's own
    `extras`): kartci's from pyproject.toml, the others' from what is installed here."""
    from importlib import metadata

    from packaging.requirements import Requirement
    from packaging.utils import canonicalize_name

    seen: set[str] = set()
    todo = [canonicalize_name(n) for n in names]
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        try:
            requires = _kartci_requires() if name == "kartci" else metadata.requires(name) or []
        except metadata.PackageNotFoundError:
            continue
        for text in requires:
            req = Requirement(text)
            wanted = extras if name == "kartci" else ()
            if req.marker is None or any(req.marker.evaluate({"extra": e}) for e in wanted) or (
                    req.marker.evaluate({"extra": ""})):
                todo.append(canonicalize_name(req.name))
                if name == "kartci" and canonicalize_name(req.name) == "kartci":
                    extras = (*extras, *req.extras)  # kartci[dev] names kartci[docs]
    return seen


def test_the_docs_extra_alone_imports_everything_the_site_documents() -> None:
    """`pip install 'kartci[docs]'` must build the site on its own: autodoc and the site's own
    directives import these modules, so with every distribution only [dev] brings made
    unimportable, each must still import (kartci.pytest_plugin needs pytest, a base
    dependency; kartci.gym needs Gymnasium: [docs] has it). The cheap proof; the strict build
    itself runs in the full tier."""
    from importlib import metadata

    from packaging.utils import canonicalize_name

    docs_side = _closure({"kartci"}, ("docs",))
    dev_only = _closure({"kartci"}, ("dev",)) - docs_side
    owners = metadata.packages_distributions()
    blocked = sorted(top for top, dists in owners.items()
                     if {canonicalize_name(d) for d in dists} <= dev_only)
    assert "hypothesis" in blocked  # a dev-only distribution: the check can see a gap
    modules = {"kartci_docs"}
    for page in DOCS.rglob("*.md"):
        current = "kartci"
        for directive, target in AUTO.findall(page.read_text(encoding="utf-8")):
            if directive == "currentmodule":
                current = target
            else:
                modules.add(target if target.startswith("kartci") else current)
    script = (
        "import importlib, sys\n"
        f"blocked = set({blocked!r})\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.partition('.')[0] in blocked:\n"
        "            raise ImportError(f'{name} is not installed by kartci[docs]')\n"
        "sys.meta_path.insert(0, Block())\n"
        f"sys.path[:0] = [{str(DOCS / '_ext')!r}, {str(ROOT)!r}]\n"
        f"for target in sorted({sorted(modules)!r}):\n"
        "    parts = target.split('.')\n"
        "    for n in range(len(parts), 0, -1):\n"
        "        try:\n"
        "            importlib.import_module('.'.join(parts[:n]))\n"
        "            break\n"
        "        except ModuleNotFoundError as err:\n"
        "            if err.name != '.'.join(parts[:n]):\n"
        "                raise\n")
    p = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
