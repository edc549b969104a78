"""Search a scenario's space for a failing run, then shrink it toward the scenario's own values.

Optuna's TPE sampler (seeded) proposes points in batches of BATCH; a batch runs through the
`Evaluate` given (the runner's executors in `kartci.app.search`, a fake in the tests) and is
told back in the order asked, so the same seed gives the same search at any `-j`. The first
batch holds the scenario's own values (the nominal). Once a run fails its criteria, the failing
point nearest the nominal is shrunk axis by axis toward it by bisection on the pass/fail
boundary, as Hypothesis shrinks a failing example: the failure reported is the one nearest to
what the team ships, and each axis it moved on ends with its boundary bracketed.

Points are tuples of (dotted key, value text), the value written as `--set` takes it.
"""

from __future__ import annotations

import itertools
import math
import random
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import TYPE_CHECKING, Any

from kartci.errors import SpecError

if TYPE_CHECKING:
    import optuna

BATCH = 4  # points asked at once: a constant, so that -j changes the speed, never the search
STARTUP = 8  # random points before TPE models the space (the nominal is the first)
RESOLUTION = 64  # a continuous axis is shrunk until its boundary is bracketed to span / this
CELLS = 10  # per continuous axis, for the coverage figure
PASSES = 3  # shrink passes over the axes (one axis moving can free another)
CLIP = 10.0  # margins told to the sampler are clipped to +-CLIP (an error, a missing value: -)
UNSEEN_LISTED = 100_000  # a finite space this small is listed to draw unseen points from
ASKS_PER_RUN = 4  # asks stop at this x budget (a sampler stuck on points it has seen)
Point = tuple[tuple[str, str], ...]


class AxisKind(StrEnum):
    """How an axis's values are drawn and bisected."""

    FLOAT = "float"  # any value in [low, high]: bisection stops at span / resolution
    GRID = "grid"  # low + k x step (an integer key: step 1): bisection ends on neighbours
    CHOICE = "choice"  # listed values: shrinking tries the nominal one


class RunStatus(StrEnum):
    """How one run of a search ended."""

    PASS = "pass"  # every criterion held
    FAIL = "fail"  # a criterion failed
    ERROR = "error"  # the run broke (non-finite state, a crash): a failure too
    INVALID = "invalid"  # the scenario refused the point: not run, not counted

    @property
    def failing(self) -> bool:
        """A failure the search looks for."""
        return self in (RunStatus.FAIL, RunStatus.ERROR)


class Phase(StrEnum):
    """Which part of the search asked for a run."""

    SEARCH = "search"
    SHRINK = "shrink"


