"""Bounded reading of spec YAML, `--set` values and data text files: bad input is one SpecError.

Scenario, world and model files, `--set` values and track CSVs come from users and from CI
configuration. A broken or hostile one must not hang the harness (a FIFO), exhaust memory
(/dev/zero, a 17 MB file, an alias bomb), or end in a traceback (`!!int x`, a recursive
alias, nesting deep enough to exhaust Python's stack). So a file must be a small regular file
before it is read, and the YAML composer counts nodes (an alias counts as the nodes it stands
for) and nesting levels as it goes, stopping at the first node past a limit.
"""

from __future__ import annotations

import contextlib
import json
import re
from pathlib import Path
from typing import Any

import yaml
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from kartci.boundedio import RefusedFileError, read_bytes, size_text
from kartci.errors import SpecError
from kartci.project import shown

SPEC_MAX_BYTES = 1 << 20  # a scenario, world or model file; the real ones are 2 KB or less
OVERRIDE_MAX_BYTES = 64 << 10  # one `--set` value
TRACK_MAX_BYTES = 8 << 20  # a track CSV; a 20 km circuit, a row a metre, is under 1 MB
YAML_MAX_NODES = 100_000  # nodes of one document with every alias expanded
YAML_MAX_DEPTH_LEVELS = 64  # nodes on the path from a document's root to its deepest leaf
YAML_INT_MAX_CHARS = 1000  # `1:2:3:...` (base 60) costs quadratic time in its length
PROBLEM_MAX_CHARS = 200  # of a YAML problem or a key echoed back in a message
_STR, _MERGE = "tag:yaml.org,2002:str", "tag:yaml.org,2002:merge"

def clip(text: str, limit_chars: int = PROBLEM_MAX_CHARS) -> str:
    """`text` on one line, cut to `limit_chars` (cut first, so a huge text costs nothing)."""
    one = " ".join(text[: limit_chars + 1].split())
    return one if len(one) <= limit_chars else one[: limit_chars - 1] + "…"


def read_bytes_bounded(path: Path, limit_bytes: int) -> bytes:
    """The bytes of a regular file of at most `limit_bytes` (kartci.boundedio.read_bytes: a
    FIFO or a device is refused without waiting or reading); a SpecError naming it otherwise."""
    try:
        return read_bytes(path, limit_bytes)
    except FileNotFoundError as err:
        raise SpecError(f"{shown(path)}: file not found") from err
    except RefusedFileError as err:
        raise SpecError(f"{shown(path)}: {err}") from err
    except (OSError, ValueError) as err:  # ValueError: a NUL character in the path
        reason = clip(str(getattr(err, "strerror", None) or err))
        raise SpecError(f"{shown(path)}: cannot read ({reason})") from err


def read_text_bounded(path: Path, limit_bytes: int) -> str:
    """A UTF-8 text file of at most `limit_bytes`, read as `read_bytes_bounded` does."""
    data = read_bytes_bounded(path, limit_bytes)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise SpecError(f"{shown(path)}: not a UTF-8 text file") from err


class _Refused(yaml.MarkedYAMLError):
    """A document past a limit, or a tagged value its tag cannot read; never taken as text."""


