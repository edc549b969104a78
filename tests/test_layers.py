"""The floor plan: kartci's packages import one way. Measured from the code's own imports by
tools/layers.py (an import inside a function counts: it is a dependency all the same)."""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

from layers import Edge, cycles, edges, levels


def test_no_cycle() -> None:
    """No two packages import each other, directly or around a loop (issue 25 untied the last)."""
    assert cycles(edges()) == []


def test_the_metric_engine_imports_no_robot_kind() -> None:
    """A kind's metrics live with the kind (`kartci.robots.<kind>.metrics`) and import the
    engine; the engine learns a robot's outline from its registered kind, never from its code."""
    assert [e.where for e in edges() if (e.source, e.target) == ("kartci.metrics",
                                                                 "kartci.robots")] == []


def test_the_contracts_do_not_import_the_project() -> None:
    """`kartci.core` is handed a project (`kartci.core.loading.PluginSource`) by its callers;
    it never looks one up from the working directory itself (issue 41)."""
    assert [e.where for e in edges()
            if (e.source, e.target) == ("kartci.core", "kartci.project")] == []


ROOT = Path(__file__).resolve().parents[1] / "kartci"
KINDS = ROOT / "robots"


def kind_names() -> list[str]:
    """kartci's own robot kinds: the packages in kartci/robots/ (each registers one kind)."""
    return sorted(p.name for p in KINDS.iterdir() if (p / "__init__.py").is_file())


def _is_shim(tree: ast.Module) -> bool:
    """A declared deprecated re-export: its docstring says so and it holds nothing but imports
    and `__all__` (so no code can hide behind the declaration)."""
    doc = ast.get_docstring(tree) or ""
    body = tree.body[1:] if ast.get_docstring(tree) is not None else tree.body
    return doc.startswith("Deprecated:") and all(
        isinstance(n, ast.Import | ast.ImportFrom)
        or (isinstance(n, ast.Assign) and [ast.unparse(t) for t in n.targets] == ["__all__"])
        for n in body)


def _identifiers(tree: ast.Module) -> list[tuple[int, str]]:
    """Every name a module defines or uses, with its line."""
    out: list[tuple[int, str]] = []
    for n in ast.walk(tree):
        if isinstance(n, ast.Name):
            out.append((n.lineno, n.id))
        elif isinstance(n, ast.Attribute):
            out.append((n.lineno, n.attr))
        elif isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            out.append((n.lineno, n.name))
        elif isinstance(n, ast.arg | ast.keyword) and n.arg is not None:
            out.append((n.lineno, n.arg))
        elif isinstance(n, ast.alias):
            out.append((n.lineno, n.asname or n.name))
        elif isinstance(n, ast.ImportFrom) and n.module:
            out.append((n.lineno, n.module))
    return out


def kind_mentions(kinds: list[str], root: Path = ROOT) -> list[str]:
    """Every place outside kartci/robots/ (and the declared deprecated re-exports) that names
    one of `kinds`: in a string (docstrings, help texts, module paths given as text) as a whole
    word (`gokart`, `models/gokart/...`, not `kart_simreal`), or in an identifier
    (`GokartModel`, `line_tracker_sweep`), with its file and line."""
    word = re.compile("|".join(rf"(?<![A-Za-z0-9]){re.escape(k)}(?![A-Za-z0-9])" for k in kinds))
    squashed = [k.replace("_", "") for k in kinds]
    found = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        if rel.parts[0] in ("robots", "data"):  # the kinds themselves; shipped-asset scripts
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        if _is_shim(tree):
            continue
        where = f"kartci/{rel.as_posix()}"
        for n in ast.walk(tree):
            if isinstance(n, ast.Constant) and isinstance(n.value, str):
                hit = word.search(n.value)
                if hit:
                    found.append(f"{where}:{n.lineno}: {hit[0]!r} in a string")
        for line, name in _identifiers(tree):
            if any(k in name.lower().replace("_", "") for k in squashed):
                found.append(f"{where}:{line}: identifier {name}")
    return found


def test_no_module_outside_the_kinds_imports_one() -> None:
    """Kind-neutral code learns what it needs of a robot from its registered `RobotKind`
    (footprint, topics, wheel odometry, joystick, replay, sim-vs-real, commands), never from
    the kind's code; only the declared deprecated re-exports import a kind."""
    shims = {f"kartci/{p.relative_to(ROOT).as_posix()}" for p in ROOT.rglob("*.py")
             if _is_shim(ast.parse(p.read_text(encoding="utf-8")))}
    assert [e.where for e in edges() if e.target == "kartci.robots" and e.source != e.target
            and e.where.rpartition(":")[0] not in shims] == []


def test_no_module_outside_the_kinds_names_one() -> None:
    """No string or identifier outside kartci/robots/ names a robot kind (issue 25)."""
    assert kind_names() == ["gokart", "line_tracker"]  # the scan below knows what to look for
    assert kind_mentions(kind_names()) == []


WORLDS = ROOT / "worlds"