@dataclass(frozen=True)
class Axis:
    """One dimension of the search: a scenario key, its range or values, and the scenario's own
    value (clipped into the range: where shrinking heads)."""

    key: str
    kind: AxisKind
    nominal: str
    low: float = 0.0  # in the key's unit
    high: float = 0.0
    step: float = 0.0  # GRID only, in the key's unit
    integer: bool = False
    choices: tuple[str, ...] = ()

    @property
    def span(self) -> float:
        """high - low, in the key's unit."""
        return self.high - self.low

    def text(self, x: float) -> str:
        """A number of this axis as `--set` takes it: on the grid, without float noise."""
        if self.kind is AxisKind.GRID:
            x = self.low + round((x - self.low) / self.step) * self.step
        if self.integer:
            return str(round(x))
        quantum = 10.0 ** math.floor(math.log10(self.span * 1e-6)) if self.span > 0 else 1e-12
        return f"{round(x / quantum) * quantum:.12g}"

    def position(self, value: str) -> float:
        """Where a value lies: its number (FLOAT), grid index (GRID) or choice index."""
        if self.kind is AxisKind.CHOICE:
            return float(self.choices.index(value))
        x = float(value)
        return round((x - self.low) / self.step) if self.kind is AxisKind.GRID else x

    def at(self, position: float) -> str:
        """The value at a position (see `position`)."""
        if self.kind is AxisKind.CHOICE:
            return self.choices[int(position)]
        return self.text(self.low + position * self.step if self.kind is AxisKind.GRID
                         else position)

    def distance(self, a: str, b: str) -> float:
        """|a - b| as a fraction of the span (choices: 0 or 1)."""
        if self.kind is AxisKind.CHOICE:
            return float(a != b)
        return abs(float(a) - float(b)) / self.span if self.span > 0 else 0.0

    def cell(self, value: str) -> int:
        """The coverage cell a value falls in."""
        if self.kind is AxisKind.CHOICE:
            return self.choices.index(value)
        n = self.cells
        return min(n - 1, int((float(value) - self.low) / self.span * n)) if self.span else 0

    @property
    def cells(self) -> int:
        """Coverage cells on this axis: every choice or grid value, or CELLS."""
        if self.kind is AxisKind.CHOICE:
            return len(self.choices)
        if self.kind is AxisKind.GRID:
            return min(CELLS, self.size)
        return CELLS

    def suggest(self, trial: optuna.Trial) -> str:
        """The sampler's value for this axis, as text."""
        if self.kind is AxisKind.CHOICE:
            return str(trial.suggest_categorical(self.key, list(self.choices)))
        if self.integer:
            return str(trial.suggest_int(self.key, int(self.low), int(self.high),
                                         step=max(1, round(self.step))))
        if self.kind is AxisKind.FLOAT:
            return self.text(trial.suggest_float(self.key, self.low, self.high))
        top = float(self.at(self.size - 1))  # as text first: Optuna checks divisibility in
        return self.text(trial.suggest_float(self.key, self.low, top, step=self.step))  # decimal

    @property
    def size(self) -> int:
        """Values on a GRID or CHOICE axis (0: a FLOAT axis, unbounded)."""
        if self.kind is AxisKind.CHOICE:
            return len(self.choices)
        if self.kind is AxisKind.GRID:
            return math.floor(self.span / self.step + 1e-9) + 1
        return 0

    def sampler_value(self, value: str) -> Any:
        """A value as the sampler holds it (for the nominal point it is given first)."""
        if self.kind is AxisKind.CHOICE:
            return value
        return int(value) if self.integer else float(value)


@dataclass(frozen=True)
class Evaluation:
    """One point run (or refused) and judged."""

    point: Point
    label: str  # its folder in OUT
    status: RunStatus
    margin: float  # the smallest criterion margin (fraction of its bound; < 0: failed)
    value: float | None = None  # the --objective metric's value (None: not asked, or NaN)
    why: tuple[str, ...] = ()  # failed criteria (`name value (bound)`), or the error
    phase: Phase = Phase.SEARCH

    def values(self) -> dict[str, str]:
        """The point as a mapping of key to value text."""
        return dict(self.point)


Evaluate = Callable[[list[Point], Phase], list[Evaluation]]  # one Evaluation per point, in order
Progress = Callable[["Snapshot"], None]


@dataclass(frozen=True)
class Bracket:
    """The pass/fail boundary on one axis, from the shrunk failure's side: `passing` is the
    failing value's nearest passing neighbour toward the nominal (or the nominal itself)."""

    key: str
    passing: str
    failing: str


@dataclass(frozen=True)
class Snapshot:
    """Where a search stands: for progress lines."""

    runs: int
    budget: int
    phase: Phase
    best: Evaluation | None  # the smallest margin so far (or the worst objective value)


@dataclass(frozen=True)
class Plan:
    """What to search: the axes, how many runs at most, the seed, and what counts as worst."""

    axes: tuple[Axis, ...]
    budget: int  # runs at most (search and shrink together; refused points do not count)
    seed: int = 0
    objective: str | None = None  # a metric to make worst; None: fail the criteria
    higher_is_worse: bool = True  # with `objective`: which way is worse
    resolution: int = RESOLUTION

    @property
    def nominal(self) -> Point:
        """The scenario's own values (clipped into the ranges)."""
        return tuple((a.key, a.nominal) for a in self.axes)


