"""Reference pages generated from kartci's own code when the site is built, never written by
hand: the metric registry (`kartci-metrics`), the scenario JSON Schema that `kartci schema`
writes (`kartci-schema`), the built-in scenarios (`kartci-scenarios`) and the command line
(`kartci-cli`: the click command typer builds from kartci's app, walked command by command).
sphinx-click cannot read it: typer vendors click (`typer._click`) since 0.26, and sphinx-click
refuses commands that are not the standalone click's; sphinxcontrib-typer 0.10 fails on typer
0.29's help rendering. The walk below is what both would do, in 40 lines.

Each directive builds docutils nodes directly (text, literals, tables), so a description with
`_`, `*` or `|` in it is shown as written, never parsed as markup.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

import typer
from docutils import nodes
from docutils.parsers.rst import Directive
from sphinx.application import Sphinx

from kartci import core, project
from kartci.cli import app
from kartci.project import ProjectConfig
from kartci.realdata.profile import Profile
from kartci.scenario import load_scenario
from kartci.scenario.schema import scenario_schema

CLI = typer.main.get_command(app)  # the `kartci` click group, with the kinds' commands
Context = CLI.context_class  # typer's vendored click (typer._click).Context

_TICKS = re.compile(r"`([^`]+)`")


def inline(text: str) -> list[nodes.Node]:
    """`text` with its Markdown `code` spans as literals and nothing else interpreted."""
    out: list[nodes.Node] = []
    pos = 0
    for m in _TICKS.finditer(text):
        if m.start() > pos:
            out.append(nodes.Text(text[pos:m.start()]))
        out.append(nodes.literal(m.group(1), m.group(1)))
        pos = m.end()
    if pos < len(text):
        out.append(nodes.Text(text[pos:]))
    return out


def _cell(content: str | list[nodes.Node]) -> nodes.entry:
    para = nodes.paragraph()
    para.extend(inline(content) if isinstance(content, str) else content)
    return nodes.entry("", para)


def table(headers: list[str], rows: Iterable[list[str | list[nodes.Node]]],
          widths: list[int]) -> nodes.table:
    """A table of `headers` over `rows` (cells are text with `code` spans, or nodes)."""
    group = nodes.tgroup(cols=len(headers))
    group.extend(nodes.colspec(colwidth=w) for w in widths)
    head = nodes.thead()
    head_row = nodes.row()
    head_row.extend(_cell(h) for h in headers)
    head.append(head_row)
    body = nodes.tbody()
    for r in rows:
        row = nodes.row()
        row.extend(_cell(c) for c in r)
        body.append(row)
    group.extend([head, body])
    return nodes.table("", group, classes=["kartci-generated"])


def section(ident: str, title: str | list[nodes.Node], *children: nodes.Node) -> nodes.section:
    """A section with an anchor `ident` (linkable as `reference/<page>.md#<ident>`)."""
    sec = nodes.section(ids=[nodes.make_id(ident)], names=[nodes.fully_normalize_name(ident)])
    heading = nodes.title()
    heading.extend(inline(title) if isinstance(title, str) else title)
    sec.append(heading)
    sec.extend(children)
    return sec


def para(text: str) -> nodes.paragraph:
    """One paragraph of text with `code` spans."""
    p = nodes.paragraph()
    p.extend(inline(text))
    return p


# --- command line ----------------------------------------------------------------------------

def commands(ctx: Any = None) -> Iterator[tuple[str, Any, Any]]:
    """Every command under `kartci` (groups first, then their commands): its path, the click
    command and its context."""
    ctx = ctx or Context(CLI, info_name="kartci")
    yield ctx.command_path, ctx.command, ctx
    group = ctx.command
    if hasattr(group, "list_commands"):
        for name in group.list_commands(ctx):
            sub = group.get_command(ctx, name)
            if sub is not None and not sub.hidden:
                yield from commands(Context(sub, info_name=name, parent=ctx))


def parameters(command: Any) -> list[Any]:
    """The command's visible arguments and options (`--help` among them is click's own)."""
    return [p for p in command.params if not getattr(p, "hidden", False)]


def _default(p: Any) -> str:
    value = p.default
    if value is None or value is False or value == () or callable(value):
        return ""
    value = getattr(value, "value", value)  # an Enum's value, as typed
    return f"`{value}`"


def _param_row(p: Any, ctx: Any) -> list[str | list[nodes.Node]]:
    names = ([p.name.upper() + ("..." if p.nargs == -1 else "")]
             if p.param_type_name == "argument" else [*p.opts, *p.secondary_opts])
    cell: list[nodes.Node] = []
    for i, name in enumerate(names):
        cell.extend([nodes.Text(", ")] if i else [])
        cell.append(nodes.literal(name, name))
    kind = "" if getattr(p, "is_flag", False) else p.display_type(ctx).strip("<>")
    extra = (" (repeatable)" if p.multiple and "repeatable" not in (p.help or "") else
             " (required)" if p.required else "")
    return [cell, f"`{kind}`" if kind else "flag", _default(p), (p.help or "") + extra]


class CliDirective(Directive):
    """Every `kartci` command: usage, help text, and a table of its arguments and options."""

    def run(self) -> list[nodes.Node]:
        """One section per command, in `kartci --help` order."""
        out: list[nodes.Node] = []
        for path, command, ctx in commands():
            usage = " ".join([path, *command.collect_usage_pieces(ctx)])
            parts: list[nodes.Node] = [nodes.literal_block(usage, usage)]
            parts.extend(para(" ".join(chunk.split()))
                         for chunk in (command.help or "").split("\n\n") if chunk.strip())
            rows = [_param_row(p, ctx) for p in parameters(command)]
            if rows:
                parts.append(table(["argument / option", "type", "default", "meaning"], rows,
                                   [22, 14, 12, 52]))
            out.append(section(f"cli-{path.replace(' ', '-')}", f"`{path}`", *parts))
        return out


# --- metrics ---------------------------------------------------------------------------------

def _tolerance(d: core.MetricDef) -> str:
    return f"max({d.abs_tol:g}, {d.rel_tol:g} x baseline)" if d.rel_tol else f"{d.abs_tol:g}"


class MetricsDirective(Directive):
    """Every registered metric set and each of its metrics: unit, better direction, default
    tolerance, definition."""

    def run(self) -> list[nodes.Node]:
        """One section per metric set, in name order."""
        out: list[nodes.Node] = []
        for mset in core.METRICS.all():
            applies = ", ".join(f"`{r}`" for r in mset.robots) or "any robot kind"
            params = (f"parameters: `metrics: {{{mset.name}: {{...}}}}`, see "
                      f"`{mset.params.__name__}` in the scenario schema"
                      if mset.params is not None else "no parameters")
            rows = [[[nodes.literal(name, name)], d.unit or "-", d.direction.value,
                     _tolerance(d), d.description + (" (wall clock: a timing figure, not judged "
                                                     "for determinism)" if d.timing else "")]
                    for name, d in mset.defs.items()]
            out.append(section(
                f"metric-set-{mset.name}", f"`{mset.name}`",
                para(f"{(mset.description or '(no description)').rstrip('.')}. Applies to: "
                     f"{applies}; "
                     f"{params}; source: `{core.METRICS.sources.get(mset.name, '?')}`."),
                table(["metric", "unit", "better", "default tolerance", "definition"], rows,
                      [18, 6, 8, 14, 54])))
        return out


# --- scenario schema -------------------------------------------------------------------------

def _type(node: Mapping[str, Any]) -> str:
    if "$ref" in node:
        return node["$ref"].rsplit("/", 1)[-1]
    if "const" in node:
        return json.dumps(node["const"])
    if "enum" in node:
        return " | ".join(json.dumps(v) for v in node["enum"])
    for key in ("anyOf", "oneOf"):
        if key in node:
            return " | ".join(_type(n) for n in node[key])
    kind = node.get("type", "any")
    if kind == "array" and "items" in node:
        return f"list of {_type(node['items'])}"
    if kind == "object" and isinstance(node.get("additionalProperties"), dict):
        return f"map of {_type(node['additionalProperties'])}"
    return str(kind) if not isinstance(kind, list) else " | ".join(kind)


def _type_cell(node: Mapping[str, Any]) -> list[nodes.Node]:
    """The type, with a model's name linking to its section on the page."""
    text = _type(node)
    out: list[nodes.Node] = []
    for i, word in enumerate(re.split(r"( \| |list of |map of )", text)):
        if i % 2 == 0 and word in _DEFS:
            ref = nodes.reference(word, "", refid=nodes.make_id(f"{_DEFS_OF[0]}-{word}"))
            ref.append(nodes.literal(word, word))
            out.append(ref)
        elif word:
            out.append(nodes.literal(word, word) if i % 2 == 0 else nodes.Text(word))
    return out