def world_kind_names(root: Path = WORLDS) -> list[str]:
    """kartci's own world kinds: the packages in kartci/worlds/ that export a `WORLD` (the
    others, like `track`, hold what several kinds share)."""
    return sorted(p.parent.name for p in root.glob("*/__init__.py")
                  if any(isinstance(n, ast.Assign) and [ast.unparse(t) for t in n.targets]
                         == ["WORLD"] for n in ast.parse(p.read_text(encoding="utf-8")).body))


def world_kind_imports(kinds: list[str], root: Path = ROOT) -> list[str]:
    """Every import of a world kind's package (`kartci.worlds.<kind>...`) from outside it,
    robot kinds aside (a robot built for one world, the line tracker for the line lab, may know
    it), with its file and line."""
    found = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        if rel.parts[0] == "robots":
            continue
        for n in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(n, ast.Import | ast.ImportFrom):
                continue
            names = ([a.name for a in n.names] if isinstance(n, ast.Import) else
                     [n.module or ""])
            for name in names:
                parts = name.split(".")
                if (parts[:2] == ["kartci", "worlds"] and len(parts) > 2 and parts[2] in kinds
                        and rel.parts[:2] != ("worlds", parts[2])):
                    found.append(f"kartci/{rel.as_posix()}:{n.lineno}: {name}")
    return found


def test_no_shared_module_imports_a_world_kind() -> None:
    """Kind-neutral code learns a world from its registered `WorldKind` (and what the track
    worlds share from `kartci.worlds.track`), never from one kind's package (issue 41)."""
    assert world_kind_names() == ["circuit", "hall", "line_lab"]  # what the scan looks for
    assert world_kind_imports(world_kind_names()) == []


def test_the_world_kind_scan_finds_what_it_looks_for(tmp_path: Path) -> None:
    """The scan is not vacuous: an import of a kind from shared code is caught; a kind's own
    import of itself, a robot kind's, and an import of the shared track package are not."""
    for folder in ("worlds/line_lab", "robots/line_tracker", "sim"):
        (tmp_path / folder).mkdir(parents=True)
    (tmp_path / "worlds/line_lab/__init__.py").write_text("WORLD = None\n")
    (tmp_path / "worlds/line_lab/world.py").write_text(
        "from kartci.worlds.line_lab.course import StraightCourse\n")
    (tmp_path / "robots/line_tracker/robot.py").write_text(
        "from kartci.worlds.line_lab import LineLabWorld\n")
    (tmp_path / "sim/mod.py").write_text("from kartci.worlds.track import Track\n"
                                         "import kartci.worlds.line_lab.world\n")
    assert world_kind_names(tmp_path / "worlds") == ["line_lab"]
    assert world_kind_imports(["line_lab"], tmp_path) == [
        "kartci/sim/mod.py:2: kartci.worlds.line_lab.world"]


def test_the_kind_scan_finds_what_it_looks_for(tmp_path: Path) -> None:
    """The scan is not vacuous: an import, a string and an identifier are each caught; a
    declared re-export and a word that merely contains a kind's name are not."""
    (tmp_path / "robots").mkdir()
    (tmp_path / "mod.py").write_text(
        '"""Drives any robot."""\n'
        "from kartci.robots.gokart.params import GokartModel\n"
        "DEFAULT = {'kind': 'line_tracker'}\n"
        "SCENARIO = 'kart_simreal'\n"
        "def drive(line_tracker_model: object) -> None: ...\n")
    (tmp_path / "shim.py").write_text('"""Deprecated: import from `kartci.robots.gokart`."""\n'
                                      "from kartci.robots.gokart import GokartModel\n"
                                      '__all__ = ["GokartModel"]\n')
    assert sorted(kind_mentions(["gokart", "line_tracker"], tmp_path)) == [
        "kartci/mod.py:2: identifier GokartModel",
        "kartci/mod.py:2: identifier kartci.robots.gokart.params",
        "kartci/mod.py:3: 'line_tracker' in a string",
        "kartci/mod.py:5: identifier line_tracker_model",
    ]


def _import_runs(body: list[ast.stmt]) -> list[list[ast.Import | ast.ImportFrom]]:
    """The runs of consecutive import statements in one block of statements."""
    runs: list[list[ast.Import | ast.ImportFrom]] = []
    previous: ast.stmt | None = None
    for stmt in body:
        if isinstance(stmt, ast.Import | ast.ImportFrom):
            if isinstance(previous, ast.Import | ast.ImportFrom):
                runs[-1].append(stmt)
            else:
                runs.append([stmt])
        previous = stmt
    return runs


def _reason(line: str) -> str:
    """The text of a `#` comment on a line, pragmas (noqa, type: ignore) left out."""
    text = line.partition("#")[2]
    return re.sub(r"\b(noqa|type:\s*ignore)\b(\[[^]]*\]|:\s*[A-Z0-9, ]+)?", "", text).strip()