@dataclass(frozen=True)
class Found:
    """What a search found: every run in order, the shrunk failure (or, with an objective, the
    worst run), the boundary on each axis it moved on, and how much of the space it saw."""

    plan: Plan
    runs: tuple[Evaluation, ...]
    failure: Evaluation | None  # the failure nearest the nominal (criteria) / worst run
    brackets: tuple[Bracket, ...]
    covered: int  # cells holding a run
    cells: int  # cells in all
    shrunk: bool = False  # the shrink ended with every axis settled, not with the budget

    @property
    def coverage(self) -> float:
        """Share of the space's cells that hold a run (0..1)."""
        return self.covered / self.cells if self.cells else 1.0

    @property
    def counted(self) -> list[Evaluation]:
        """The runs that count against the budget (not the refused points)."""
        return [e for e in self.runs if e.status is not RunStatus.INVALID]

    @property
    def smallest(self) -> Evaluation | None:
        """The run with the smallest margin, the first of equals."""
        runs = self.counted
        return min(runs, key=lambda e: e.margin) if runs else None

    @property
    def worst(self) -> Evaluation | None:
        """The run where the objective is worst (None without an objective)."""
        return _worst(self.counted, self.plan)


def _worst(runs: Sequence[Evaluation], plan: Plan) -> Evaluation | None:
    scored = [e for e in runs if e.value is not None and math.isfinite(e.value)]
    if not scored:
        return None
    sign = 1.0 if plan.higher_is_worse else -1.0
    return max(scored, key=lambda e: sign * (e.value or 0.0))


def score(e: Evaluation, plan: Plan) -> float | None:
    """What the sampler minimises: the margin (clipped), or the objective turned so that lower
    is worse; None for a point that tells nothing (refused, or the objective not computed)."""
    if e.status is RunStatus.INVALID:
        return None
    if plan.objective is not None:
        if e.value is None or not math.isfinite(e.value):
            return None
        return -e.value if plan.higher_is_worse else e.value
    if e.status is RunStatus.ERROR:
        return -CLIP
    return max(-CLIP, min(CLIP, e.margin))