class _BoundedLoader(yaml.SafeLoader):
    """SafeLoader that refuses documents past YAML_MAX_NODES (aliases expanded), past
    YAML_MAX_DEPTH_LEVELS, with a recursive alias, or with a scalar its tag cannot read."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._nodes = 0  # composed so far, an alias counting as the nodes it stands for
        self._level = 0  # of the node being composed; the root is level 1
        self._reach = 0  # deepest level (aliases expanded) below the open nodes so far
        self._measured: dict[int, tuple[int, int]] = {}  # anchored node: (nodes, levels)

    def _refuse_past_limits(self, mark: Any) -> None:
        if self._nodes > YAML_MAX_NODES:
            raise _Refused(None, None, f"more than {YAML_MAX_NODES} nodes with aliases expanded",
                           mark)
        if self._reach > YAML_MAX_DEPTH_LEVELS:
            raise _Refused(None, None, f"nested more than {YAML_MAX_DEPTH_LEVELS} levels deep",
                           mark)

    # C901: kept line-for-line with PyYAML's compose_node so it can be diffed against upstream
    def compose_node(self, parent: Node | None, index: Any) -> Node | None:  # noqa: C901
        """Composer.compose_node (PyYAML 3.x to 6.x) with the counting added. Written out rather
        than wrapped, and dispatching on the event's class, so that loading a normal file is
        no slower than with plain SafeLoader."""
        event: Any = self.peek_event()  # type: ignore[no-untyped-call]
        kind = event.__class__
        level = self._level + 1
        if kind is yaml.AliasEvent:
            self.get_event()  # type: ignore[no-untyped-call]
            target = self.anchors.get(event.anchor)
            if target is None:
                raise yaml.composer.ComposerError(None, None, "found undefined alias",
                                                  event.start_mark)
            measured = self._measured.get(id(target))
            if measured is None:  # anchored but not finished: the alias is inside it
                raise _Refused(None, None, "recursive alias", event.start_mark)
            self._nodes += measured[0]
            self._reach = max(self._reach, level + measured[1] - 1)
            self._refuse_past_limits(event.start_mark)
            return target
        anchor = event.anchor
        if anchor is not None and anchor in self.anchors:
            first = self.anchors[anchor].start_mark.line + 1
            raise yaml.composer.ComposerError(
                None, None, f"anchor defined again (first on line {first})", event.start_mark)
        before, outer_reach = self._nodes, self._reach
        self._nodes += 1
        if self._nodes > YAML_MAX_NODES or level > YAML_MAX_DEPTH_LEVELS:
            self._reach = level
            self._refuse_past_limits(event.start_mark)
        self._level = self._reach = level
        self.descend_resolver(parent, index)
        node: Node
        if kind is yaml.ScalarEvent:
            node = self.compose_scalar_node(anchor)
        elif kind is yaml.SequenceStartEvent:
            node = self.compose_sequence_node(anchor)
        elif kind is yaml.MappingStartEvent:
            node = self.compose_mapping_node(anchor)
        else:  # the parser only asks for a node where one starts
            raise yaml.composer.ComposerError(None, None, "expected a node", event.start_mark)
        self.ascend_resolver()
        self._level = level - 1
        if anchor is not None:
            self._measured[id(node)] = (self._nodes - before, self._reach - level + 1)
        if outer_reach > self._reach:
            self._reach = outer_reach
        return node

    def compose_mapping_node(self, anchor: Any) -> MappingNode:
        """Composer's, refusing a key given twice in one mapping: PyYAML keeps the last one
        silently, so a second `criteria: {}` would turn a failing scenario into a passing one.
        Keys are compared as their values (`1`, `0x1` and `true` are one key in Python), and
        keys a `<<` merge brings in may still be overridden."""
        node = super().compose_mapping_node(anchor)
        first: dict[Any, Node] = {}
        for key_node, _ in node.value:
            if not isinstance(key_node, ScalarNode) or key_node.tag == _MERGE:
                continue
            key = key_node.value if key_node.tag == _STR else self.construct_object(key_node)
            earlier = first.setdefault(key, key_node)
            if earlier is not key_node:
                raise _Refused(None, None, "duplicate key (first at line "  # no key: contents
                               f"{earlier.start_mark.line + 1})", key_node.start_mark)
        return node


def _checked(construct: Any) -> Any:
    """A scalar constructor whose errors on a bad value (`!!int x`, `!!bool maybe`, a 30 Feb
    timestamp) become a _Refused naming the line, instead of a ValueError or KeyError."""

    def run(loader: _BoundedLoader, node: ScalarNode) -> Any:
        try:
            return construct(loader, node)
        except (ArithmeticError, AttributeError, LookupError, TypeError, ValueError) as err:
            tag = str(node.tag).replace("tag:yaml.org,2002:", "!!")
            raise _Refused(None, None, f"not a valid {clip(tag, 40)}", node.start_mark) from err

    return run


def _bounded_int(loader: _BoundedLoader, node: ScalarNode) -> int:
    if len(node.value) > YAML_INT_MAX_CHARS:
        raise _Refused(None, None, f"an integer of more than {YAML_INT_MAX_CHARS} characters",
                       node.start_mark)
    return loader.construct_yaml_int(node)


for _tag, _construct in (("int", _bounded_int), ("float", yaml.SafeLoader.construct_yaml_float),
                         ("bool", yaml.SafeLoader.construct_yaml_bool),
                         ("timestamp", yaml.SafeLoader.construct_yaml_timestamp)):
    _BoundedLoader.add_constructor(f"tag:yaml.org,2002:{_tag}", _checked(_construct))


# a quoted token in a PyYAML problem (a tag, a scalar) is the file's text; one character (a
# `','` expected, a `'\t'` found) and a token's kind (`'<scalar>'`) tell where, not what
_QUOTED = re.compile(r"""\s*(['"])(.*?)\1""")


def _unquoted(problem: str) -> str:
    """`problem` without the quoted tokens that could be the file's text."""
    return _QUOTED.sub(lambda m: m[0] if len(m[2]) <= 2 or re.fullmatch(r"<[a-z ]+>", m[2])
                       else "", problem)


def _problem(err: yaml.YAMLError, text: str, where: str) -> str:
    """`where:LINE:COLUMN: problem` (or `where: problem` when YAML gives no place), without
    the snippet of the document PyYAML would print or any token it quotes: the file may be
    anything a path pointed at, and the message ends up in CI artifacts."""
    if isinstance(err, yaml.MarkedYAMLError):
        mark = err.problem_mark or err.context_mark
        place = f":{mark.line + 1}:{mark.column + 1}" if mark is not None else ""
        problem = _unquoted(err.problem or err.context or "") or "invalid YAML"
        return f"{where}{place}: {clip(problem)}"
    if isinstance(err, yaml.reader.ReaderError) and isinstance(err.position, int):
        line_start = text.rfind("\n", 0, err.position) + 1
        place = f":{text.count(chr(10), 0, err.position) + 1}:{err.position - line_start + 1}"
        char = err.character if isinstance(err.character, int) else ord(err.character[:1] or " ")
        return f"{where}{place}: character #x{char:04x}: {clip(str(err.reason))}"
    return f"{where}: invalid YAML"


def _load(text: str, where: str, lenient: bool = False) -> Any:
    """One YAML document, or a SpecError `where:LINE:COLUMN: problem`. With `lenient`, text
    that is not YAML is taken as a string (a `--set` value) unless it was refused for its
    size, depth, a recursive alias or a bad tagged value."""
    return _load_node(text, where, lenient)[0]


def _load_node(text: str, where: str, lenient: bool = False) -> tuple[Any, Node | None]:
    """_load's document and the node it was built from (for the marks of its keys)."""
    loader = None
    try:
        loader = _BoundedLoader(text)  # its reader checks the characters here
        node = loader.get_single_node()
        data = None if node is None else loader.construct_document(node)
        return data, node
    except _Refused as err:
        raise SpecError(_problem(err, text, where)) from err
    except yaml.YAMLError as err:
        if lenient:
            return text, None
        raise SpecError(_problem(err, text, where)) from err
    except RecursionError as err:  # only if called with the stack already deep
        raise SpecError(f"{where}: nested too deeply") from err
    except (ArithmeticError, AttributeError, LookupError, TypeError, ValueError) as err:
        # a collection the constructor cannot build (the scalar tags have their own net)
        raise SpecError(f"{where}: cannot read ({clip(str(err))})") from err
    finally:
        if loader is not None:
            loader.dispose()


def read_yaml(path: Path, limit_bytes: int = SPEC_MAX_BYTES) -> dict[str, Any]:
    """A YAML file holding a mapping, read within the byte, node and depth limits."""
    return read_yaml_marked(path, limit_bytes)[0]


# Where a key was written: the file (as shown in messages), its line and column (1-based), and
# the key's dotted path in that file (`floor_friction` of a world file inlined under `world`).
Mark = tuple[str, int, int, str]


def read_yaml_marked(path: Path, limit_bytes: int = SPEC_MAX_BYTES
                     ) -> tuple[dict[str, Any], dict[str, Mark]]:
    """read_yaml's mapping and the mark of every key and list item in it, by dotted path
    (`agents.kart0.start.along_m`, `obstacles.0`): a validation error can then name the file
    and line its bad value came from."""
    text = read_text_bounded(path, limit_bytes)
    data, node = _load_node(text, shown(path))
    if not isinstance(data, dict) or node is None:
        raise SpecError(f"{shown(path)}: expected a mapping of keys at the top level")
    return data, _marks(node, shown(path))


def _marks(root: Node, where: str) -> dict[str, Mark]:
    """The mark of every mapping key and sequence item under `root`; of a key given twice
    through a `<<` merge, the one that wins (the constructor has merged the nodes already)."""
    out: dict[str, Mark] = {}
    stack: list[tuple[Node, str]] = [(root, "")]
    while stack:  # bounded: the composer refused documents of more than YAML_MAX_NODES
        node, prefix = stack.pop()
        if isinstance(node, MappingNode):
            items = {str(k.value): (k, v) for k, v in node.value
                     if isinstance(k, ScalarNode) and k.tag != _MERGE}  # the last one wins
        elif isinstance(node, SequenceNode):
            items = {str(i): (item, item) for i, item in enumerate(node.value)}
        else:
            continue
        for key, (at, value) in items.items():
            dotted = f"{prefix}.{key}" if prefix else key
            out[dotted] = (where, at.start_mark.line + 1, at.start_mark.column + 1, dotted)
            stack.append((value, dotted))
    return out


def parse_value(text: str, where: str) -> Any:
    """A `--set` value as YAML (numbers, booleans, lists), within the same limits; text that is
    not YAML stays a string. `where` names the override in messages."""
    where = clip(where, 80)
    n_bytes = len(text.encode("utf-8", "surrogatepass"))
    if n_bytes > OVERRIDE_MAX_BYTES:
        raise SpecError(f"{where}: the value is {n_bytes} bytes, more than the "
                        f"{size_text(OVERRIDE_MAX_BYTES)} allowed")
    return _load(text, where, lenient=True)


def _short_str(v: Any, limit_chars: int) -> str:
    """str(v), cut; an integer too long to print (or to print quickly) is named instead."""
    if isinstance(v, int) and not isinstance(v, bool) and v.bit_length() >= 1000:
        return f"<an integer of {v.bit_length()} bits>"
    return str(v)[: limit_chars + 1]


class _PreviewFullError(Exception):
    """The preview has reached its length."""


class _Preview:
    """One-line JSON written piece by piece until `limit_chars` + 1 characters are out, then
    stopped by _PreviewFullError."""

    def __init__(self, limit_chars: int) -> None:
        self.limit_chars = limit_chars
        self.out: list[str] = []
        self.room = limit_chars + 1

    def emit(self, piece: str) -> None:
        self.out.append(piece[: self.room])
        self.room -= len(piece)
        if self.room <= 0:
            raise _PreviewFullError

    def walk(self, v: Any) -> None:
        if isinstance(v, str):
            self.emit(json.dumps(v[: self.limit_chars + 1]))
        elif v is None or isinstance(v, bool | float):
            self.emit(json.dumps(v))
        elif isinstance(v, int):
            self.emit(_short_str(v, self.limit_chars))
        elif isinstance(v, dict):
            self.emit("{")
            for i, (key, item) in enumerate(v.items()):
                self.emit(", " if i else "")
                self.walk(key if isinstance(key, str) else _short_str(key, self.limit_chars))
                self.emit(": ")
                self.walk(item)
            self.emit("}")
        elif isinstance(v, list | tuple | set | frozenset):
            self.emit("[")
            for i, item in enumerate(v):
                if i:
                    self.emit(", ")
                self.walk(item)
            self.emit("]")
        else:
            self.emit(json.dumps(_short_str(v, self.limit_chars)))


def preview(value: Any, limit_chars: int = 60) -> str:
    """`value` as one line of JSON of at most `limit_chars`, built piece by piece and stopped
    once long enough: a huge or cyclic value costs no more than a short one."""
    writer = _Preview(limit_chars)
    with contextlib.suppress(_PreviewFullError):
        writer.walk(value)
    text = "".join(writer.out)
    return text if len(text) <= limit_chars else text[: limit_chars - 1] + "…"