_DEFS: set[str] = set()  # the `$defs` of the schema being drawn, and its name (link targets)
_DEFS_OF = ["scenario"]


def _bounds(node: Mapping[str, Any]) -> str:
    marks = (("minimum", ">="), ("exclusiveMinimum", ">"), ("maximum", "<="),
             ("exclusiveMaximum", "<"), ("pattern", "matches"), ("minLength", "length >="))
    return ", ".join(f"{word} `{node[key]}`" for key, word in marks if key in node)


def schema_rows(obj: Mapping[str, Any]) -> list[list[str | list[nodes.Node]]]:
    """One row per property of an object schema: field, type, default, bounds, meaning."""
    required = set(obj.get("required", ()))
    rows: list[list[str | list[nodes.Node]]] = []
    for name, prop in obj.get("properties", {}).items():
        default = ("(required)" if name in required else
                   f"`{json.dumps(prop['default'])}`" if "default" in prop else "")
        rows.append([[nodes.literal(name, name)], _type_cell(prop), default, _bounds(prop),
                     prop.get("description", "")])
    return rows


def objects(node: Mapping[str, Any], where: str) -> Iterator[tuple[str, Mapping[str, Any]]]:
    """Every object schema with properties inside `node` (not behind a `$ref`), by path."""
    if "properties" in node:
        yield where, node
        for name, prop in node["properties"].items():
            yield from objects(prop, f"{where}.{name}" if where else name)
    for key in ("anyOf", "oneOf", "allOf"):
        for i, sub in enumerate(node.get(key, ())):
            yield from objects(sub, _form(where, sub, i) if "properties" in sub else where)
    for key in ("items", "additionalProperties"):
        sub = node.get(key)
        if isinstance(sub, dict):
            yield from objects(sub, f"{where}[]" if key == "items" else f"{where}.<name>")


