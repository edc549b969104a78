"""Per-stage track references and lateral bounds for the MPCC, with obstacles and other karts
carved out of the bounds ("narrowing the track bounds", REFERENCE.md)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kartci.worlds.track import Track

NO_LIMIT_M = 1e6


@dataclass(frozen=True)
class Obstacle:
    """Something to keep clear of, in track coordinates: centre progress and lateral offset
    (m), its half-extent (m), and its speed along the track (m/s; 0 for static ones)."""

    s_m: float
    lateral_m: float
    radius_m: float
    speed_mps: float = 0.0
    follow_gap_m: float = 0.0  # > 0: a kart; stay this far behind it when it cannot be passed


def obstacle_from_xy(track: Track, x: float, y: float, radius_m: float, speed_mps: float = 0.0,
                     follow_gap_m: float = 0.0) -> Obstacle:
    """An obstacle at world point (x, y) m, placed in track coordinates."""
    s, lat, _, _ = track.project(np.array([[x, y]]))
    return Obstacle(float(s[0]), float(lat[0]), radius_m, speed_mps, follow_gap_m)


DEFAULT_FLOOR_FRICTION = 0.9  # a map without a floor's friction: concrete (REFERENCE.md)


@dataclass(frozen=True)
class FrictionMap:
    """The floor's friction as the kart's map knows it (the world's floor and zones): the
    plant's `friction_at`, vectorised. `grip` is the tyres' friction coefficient mu there,
    which bounds their peak force per unit load as in the plant (tyres.py)."""

    floor: float  # friction coefficient outside every zone (dimensionless)
    zones: tuple[tuple[float, float, float, float, float], ...] = ()  # x0, y0, x1, y1 m, mu
    tyre_factor: float = 1.0  # the kart's `tire_friction` (dimensionless)

    @classmethod
    def of(cls, world: object, tyre_factor: float) -> FrictionMap:
        """The map of a world's parameters (`floor_friction`, `zones`; a world without them
        is all concrete)."""
        zones = tuple((z.min_m[0], z.min_m[1], z.max_m[0], z.max_m[1], z.friction)
                      for z in getattr(world, "zones", ()))
        return cls(float(getattr(world, "floor_friction", DEFAULT_FLOOR_FRICTION)), zones,
                   tyre_factor)

    def grip(self, xy: np.ndarray) -> np.ndarray:
        """The tyres' friction coefficient at points (n, 2), m: the last zone holding a point
        wins."""
        mu = np.full(len(xy), self.floor)
        for x0, y0, x1, y1, f in self.zones:
            inside = (xy[:, 0] >= x0) & (xy[:, 0] <= x1) & (xy[:, 1] >= y0) & (xy[:, 1] <= y1)
            mu = np.where(inside, f, mu)
        out: np.ndarray = mu * self.tyre_factor
        return out


@dataclass(frozen=True)
class TrackWidths:
    """The track's free widths as periodic interpolation tables, sorted and padded once:
    `np.interp(..., period=)` sorts its table on every call, the same arithmetic otherwise."""

    track: Track
    s_m: np.ndarray  # sample arc lengths, m, one sample of the previous and next lap added
    left_m: np.ndarray  # free width left of the centreline at `s_m`, m
    right_m: np.ndarray  # free width right of the centreline at `s_m`, m

    @classmethod
    def of(cls, track: Track) -> TrackWidths:
        """The tables of `track`, as `np.interp` pads them for its `period`."""
        period = track.length_m
        xp = np.asarray(track.s, dtype=np.float64) % period
        order = np.argsort(xp)
        xp = xp[order]
        left, right = (np.asarray(w, dtype=np.float64)[order]
                       for w in (track.w_left, track.w_right))
        return cls(track, np.concatenate((xp[-1:] - period, xp, xp[0:1] + period)),
                   *(np.concatenate((f[-1:], f, f[0:1])) for f in (left, right)))

    def at(self, s_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The free widths (left, right) at arc lengths `s_m` (m, unwrapped)."""
        length = self.track.length_m
        x = np.mod(s_m, length) % length
        return np.interp(x, self.s_m, self.left_m), np.interp(x, self.s_m, self.right_m)


def stage_params(widths: TrackWidths, s_bar: np.ndarray, step_s: float, padding_m: float,
                 obstacles: list[Obstacle], margin_m: float, kart_length_m: float,
                 squeeze_m: float = 0.0) -> np.ndarray:
    """Rows of [x_ref, y_ref, cos, sin, s_ref, lateral_lo, lateral_hi, s_max] for stages
    1..N at predicted progress `s_bar` (m, unwrapped). Beside a kart it passes the bound on the
    passing side may come `squeeze_m` closer to the track's edge than `padding_m`: clearing the
    kart matters more than the edge's margin."""
    track = widths.track
    n = len(s_bar)
    m = len(track.s)
    wrapped = np.mod(s_bar, track.length_m)
    idx = np.rint(wrapped / track.length_m * m).astype(int) % m
    diff = (track.s[idx] - wrapped + track.length_m / 2) % track.length_m - track.length_m / 2
    s_ref = s_bar + diff  # the progress of the sample the reference is taken at
    heading, xy = track.heading[idx], track.xy[idx]
    left, right = widths.at(s_bar)
    hi = left - padding_m
    lo = padding_m - right
    s_max = np.full(n, NO_LIMIT_M)
    t = step_s * np.arange(1, n + 1)
    for ob in obstacles:
        s_ob = ob.s_m + ob.speed_mps * t
        # the obstacle's progress unwrapped next to the stage's
        gap = (s_ob - s_bar + track.length_m / 2) % track.length_m - track.length_m / 2
        near = np.abs(gap) < ob.radius_m + kart_length_m / 2 + margin_m
        if not near.any():
            continue
        clear = ob.radius_m + margin_m
        left_lo, right_hi = ob.lateral_m + clear, ob.lateral_m - clear
        # only beside a kart: a corridor squeezed past a static box in a bend can be too
        # narrow to enter, and a plan that stops short of it is cheaper than its slack
        squeeze = squeeze_m if ob.follow_gap_m > 0 else 0.0
        room_left, room_right = hi + squeeze - left_lo, right_hi - lo + squeeze
        pass_left = room_left[near].min() >= room_right[near].min()
        if ob.follow_gap_m > 0 and max(room_left[near].min(), room_right[near].min()) < 0:
            # no way past: follow it
            s_max = np.minimum(s_max, np.where(gap > 0, s_bar + gap - ob.follow_gap_m,
                                               NO_LIMIT_M))
            continue
        if pass_left:
            lo = np.where(near, np.maximum(lo, left_lo), lo)
            hi = np.where(near, hi + squeeze, hi)
        else:
            hi = np.where(near, np.minimum(hi, right_hi), hi)
            lo = np.where(near, lo - squeeze, lo)
    return np.column_stack([xy, np.cos(heading), np.sin(heading), s_ref, lo, hi, s_max])


def progress_guess(s0: float, v0: float, step_s: float, n: int,
                   v_max: float) -> np.ndarray:
    """A first guess of the predicted progress: accelerate gently from the current speed."""
    v = np.minimum(max(v0, 1.0) + 1.0 * step_s * np.arange(1, n + 1), v_max)
    return s0 + np.cumsum(v) * step_s
