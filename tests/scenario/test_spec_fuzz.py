"""Spec loading is total and bounded: every malformed scenario, world, model, `--set` value or
track file is one KartciError line, in bounded time and memory, never a traceback.

Explicit tests cover the cases found in review (alias bomb, 17 MB file, /dev/zero, a FIFO,
recursive aliases, deep nesting, `!!int x`, `.inf`, 1e308, `end_m=[1e300,0]`). The hypothesis
tests write generated YAML (random nesting, real scenario keys, anchors and aliases, tags, odd
floats, non-UTF-8 bytes, mutations of the real scenarios) to a file and load it, and apply
generated `--set` assignments to `line_straight`; any exception but a KartciError fails, as
does a message of more than one line. The normal run tries a few hundred derandomized examples
(the same ones on every CI run). The long run, 10,000+ random examples of each, is opt-in:

    KARTCI_LONG=1 pytest -m long tests/scenario/test_spec_fuzz.py --hypothesis-show-statistics
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from kartci.errors import KartciError, SpecError
from kartci.project import BUILTIN_SCENARIOS, BUILTIN_SIMS
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.scenario.yamlio import (
    SPEC_MAX_BYTES,
    YAML_MAX_DEPTH_LEVELS,
    YAML_MAX_NODES,
    parse_value,
    preview,
    read_text_bounded,
)
from kartci.worlds.track import load_track

# the scenario's body, without its editor modeline (the tests splice text after the first key)
STRAIGHT = "".join(line for line in (BUILTIN_SCENARIOS / "line_straight.yaml").read_text(
    encoding="utf-8").splitlines(keepends=True) if not line.startswith("# yaml-language-server"))
SCENARIOS = tuple(p.read_text(encoding="utf-8")
                  for p in sorted(BUILTIN_SCENARIOS.glob("*.yaml")))
MESSAGE_MAX_CHARS = 1000  # a path, a key, a short problem and a 60-character preview fit


def _spec_error(load: Callable[[], object]) -> str:
    """The message of the one SpecError `load` raises; it must be one short line."""
    with pytest.raises(SpecError) as info:
        load()
    message = str(info.value)
    assert "\n" not in message and len(message) < MESSAGE_MAX_CHARS, message[:300]
    return message


def _scenario_error(name: str, *overrides: str) -> str:
    return _spec_error(lambda: load_scenario(name, list(overrides), project=active_project()))


def _file(tmp_path: Path, text: str | bytes, name: str = "bad.yaml") -> str:
    path = tmp_path / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return str(path)


def _with(key_line: str) -> str:
    """line_straight with its description line replaced by `key_line` (which may span lines)."""
    lines = STRAIGHT.splitlines()
    assert lines[0].startswith("description:")
    return "\n".join([key_line, *lines[1:]]) + "\n"


def _bomb(levels: int) -> list[str]:
    """A billion-laughs anchor chain: level k holds 9 aliases of level k - 1."""
    lines = ['l0: &l0 ["lol"]']
    lines += [f"l{k}: &l{k} [{', '.join([f'*l{k - 1}'] * 9)}]" for k in range(1, levels)]
    return lines


# --- the cases found in review -------------------------------------------------------------


def test_alias_bomb_is_refused_by_its_expanded_size(tmp_path: Path) -> None:
    bomb = _bomb(9)  # 9**8 = 43 million strings once expanded
    text = _with("bombs:\n" + "\n".join("  " + b for b in bomb) + "\ndescription: *l8")
    message = _scenario_error(_file(tmp_path, text))
    assert f"more than {YAML_MAX_NODES} nodes with aliases expanded" in message
    assert "bad.yaml:7:" in message  # the line of the alias that went past the limit
    flow = "{" + ", ".join(bomb) + "}"
    assert "aliases expanded" in _scenario_error("line_straight", f"description={flow}")
    # the count is exact: 5 levels are 15,690 nodes, 6 levels 141,170
    assert len(parse_value("{" + ", ".join(_bomb(5)) + "}", "x")["l4"][8][8][8][0]) == 1
    assert "aliases expanded" in _spec_error(lambda: parse_value("{" + ", ".join(_bomb(6)) + "}",
                                                                 "x"))


def test_a_file_over_the_size_limit_is_refused_before_it_is_parsed(tmp_path: Path) -> None:
    text = STRAIGHT + "pad: [" + "0, " * 5_700_000 + "0]\n"  # 17 MB of valid YAML
    assert len(text) > 17_000_000
    message = _scenario_error(_file(tmp_path, text))
    assert f"more than the {SPEC_MAX_BYTES >> 20} MiB allowed" in message
    big = tmp_path / "big.csv"
    big.write_text("0,0,1,1\n" * 2_000_000)
    assert "allowed" in _spec_error(lambda: load_track(big))


def _without_hanging(load: Callable[[], object], fifo: Path) -> BaseException | None:
    """What `load` raises, run in a thread; should it block in open() on `fifo`, it is released
    by opening the write end, and the test fails instead of hanging."""
    outcome: list[BaseException | None] = []

    def run() -> None:
        try:
            load()
            outcome.append(None)
        except BaseException as err:  # handed to the test thread
            outcome.append(err)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(10.0)
    if thread.is_alive():
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        thread.join(10.0)
        pytest.fail(f"loading {fifo} blocked")
    return outcome[0]


def test_fifos_devices_and_directories_are_refused_without_reading(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe.yaml"
    os.mkfifo(fifo)
    for load in (lambda: load_scenario(str(fifo),
                                       project=active_project()), lambda: load_track(fifo)):
        err = _without_hanging(load, fifo)
        assert isinstance(err, SpecError) and "not a regular file (a FIFO)" in str(err)
    if Path("/dev/zero").exists():
        assert "character device" in _scenario_error("/dev/zero")
        assert "character device" in _spec_error(lambda: load_track(Path("/dev/zero")))
    (tmp_path / "dir.yaml").mkdir()
    assert "directory" in _scenario_error(str(tmp_path / "dir.yaml"))


def test_recursive_aliases_are_refused(tmp_path: Path) -> None:
    for line in ("description: &a [*a]", "description: &a {x: [1, *a]}",
                 "description: x\nagents: &b {lt0: *b}"):
        assert "recursive alias" in _scenario_error(_file(tmp_path, _with(line)))
    assert "recursive alias" in _scenario_error("line_straight", "description=&a {<<: *a}")


def test_deep_nesting_is_refused_before_python_runs_out_of_stack(tmp_path: Path) -> None:
    deep = f"nested more than {YAML_MAX_DEPTH_LEVELS} levels deep"
    for n in (400, 5000):
        flow = _with("description: " + "[" * n + "]" * n)
        assert deep in _scenario_error(_file(tmp_path, flow))
    block = _with("description:\n" + "".join("  " * i + "- \n" for i in range(1, 400)))
    assert deep in _scenario_error(_file(tmp_path, block))
    # 40 levels inside an anchor plus 40 around its alias: deep only once expanded
    aliased = _with("a: &a " + "[" * 40 + "]" * 40 + "\ndescription: " + "[" * 40 + "*a"
                    + "]" * 40)
    assert deep in _scenario_error(_file(tmp_path, aliased))
    assert deep in _scenario_error("line_straight", "description=" + "[" * 400 + "]" * 400)
    # the depth is exact, aliases expanded: a mapping, 31 or 32 lists, an alias of 32 lists
    assert parse_value("[" * 64 + "]" * 64, "x")
    assert deep in _spec_error(lambda: parse_value("[" * 65 + "]" * 65, "x"))
    anchored = "{a: &a " + "[" * 32 + "]" * 32 + ", b: "
    assert parse_value(anchored + "[" * 31 + "*a" + "]" * 31 + "}", "x")
    assert deep in _spec_error(lambda: parse_value(anchored + "[" * 32 + "*a" + "]" * 32 + "}",
                                                   "x"))


def test_bad_explicit_tags_are_one_line_naming_the_line(tmp_path: Path) -> None:
    for tagged in ("!!int x", "!!float y", "!!bool maybe", "!!timestamp 2001-13-45",
                   "!!int 1:2:x", "!!int ''", "!!float ''"):
        message = _scenario_error(_file(tmp_path, _with(f"probe: {tagged}")))  # seed: taken
        assert ":1:8: not a valid !!" in message
        assert "not a valid !!" in _scenario_error("line_straight", f"seed={tagged}")
    sexagesimal = "1" + ":59" * 100_000  # base 60: quadratic time to build the integer
    assert "1000 characters" in _scenario_error(_file(tmp_path, _with(f"probe: {sexagesimal}")))
    assert "1000 characters" in _scenario_error("line_straight", f"seed={sexagesimal[:30_000]}")


def test_infinite_nan_and_overflowing_numbers(tmp_path: Path) -> None:
    inf = STRAIGHT.replace("period_s: 0.06", "period_s: .inf")
    assert "period_s: Input should be a finite number" in _scenario_error(_file(tmp_path, inf))
    big = STRAIGHT.replace("period_s: 0.06", "period_s: 1" + "0" * 308)  # 1e308, an int
    assert _scenario_error(_file(tmp_path, big)).endswith(
        "period_s: must be at most 3600 s")  # a value from a file is never echoed
    assert "finite number" in _scenario_error("line_straight", "duration_s=.nan")
    assert "finite number" in _scenario_error("line_straight",
                                              "metrics.line_tracking.transient_s=1e400")
    assert "period_s (from --set): must be at most 3600 s (got \"1.0e308\")" in _scenario_error(
        "line_straight", "agents.lt0.controller.period_s=1.0e308")
    far = _scenario_error("line_straight", "world.course.end_m=[1e300,0]")
    assert far.endswith('world.course.end_m.0 (from --set): must be at most 10000 m (got "1e300")')


def test_malformed_structure_is_a_spec_error(tmp_path: Path) -> None:
    assert "mapping of keys" in _scenario_error(_file(tmp_path, "- 1\n"))
    assert "mapping of keys" in _scenario_error(_file(tmp_path, ""))
    assert "Keys should be strings" in _scenario_error(_file(tmp_path,
                                                             _with("description: x\n7: 8")))
    assert "valid string" in _scenario_error(_file(tmp_path, STRAIGHT.replace("lt0:", "7:")))
    assert "unhashable" in _scenario_error(_file(tmp_path, _with("description: {[1]: 2}")))
    assert ":2:4: anchor defined again (first on line 1)" in _scenario_error(
        _file(tmp_path, _with("description: &a x\nx: &a y")))
    assert ":1:14: found undefined alias" in _scenario_error(
        _file(tmp_path, _with("description: *b")))
    assert "'b' is not an item index" in _scenario_error("line_straight", "tags=[a]", "tags.b=1")
    assert "not a mapping" in _scenario_error("line_straight", "seed.x=1")
    assert "not a mapping" in _scenario_error("line_straight", "agents.lt0.start.along_m.x.y=1")
    nul = _scenario_error(_file(tmp_path, _with("description: a\x00b")))
    assert ":1:15: character #x0000" in nul
    surrogate = STRAIGHT.encode() + b"\xed\xa0\x80"
    assert "not a UTF-8 text file" in _scenario_error(_file(tmp_path, surrogate))


def test_messages_never_carry_a_huge_value(tmp_path: Path) -> None:
    huge = ["x" * 30_000] * 2
    shown = _scenario_error("line_straight", f"description={huge}")
    assert '(got ["xxxxxxxxxx' in shown and shown.endswith("…)") and len(shown) < 200
    dates = _scenario_error("line_straight", "description=[{2020-01-01: 1}]")  # not JSON keys
    assert '(got [{"2020-01-01": 1}])' in dates
    _scenario_error("line_straight", "world.kind=" + "k" * 60_000)
    _scenario_error("line_straight", "x" * 60_000 + "=1")
    _scenario_error(_file(tmp_path, _with("*" + "a" * 500_000)))
    assert "File name too long" in _scenario_error("line_straight", "world=" + "w" * 5000)
    assert "world 'a\\tb' not found" in _scenario_error("line_straight", 'world="a\\tb"')
    cyclic: list[object] = []
    cyclic.append(cyclic)
    assert preview(cyclic, 20) == "[[[[[[[[[[[[[[[[[[[…"
    assert preview({"k": 10**5000}) == '{"k": <an integer of 16610 bits>}'


def test_set_values_that_are_not_yaml_stay_strings() -> None:
    assert parse_value("a: b: c", "--set x") == "a: b: c"
    assert parse_value("*undefined", "--set x") == "*undefined"
    assert parse_value("[1, 2.5, true]", "--set x") == [1, 2.5, True]
    assert "64 KiB" in _spec_error(lambda: parse_value("x" * (65 << 10), "--set x"))


def test_track_reader_keeps_the_csv_and_its_limits(tmp_path: Path) -> None:
    csv = BUILTIN_SIMS / "tracks" / "chicane.csv"
    assert read_text_bounded(csv, 1 << 20) == csv.read_text(encoding="utf-8")
    assert load_track(csv).length_m > 10.0
    assert "more than the 1 KiB allowed" in _spec_error(lambda: read_text_bounded(csv, 1 << 10))
    assert "file not found" in _spec_error(lambda: load_track(tmp_path / "none.csv"))


# --- property-based fuzz -------------------------------------------------------------------

KEYS = ("world", "agents", "duration_s", "physics", "dt_s", "physics.dt_s", "odom_rate_hz",
        "agents.lt0.controller", "description", "name", "seed", "lt0", "k1", "model",
        "controller", "type", "kind", "course", "start_m", "end_m", "center_m", "radius_m",
        "period_s", "kp", "v1_mps", "metrics", "transient_s", "criteria", "completion", "max",
        "min", "tags", "from", "obstacles", "start", "along_m", "line_sensor", "mode", "steps",
        "t_s", "source", "log", "track", "<<", "? [k]", "'q'", "1", "~", "x y", "")
WORDS = ("line_lab/straight", "line_lab/circle", "winti/hall", "line_tracker", "gokart",
         "line_pid", "mpcc", "script", "manual", "straight", "circle", "hall", "line_lab",
         "geometric", "rendered", "/dev/zero", "../scenarios/line_straight", "nope", "a b")
SCALARS = ("0", "-1", "1", "26.0", "0.06", "0.002", "1e308", "1" + "0" * 308, "1.0e308",
           "-1.0e300", "1e300", ".inf", "-.inf", ".nan", ".NaN", "1.0e-320", "0x1F", "0o17",
           "0b101", "1_000", "190:20:30", "1:2:3.5", "~", "null", "yes", "off", "true",
           "2001-02-30", "2001-12-14t21:59:43.10-05:00", "!!int x", "!!int 1e3", "!!float y",
           "!!float .inf", "!!bool maybe", "!!timestamp 2001-13-01", "!!binary '@@'",
           "!!null x", "!!str 1", "!!set {a, b}", "!!omap [1, 2]", "!!pairs [a]", "!!map [1]",
           "!!seq {a: 1}", "!foo bar", "!!python/object:os.system x",
           "!<tag:yaml.org,2002:int> z", "'quoted'", '"\\x00\\uD800"', "*nope", "*a0", "*a1",
           "*a2", "<<", "=", "- 1", "'", '"', "{", "]", "}", "[", ": ", "&", "*", "!", "%", "@",
           "`", "|", ">", "#c", "---", "...", "? ", ",", "\t", "\\")
TAGS = ("!!int", "!!float", "!!str", "!!bool", "!!seq", "!!map", "!!set", "!!omap", "!!pairs",
        "!!timestamp", "!!binary", "!!null", "!!merge", "!local", "!!python/tuple", "!<x>")

printable = st.text(st.characters(exclude_categories=("Cc", "Cs")), max_size=8)
scalars = st.one_of(
    st.sampled_from(SCALARS + WORDS),
    st.floats().map(lambda x: f"{x:.3e}"),  # YAML 1.1 wants a dot: 1.000e+300
    st.floats().map(repr),
    st.integers(min_value=-(10**400), max_value=10**400).map(str),
    printable.map(lambda s: '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'),
    printable,  # control characters come from the byte corruption in _document
)
keys = st.one_of(st.sampled_from(KEYS), printable)


def _nest(children: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
    return st.one_of(
        st.lists(children, max_size=5).map(lambda xs: "[" + ", ".join(xs) + "]"),
        st.lists(st.tuples(keys, children), max_size=5).map(
            lambda kvs: "{" + ", ".join(f"{k}: {v}" for k, v in kvs) + "}"),
        st.tuples(st.integers(0, 4), children).map(lambda t: f"&a{t[0]} {t[1]}"),
        st.tuples(st.sampled_from(TAGS), children).map(lambda t: f"{t[0]} {t[1]}"),
    )


trees = st.recursive(scalars, _nest, max_leaves=25)
deep = st.integers(30, 400).map(lambda n: "[" * n + "]" * n)
bombs = st.integers(2, 10).map(lambda n: "{" + ", ".join(_bomb(n)) + "}")
values = st.integers(0, 19).flatmap(  # mostly trees, 1 in 20 deep, 1 in 20 a bomb
    lambda i: deep if i == 0 else bombs if i == 1 else trees)


@st.composite
def _document(draw: st.DrawFn) -> bytes:
    """A block mapping of (mostly) scenario keys, or a real scenario with lines changed."""
    if draw(st.integers(0, 2)) == 0:
        lines = []
        for key, value in draw(st.lists(st.tuples(keys, values), max_size=8)):
            parts = key.split(".")  # `physics.dt_s` as a nested mapping
            lines.append(f"{parts[0]}: " + "".join("{" + p + ": " for p in parts[1:]) + value
                         + "}" * (len(parts) - 1))
    else:
        lines = draw(st.sampled_from(SCENARIOS)).splitlines()
        for _ in range(draw(st.integers(1, 4))):
            i = draw(st.integers(0, len(lines)))
            head = lines[i].partition(":")[0] if i < len(lines) else draw(keys)
            changed = f"{head}: {draw(st.one_of(scalars, values))}"
            op = draw(st.sampled_from(("replace", "insert", "delete")))
            if op == "replace" and i < len(lines):
                lines[i] = changed
            elif op == "insert":
                lines.insert(i, changed)
            elif i < len(lines):
                del lines[i]
    data = ("\n".join(lines) + "\n").encode("utf-8", "surrogatepass")
    if draw(st.integers(0, 9)) == 7:  # a few bytes of anything, often not UTF-8
        at = draw(st.integers(0, len(data)))
        data = data[:at] + draw(st.binary(min_size=1, max_size=4)) + data[at:]
    return data


SET_KEYS = ("agents.lt0.controller.period_s", "agents.lt0.controller.kp", "agents.lt0.controller",
            "agents.lt0.model", "agents.lt0.model.wheel_radius_m", "agents.lt0", "agents",
            "world", "world.course.end_m", "world.course.type", "world.kind", "world.from",
            "world.course.radius_m", "physics.dt_s", "physics", "duration_s", "description",
            "seed", "tags", "tags.x", "criteria.completion.min", "criteria", "name", "metrics",
            "a.b", "", " ", ".", "..", "agents.lt0.start.along_m.x")
assignments = st.tuples(
    st.one_of(st.sampled_from(SET_KEYS), keys),
    st.sampled_from(("=",) * 8 + ("", "==")),
    st.one_of(values, st.text(max_size=10)),
).map("".join)


def _loads_or_one_line_error(load: Callable[[], object]) -> None:
    """Loading either works or raises one KartciError of one short line; anything else fails."""
    try:
        load()
    except KartciError as err:
        message = str(err)
        assert "\n" not in message and len(message) < MESSAGE_MAX_CHARS, message[:300]


FAST = settings(max_examples=150, derandomize=True, database=None, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
LONG = settings(max_examples=12_000, database=None, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def _check_document(data: bytes, folder: Path) -> None:
    path = folder / "fuzz.yaml"
    path.write_bytes(data)
    _loads_or_one_line_error(lambda: load_scenario(str(path), project=active_project()))


def _check_overrides(overrides: list[str]) -> None:
    _loads_or_one_line_error(lambda: load_scenario("line_straight", overrides,
                                                   project=active_project()))


@FAST
@given(data=_document())
def test_fuzz_scenario_files(data: bytes, tmp_path_factory: pytest.TempPathFactory) -> None:
    _check_document(data, tmp_path_factory.getbasetemp())


@FAST
@given(overrides=st.lists(assignments, min_size=1, max_size=3))
def test_fuzz_set_overrides(overrides: list[str]) -> None:
    _check_overrides(overrides)


@pytest.mark.long(reason="fuzzing with 12,000 scenario files and overrides")
@LONG
@given(data=_document())
def test_fuzz_scenario_files_long(data: bytes, tmp_path_factory: pytest.TempPathFactory) -> None:
    _check_document(data, tmp_path_factory.getbasetemp())


@pytest.mark.long(reason="fuzzing with 12,000 scenario files and overrides")
@LONG
@given(overrides=st.lists(assignments, min_size=1, max_size=3))
def test_fuzz_set_overrides_long(overrides: list[str]) -> None:
    _check_overrides(overrides)