class _Search:
    """The state of one search: every evaluation by point, the runs in order, the budget."""

    def __init__(self, plan: Plan, evaluate: Evaluate, progress: Progress | None) -> None:
        self.plan, self.evaluate, self.progress = plan, evaluate, progress
        self.seen: dict[Point, Evaluation] = {}
        self.runs: list[Evaluation] = []
        self.settled = False  # the shrink ended within the budget

    @property
    def spent(self) -> int:
        return sum(1 for e in self.runs if e.status is not RunStatus.INVALID)

    def run(self, points: list[Point], phase: Phase) -> None:
        """Evaluate the points not seen yet (at most what the budget has left)."""
        new = list(dict.fromkeys(p for p in points if p not in self.seen))
        new = new[:max(0, self.plan.budget - self.spent)]
        if not new:
            return
        for e in self.evaluate(new, phase):
            self.seen[e.point] = e
            self.runs.append(e)
        if self.progress is not None:
            self.progress(Snapshot(self.spent, self.plan.budget, phase, self.best()))

    def best(self) -> Evaluation | None:
        runs = [e for e in self.runs if e.status is not RunStatus.INVALID]
        if self.plan.objective is not None:
            return _worst(runs, self.plan)
        return min(runs, key=lambda e: e.margin) if runs else None

    def explore(self) -> None:
        """Ask, run and tell in batches until a run fails (criteria) or the budget is spent."""
        try:
            import optuna  # optional dependency (kartci[search]), with SQLAlchemy under it
        except ImportError:
            raise SpecError('kartci search needs Optuna: pip install "kartci[search]"') from None

        optuna.logging.set_verbosity(optuna.logging.WARNING)
        study = optuna.create_study(direction="minimize", sampler=optuna.samplers.TPESampler(
            seed=self.plan.seed, n_startup_trials=STARTUP))
        study.enqueue_trial({a.key: a.sampler_value(a.nominal) for a in self.plan.axes})
        asks = 0
        sizes = [a.size for a in self.plan.axes]
        space = math.prod(sizes) if all(sizes) else math.inf  # finite: stop when all are seen
        fill = random.Random(self.plan.seed)  # unseen points for the sampler's repeats
        while (self.spent < self.plan.budget and asks < ASKS_PER_RUN * self.plan.budget
               and len(self.seen) < space):
            n = min(BATCH, self.plan.budget - self.spent)
            trials = [study.ask() for _ in range(n)]
            asks += n
            points = [tuple((a.key, a.suggest(t)) for a in self.plan.axes) for t in trials]
            repeats = n - len({p for p in points if p not in self.seen})
            self.run(points, Phase.SEARCH)
            if space < math.inf:  # TPE settles on a finite space's best and repeats it: the
                for point in self._unseen(repeats, fill):  # next batch tries others as well
                    study.enqueue_trial({a.key: a.sampler_value(v) for a, (_, v) in
                                         zip(self.plan.axes, point, strict=True)})
            for trial, point in zip(trials, points, strict=True):
                e = self.seen.get(point)  # None: over the budget, never run
                value = None if e is None else score(e, self.plan)
                if value is None:
                    study.tell(trial, state=optuna.trial.TrialState.FAIL)
                else:
                    study.tell(trial, value)
            if self.plan.objective is None and any(
                    self.seen[p].status.failing for p in points if p in self.seen):
                return

    def _unseen(self, n: int, rng: random.Random) -> list[Point]:
        """Up to n points of a finite space not run yet, drawn with the search's seed."""
        if n <= 0:
            return []
        values = [[a.at(k) for k in range(a.size)] for a in self.plan.axes]
        if math.prod(len(v) for v in values) <= UNSEEN_LISTED:
            left = [p for p in (tuple(zip((a.key for a in self.plan.axes), vs, strict=True))
                                for vs in itertools.product(*values)) if p not in self.seen]
            return rng.sample(left, min(n, len(left)))
        drawn = (tuple((a.key, rng.choice(v)) for a, v in zip(self.plan.axes, values,
                                                                  strict=True))
                 for _ in range(20 * n))
        return list(dict.fromkeys(p for p in drawn if p not in self.seen))[:n]

    def one(self, point: Point) -> Evaluation | None:
        """One point's evaluation (run now unless seen); None when the budget is spent."""
        self.run([point], Phase.SHRINK)
        return self.seen.get(point)

    def shrink(self, start: Evaluation) -> tuple[Evaluation, list[Bracket]]:
        """Move a failure toward the nominal, axis by axis, until no axis moves."""
        current, brackets = start, {}
        for _ in range(PASSES):
            moved = False
            for i in range(len(self.plan.axes)):
                new, bracket = self._shrink_axis(current, i)
                if bracket is not None:
                    brackets[bracket.key] = bracket
                elif self.plan.axes[i].key in brackets and new.point != current.point:
                    del brackets[self.plan.axes[i].key]  # now at the nominal: no boundary
                moved = moved or new.point != current.point
                current = new
            if not moved or self.spent >= self.plan.budget:
                break
        self.settled = self.spent < self.plan.budget
        return current, [brackets[a.key] for a in self.plan.axes if a.key in brackets]

    def _shrink_axis(self, current: Evaluation, i: int) -> tuple[Evaluation, Bracket | None]:
        """Move axis i of a failure toward the nominal: all the way when the nominal value
        still fails there, else by bisection between them (a choice: no order, no bisection)."""
        axis = self.plan.axes[i]
        value = current.point[i][1]
        if value == axis.nominal:
            return current, None
        target = self.one(_moved(current.point, i, axis.nominal))
        if target is None or target.status is RunStatus.INVALID:
            return current, None  # the budget is spent, or no answer there: nothing proven
        if target.status.failing:
            return target, None
        if axis.kind is AxisKind.CHOICE:
            return current, Bracket(axis.key, axis.nominal, value)
        return self._bisect(current, i)

    def _bisect(self, current: Evaluation, i: int) -> tuple[Evaluation, Bracket]:
        """Bisect axis i between the nominal (passing) and the current failure; the points
        already run on that line narrow the bracket first."""
        axis = self.plan.axes[i]
        pass_x, fail_x = axis.position(axis.nominal), axis.position(current.point[i][1])
        fail_e = current
        line = self._on_line(current, i)
        for e in line:  # the nearest failure to the nominal, then the nearest pass to it
            x = axis.position(e.point[i][1])
            if e.status.failing and _between(x, pass_x, fail_x):
                fail_x, fail_e = x, e
        for e in line:
            x = axis.position(e.point[i][1])
            if e.status is RunStatus.PASS and _between(x, pass_x, fail_x) and x != fail_x:
                pass_x = x
        while not self._bracketed(axis, pass_x, fail_x):
            mid = (pass_x + fail_x) / 2
            if axis.kind is not AxisKind.FLOAT:  # a grid index strictly between the two
                mid = float(math.floor(mid) if fail_x > pass_x else math.ceil(mid))
            got = self.one(_moved(current.point, i, axis.at(mid)))
            if got is None or got.status is RunStatus.INVALID:
                break  # the budget is spent, or no answer here: stop rather than guess
            if got.status.failing:
                fail_x, fail_e = mid, got
            else:
                pass_x = mid
        return fail_e, Bracket(axis.key, axis.at(pass_x), axis.at(fail_x))

    def _on_line(self, current: Evaluation, i: int) -> list[Evaluation]:
        """Runs differing from `current` on axis i only."""
        rest = current.point[:i] + current.point[i + 1:]
        return [e for e in self.runs if e.point[:i] + e.point[i + 1:] == rest]

    def _bracketed(self, axis: Axis, pass_x: float, fail_x: float) -> bool:
        if axis.kind is AxisKind.FLOAT:
            return abs(fail_x - pass_x) <= axis.span / self.plan.resolution
        return abs(fail_x - pass_x) <= 1

    def nearest_failure(self) -> Evaluation | None:
        """The failing run nearest the nominal (summed distance over the axes; ties: first)."""
        failing = [e for e in self.runs if e.status.failing]
        if not failing:
            return None
        return min(failing, key=lambda e: sum(a.distance(v, a.nominal) for a, (_, v) in
                                              zip(self.plan.axes, e.point, strict=True)))