def _form(where: str, sub: Mapping[str, Any], i: int) -> str:
    """A name for one of the shapes a field takes: by its kind, and whether it names a file."""
    props = sub["properties"]
    kind = props.get("kind", {}).get("const") or props.get("type", {}).get("const")
    if kind is None:
        return f"{where} (form {i + 1})"
    return f"{where} ({kind}, {'a file with some keys replaced' if 'from' in props else 'in full'})"


def schema_fields(schema: Mapping[str, Any]) -> set[str]:
    """Every property name anywhere in the schema (what the reference must show)."""
    names: set[str] = set()
    for _, obj in objects(schema, ""):
        names.update(obj["properties"])
    for model in schema.get("$defs", {}).values():
        for _, obj in objects(model, ""):
            names.update(obj["properties"])
    return names


_HEADERS = ["field", "type", "default", "bounds", "meaning"]
_WIDTHS = [14, 16, 10, 12, 48]


def file_schemas() -> dict[str, Mapping[str, Any]]:
    """The JSON Schema of each file kartci reads, by the name the directive takes: scenario
    files (`kartci schema`), import profiles, and the project file (`kartci.toml`)."""
    return {"scenario": scenario_schema(), "profile": Profile.model_json_schema(),
            "project": ProjectConfig.model_json_schema()}


class SchemaDirective(Directive):
    """A file's JSON Schema as tables (argument: `scenario`, `profile` or `project`): the top
    level and its inline forms, then every model it refers to."""

    optional_arguments = 1

    def run(self) -> list[nodes.Node]:
        """The top-level sections, then one per `$defs` model."""
        which = self.arguments[0] if self.arguments else "scenario"
        schema = file_schemas()[which]
        defs: Mapping[str, Any] = schema.get("$defs", {})
        _DEFS.clear()
        _DEFS.update(defs)
        _DEFS_OF[0] = which
        out: list[nodes.Node] = []
        for where, obj in objects(schema, ""):
            title = f"`{where}`" if where else f"The {which} file (top level)"
            body = [para(obj["description"])] if "description" in obj else []
            out.append(section(f"{which}-path-{where or 'top'}", title, *body,
                               table(_HEADERS, schema_rows(obj), _WIDTHS)))
        for name, model in defs.items():
            parts: list[nodes.Node] = []
            if "description" in model:
                parts.append(para(model["description"]))
            if "enum" in model:
                parts.append(para("One of: " + ", ".join(f"`{json.dumps(v)}`"
                                                         for v in model["enum"]) + "."))
            for where, obj in objects(model, ""):
                if where:
                    parts.append(para(f"`{where}`:"))
                parts.append(table(_HEADERS, schema_rows(obj), _WIDTHS))
            out.append(section(f"{which}-{name}", f"`{name}`", *parts))
        return out


