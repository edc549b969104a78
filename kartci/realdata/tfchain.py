"""A pose source from TF: the transform parent -> child through any chain of /tf and /tf_static
edges (map -> odom -> base_link), sampled at the other trajectory's stamps as tf2's lookup
does: each dynamic edge interpolated between its two neighbouring transforms (translation
linearly, rotation by slerp), static edges as they are; a stamp outside any dynamic edge's
recorded span is left out (no extrapolation). evo 1.38's bag reader instead samples a chain on
its own 10 Hz grid and pairs stamps within 10 ms, so its APE on a TF source differs a little
(tests/realdata/test_align_real.py)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from kartci.errors import LogError

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

TF_TYPES = ("tf2_msgs/msg/TFMessage", "tf/msg/tfMessage")


def _frame(name: str) -> str:
    return name.lstrip("/")


@dataclass
class _Edge:
    """One parent -> child transform over time (static: recorded once, valid always)."""

    static: bool = False
    t_ns: list[int] = field(default_factory=list)
    xyz: list[tuple[float, float, float]] = field(default_factory=list)
    quat: list[tuple[float, float, float, float]] = field(default_factory=list)

    def at(self, t_ns: np.ndarray) -> tuple[np.ndarray, Rotation, np.ndarray]:
        """Translations (n x 3), rotations and a mask of the stamps inside the edge's span."""
        from scipy.spatial.transform import Rotation, Slerp  # start-up: 0.3 s, TF sources only

        if self.static:
            n = len(t_ns)
            return (np.tile(self.xyz[-1], (n, 1)), Rotation.from_quat([self.quat[-1]] * n),
                    np.ones(n, bool))
        order = np.argsort(self.t_ns, kind="stable")
        ts = np.asarray(self.t_ns, np.int64)[order]
        keep = np.concatenate([[True], np.diff(ts) > 0])  # one transform per stamp
        ts = ts[keep]
        xyz = np.asarray(self.xyz, float)[order][keep]
        rots = Rotation.from_quat(np.asarray(self.quat, float)[order][keep])
        inside = (t_ns >= ts[0]) & (t_ns <= ts[-1])
        tq = np.clip(t_ns, ts[0], ts[-1])
        rel = (tq - ts[0]) * 1e-9
        knots = (ts - ts[0]) * 1e-9
        pos = np.column_stack([np.interp(rel, knots, xyz[:, k]) for k in range(3)])
        rot = Slerp(knots, rots)(rel) if len(ts) > 1 else Rotation.from_quat(
            [rots.as_quat()[0]] * len(t_ns))
        return pos, rot, inside


class TfTree:
    """Every edge of /tf and /tf_static in a log."""

    def __init__(self) -> None:
        self.edges: dict[tuple[str, str], _Edge] = {}
        self.parent_of: dict[str, str] = {}

    def add(self, m: Any, static: bool) -> None:
        """The transforms of one TFMessage (or ROS 1 tfMessage)."""
        for tr in m.transforms:
            parent, child = _frame(tr.header.frame_id), _frame(tr.child_frame_id)
            edge = self.edges.setdefault((parent, child), _Edge(static=static))
            self.parent_of.setdefault(child, parent)
            st, p, q = tr.header.stamp, tr.transform.translation, tr.transform.rotation
            edge.t_ns.append(int(st.sec) * 1_000_000_000 + int(st.nanosec))
            edge.xyz.append((float(p.x), float(p.y), float(p.z)))
            edge.quat.append((float(q.x), float(q.y), float(q.z), float(q.w)))

    def _up(self, frame: str) -> list[str]:
        """The frame and its ancestors, up to the root."""
        out = [frame]
        while out[-1] in self.parent_of and len(out) <= len(self.parent_of):
            out.append(self.parent_of[out[-1]])
        return out

    def chain(self, parent: str, child: str) -> tuple[list[tuple[str, str]],
                                                      list[tuple[str, str]]]:
        """The edges from the common ancestor down to `parent` and down to `child`; a LogError
        naming the frames the log has when they are not connected."""
        parent, child = _frame(parent), _frame(child)
        up_p, up_c = self._up(parent), self._up(child)
        common = next((f for f in up_c if f in up_p), None)
        frames = {*self.parent_of, *self.parent_of.values()}
        if common is None or parent not in frames or child not in frames:
            raise LogError(f"no TF chain from '{parent}' to '{child}' in the log (frames: "
                           f"{', '.join(sorted(frames)) or 'none'})")
        return self._down(up_p, common), self._down(up_c, common)

    def _down(self, path: list[str], common: str) -> list[tuple[str, str]]:
        """The edges from `common` down `path` (a frame and its ancestors)."""
        return [(self.parent_of[f], f) for f in reversed(path[: path.index(common)])]

    def stamps(self, parent: str, child: str) -> np.ndarray:
        """The stamps of the chain's own data: those of its dynamic edge nearest the child."""
        to_parent, to_child = self.chain(parent, child)
        for key in [*reversed(to_child), *reversed(to_parent)]:
            if not self.edges[key].static:
                return np.unique(np.asarray(self.edges[key].t_ns, np.int64))
        raise LogError(f"the TF chain from '{parent}' to '{child}' is static: it has no "
                       "stamps of its own to sample a trajectory at")

    def _compose(self, edges: Iterable[tuple[str, str]], t_ns: np.ndarray
                 ) -> tuple[np.ndarray, Rotation, np.ndarray]:
        from scipy.spatial.transform import Rotation  # start-up: 0.3 s, TF sources only

        pos = np.zeros((len(t_ns), 3))
        rot = Rotation.identity(len(t_ns))
        ok = np.ones(len(t_ns), bool)
        for key in edges:
            p, r, inside = self.edges[key].at(t_ns)
            pos, rot, ok = pos + rot.apply(p), rot * r, ok & inside
        return pos, rot, ok

    def lookup(self, parent: str, child: str, t_ns: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The stamps inside every dynamic edge's span, with the pose of `child` in `parent`
        at each: (stamps ns, positions n x 3 m, quaternions n x 4 xyzw)."""
        to_parent, to_child = self.chain(parent, child)
        pp, rp, okp = self._compose(to_parent, t_ns)
        pc, rc, okc = self._compose(to_child, t_ns)
        ok = np.flatnonzero(okp & okc)
        if len(ok) == 0:
            return t_ns[:0], np.zeros((0, 3)), np.zeros((0, 4))
        inv = rp[ok].inv()
        return t_ns[ok], inv.apply(pc[ok] - pp[ok]), (inv * rc[ok]).as_quat()