def _moved(point: Point, i: int, value: str) -> Point:
    """`point` with axis i at `value`."""
    return tuple((k, value if j == i else old) for j, (k, old) in enumerate(point))


def _between(x: float, pass_x: float, fail_x: float) -> bool:
    """x on the segment from pass_x (excluded) to fail_x (included)."""
    return (pass_x < x <= fail_x) if fail_x > pass_x else (fail_x <= x < pass_x)


def search(plan: Plan, evaluate: Evaluate, progress: Progress | None = None) -> Found:
    """Search, then (criteria, a failure found) shrink; see the module's docstring."""
    if not plan.axes:
        raise SpecError("search: give at least one --over KEY=LOW..HIGH")
    s = _Search(plan, evaluate, progress)
    s.explore()
    failure: Evaluation | None
    brackets: list[Bracket] = []
    if plan.objective is not None:
        failure = _worst([e for e in s.runs if e.status is not RunStatus.INVALID], plan)
    else:
        failure = s.nearest_failure()
        if failure is not None:
            failure, brackets = s.shrink(failure)
    cells = {tuple(a.cell(v) for a, (_, v) in zip(plan.axes, e.point, strict=True))
             for e in s.runs if e.status is not RunStatus.INVALID}
    return Found(plan, tuple(s.runs), failure, tuple(brackets), len(cells),
                 math.prod(a.cells for a in plan.axes), s.settled)