# --- built-in scenarios ----------------------------------------------------------------------

def builtin_scenarios() -> list[Path]:
    """The default suite's files (the wheel's, or a checkout's top-level `scenarios/`)."""
    return sorted(project.BUILTIN_SCENARIOS.glob("*.yaml"))


class ScenariosDirective(Directive):
    """Every built-in scenario: what it checks, its world, robots and controllers, how long,
    its criteria and its sweep, read from the validated scenario."""

    def run(self) -> list[nodes.Node]:
        """A table of all, then one section per scenario with its file."""
        rows: list[list[str | list[nodes.Node]]] = []
        for path in builtin_scenarios():
            spec = load_scenario(path, project=project.current())
            agents = "; ".join(
                f"`{name}`: `{a.model.kind}` driven by `{a.controller.type}`"
                for name, a in spec.agents.items())
            extra = []
            if spec.sweep:
                extra.append("sweep " + ", ".join(f"`{k}` x {len(v)}" for k, v in
                                                  spec.sweep.items()))
            if spec.criteria:
                extra.append("criteria on " + ", ".join(f"`{k}`" for k in spec.criteria))
            if spec.tags:
                extra.append("tags " + ", ".join(f"`{t}`" for t in spec.tags))
            ref = nodes.reference("", "", refid=nodes.make_id(f"scenario-{spec.name}"))
            ref.append(nodes.literal(spec.name, spec.name))
            rows.append([[ref], spec.description, f"`{spec.world.kind}`", agents,
                         f"{spec.duration_s:g} s", "; ".join(extra)])
        out: list[nodes.Node] = [table(["scenario", "what it checks", "world", "agents",
                                        "duration", "criteria, sweep, tags"], rows,
                                       [14, 34, 8, 22, 6, 16])]
        for path in builtin_scenarios():
            text = path.read_text(encoding="utf-8")
            block = nodes.literal_block(text, text, language="yaml")
            out.append(section(f"scenario-{path.stem}", f"`{path.stem}`",
                               para(f"`scenarios/{path.name}`:"), block))
        return out


# --- docstrings ------------------------------------------------------------------------------

_SINGLE = re.compile(r"(?<![`\\])`([^`\n]+)`(?!`)")


def markdown_docstring(app: Sphinx, what: str, name: str, obj: object, options: object,
                       lines: list[str]) -> None:
    """kartci's docstrings are written as Markdown (`code` spans, ``` fences), as the README:
    turn those two into reStructuredText for autodoc, in place."""
    out: list[str] = []
    fence: str | None = None
    for line in lines:
        stripped = line.strip()
        if stripped.startswith("```"):
            if fence is None:
                fence = line[: len(line) - len(line.lstrip())]
                out.extend([f"{fence}.. code-block:: {stripped[3:].strip() or 'text'}", ""])
            else:
                fence = None
                out.append("")
            continue
        out.append(f"{fence}   {line[len(fence):]}" if fence is not None else
                   _SINGLE.sub(r"``\1``", line))
    lines[:] = out


def pydantic_signature(app: Sphinx, what: str, name: str, obj: object, options: object,
                       signature: str | None, annotation: str | None
                       ) -> tuple[str | None, str | None] | None:
    """A pydantic model's constructor signature is every field with its validation metadata:
    the scenario schema reference shows the fields; the class entry shows none."""
    if what == "class" and isinstance(obj, type) and hasattr(obj, "model_fields"):
        return "", annotation
    return None


def setup(sphinx: Sphinx) -> dict[str, Any]:
    """Register the directives and the docstring hooks."""
    sphinx.connect("autodoc-process-docstring", markdown_docstring)
    sphinx.connect("autodoc-process-signature", pydantic_signature)
    sphinx.add_directive("kartci-cli", CliDirective)
    sphinx.add_directive("kartci-metrics", MetricsDirective)
    sphinx.add_directive("kartci-schema", SchemaDirective)
    sphinx.add_directive("kartci-scenarios", ScenariosDirective)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