def unexplained_late_imports(root: Path = ROOT) -> list[str]:
    """Every import made inside a function without a `#` comment saying why it is late: on the
    import's own line, or on the line above the run of imports it belongs to."""
    found = []
    for path in sorted(root.rglob("*.py")):
        lines = path.read_text(encoding="utf-8").splitlines()
        tree = ast.parse("\n".join(lines))
        seen: set[int] = set()
        for func in ast.walk(tree):
            if not isinstance(func, ast.FunctionDef | ast.AsyncFunctionDef):
                continue
            for node in ast.walk(func):
                for block in (getattr(node, f, None) for f in ("body", "orelse", "finalbody")):
                    if not isinstance(block, list):
                        continue
                    for run in _import_runs(block):
                        above = lines[run[0].lineno - 2] if run[0].lineno > 1 else ""
                        heads = _reason(above) if above.strip().startswith("#") else ""
                        for imp in run:
                            own = any(_reason(line) for line in
                                      lines[imp.lineno - 1:(imp.end_lineno or imp.lineno)])
                            if id(imp) not in seen and not (heads or own):
                                found.append(f"kartci/{path.relative_to(root).as_posix()}:"
                                             f"{imp.lineno}: {ast.unparse(imp)}")
                            seen.add(id(imp))
    return found


def test_every_late_import_says_why() -> None:
    """Imports inside functions are left only for optional dependencies and start-up cost
    (`kartci --help`, the pytest plugin's load, `import kartci`), each with a one-line `#`
    reason; any other import belongs at the top of its module (issue 25)."""
    assert unexplained_late_imports() == []


def test_the_late_import_scan_finds_what_it_looks_for(tmp_path: Path) -> None:
    """The scan is not vacuous: an import without a reason is caught (a pragma is no reason);
    one with a reason on its line or above its run of imports is not, nor a top-level one."""
    (tmp_path / "mod.py").write_text(
        "import os\n"
        "def f() -> None:\n"
        "    # optional dependency: ray\n"
        "    import ray\n"
        "\n"
        "    from ray import util\n"
        "    x = 1\n"
        "    import json\n"
        "    import csv  # noqa: F401\n"
        "    if x:\n"
        "        import zenoh  # optional dependency: zenoh\n"
        "    class K:\n"
        "        def g(self) -> None:\n"
        "            import sqlite3\n")
    assert unexplained_late_imports(tmp_path) == [
        "kartci/mod.py:8: import json",
        "kartci/mod.py:9: import csv",
        "kartci/mod.py:14: import sqlite3",
    ]


def test_levels_put_every_import_above_what_it_imports() -> None:
    """`tools/layers.py --levels`: the longest import path down, so every arrow points down."""
    tiny = [Edge("a", "b", "", False), Edge("b", "c", "", False), Edge("a", "c", "", True)]
    assert levels(tiny) == {0: ["c"], 1: ["b"], 2: ["a"]}
    found = edges()
    at = {name: k for k, names in levels(found).items() for name in names}
    assert [e.where for e in found if at[e.source] <= at[e.target]] == []


# Where `kartci.project.current()` may be read: the entry points, which find the project a
# command, a Python call or a test session runs in and hand it down (issue 41). Everything
# below them is handed its `Project` (or a `Scenario` carrying one, `Scenario.project`).
ENTRY_POINTS = ("cli/", "command_options.py", "api.py", "pytest_plugin.py", "testing.py",
                "gym/", "project.py")


def project_lookups(root: Path = ROOT) -> list[str]:
    """Every read of the active project (`project.current()`, or `current` imported from
    `kartci.project`) outside the entry points, with its file and line."""
    found = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        if rel.startswith(ENTRY_POINTS):
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for n in ast.walk(tree):
            if (isinstance(n, ast.Attribute) and n.attr == "current"
                    and isinstance(n.value, ast.Name) and n.value.id == "project"):
                found.append(f"kartci/{rel}:{n.lineno}: project.current")
            elif isinstance(n, ast.ImportFrom) and n.module == "kartci.project" and any(
                    a.name == "current" for a in n.names):
                found.append(f"kartci/{rel}:{n.lineno}: from kartci.project import current")
    return sorted(found)


def test_only_the_entry_points_look_the_project_up() -> None:
    """The CLI, `kartci.api`, the pytest plugin (and the other public entry points: the
    Gymnasium envs, `kartci.testing.check_kind`) read the working directory's project; the
    code below them is handed it (issue 41)."""
    assert project_lookups() == []


def test_the_project_lookup_scan_finds_what_it_looks_for(tmp_path: Path) -> None:
    """The scan is not vacuous: a call, a reference and an imported `current` are caught;
    an entry point's own reads and another `current` are not."""
    (tmp_path / "cli").mkdir()
    (tmp_path / "cli/run.py").write_text("from kartci import project\nP = project.current()\n")
    (tmp_path / "deep.py").write_text("from kartci import project\n"
                                      "from kartci.project import current\n"
                                      "A = project.current()\n"
                                      "B = project.current\n"
                                      "C = other.current()\n")
    assert project_lookups(tmp_path) == ["kartci/deep.py:2: from kartci.project import current",
                                         "kartci/deep.py:3: project.current",
                                         "kartci/deep.py:4: project.current"]
