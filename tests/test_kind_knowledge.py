"""Kinds own their knowledge (issue 41): the shared modules that read what kinds register (log
flatteners, metric definitions, report figures, wall-clock fields, bridge command types) name no
kind, none of a kind's messages, metrics or controllers, whatever word they use for them. Like
tests/test_layers.py for imports: measured from the files' text."""

from __future__ import annotations

import re
from pathlib import Path

from kartci.core import CONTROLLERS, METRICS, ROBOTS
from kartci.metrics.defs import DEFS

ROOT = Path(__file__).resolve().parents[1] / "kartci"
SHARED = ("logs/tables.py", "metrics/defs.py", "report/figures.py", "logs/wallclock.py",
          "bridge/params.py")
# words for the built-in kinds that no registration spells out
NICKNAMES = ("kart", "line tracker", "line sensor", "sensor point")
# names a kind registers that are ordinary words too (`commands` a bridge takes back, a run's
# `completion`): caught only as a name, in quotes
ORDINARY = frozenset({"commands", "completion", "manual", "script"})


def kind_vocabulary() -> list[str]:
    """Every name only one built-in kind owns: the kind, its message types (full and short),
    the metrics only its sets define, the controllers that drive only it, and its nicknames."""
    words = set(NICKNAMES)
    for kind in ROBOTS.all():
        if not ROBOTS.sources[kind.name].startswith("kartci.robots."):
            continue  # kartci's own kinds only (real-data import's `recorded` is kind-neutral)
        words.add(kind.name)
        for msgtype in (*kind.flatteners, *kind.wall_clock, *kind.commands):
            words |= {msgtype, msgtype.rsplit("/", 1)[-1]}
        for name in kind.metrics:
            words |= set(METRICS.get(name).defs) - set(DEFS)
        words |= {c.name for c in CONTROLLERS.all() if c.robots == (kind.name,)}
    return sorted(words)


def mentions(words: list[str], files: list[Path]) -> list[str]:
    """Each line of `files` that holds one of `words` as a whole word (any case; a plural
    too; an ordinary word only as a quoted name), with its file, line and the word."""
    pattern = re.compile("|".join(
        rf"(?<=[\"'`]){re.escape(w)}(?=[\"'`])" if w in ORDINARY else
        rf"(?<![A-Za-z0-9_]){re.escape(w)}s?(?![A-Za-z0-9_])"
        for w in sorted(words, key=len, reverse=True)), re.IGNORECASE)
    found = []
    for path in files:
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            found += [f"{path.name}:{n}: {hit[0]!r}" for hit in pattern.finditer(line)]
    return found


def test_the_vocabulary_holds_what_each_kind_registers() -> None:
    words = kind_vocabulary()
    assert {"gokart", "line_tracker", "KartCommand", "kartci_msgs/msg/SolverStats",
            "LineSensor", "TyreForces", "LineControllerState", "solver_failures", "overtakes",
            "line_lost", "mpcc", "line_pid"} <= set(words)


def test_the_shared_modules_name_no_kind() -> None:
    """What a kind knows is registered by the kind; the modules that read it stay generic."""
    assert mentions(kind_vocabulary(), [ROOT / f for f in SHARED]) == []


def test_the_scan_finds_what_it_looks_for(tmp_path: Path) -> None:
    """Not vacuous: a message type, a kind's metric, a nickname and a quoted controller name
    are caught; a word that merely holds one (`kartci`, `karting`), or an ordinary word used
    as one, is not."""
    mod = tmp_path / "mod.py"
    mod.write_text('"""kartci reads karting logs."""\n'
                   'FLAT = {"kartci_msgs/msg/KartCommand": 1}\n'
                   "# the MPCC's solver_failures of two Karts\n"
                   "OK = ('the commands', 'commands')\n")
    assert mentions(kind_vocabulary(), [mod]) == [
        "mod.py:2: 'kartci_msgs/msg/KartCommand'", "mod.py:3: 'MPCC'",
        "mod.py:3: 'solver_failures'", "mod.py:3: 'Karts'", "mod.py:4: 'commands'"]
