"""The line lab as the rendered line cameras draw it: the same pixels for fewer triangles.

PyBullet's TinyRenderer transforms and rasterises every triangle of every visible shape for each
image, and skips shapes with alpha 0. A line camera sees ~2.5 cm of floor, so:
- the 720-triangle ring is hidden and redrawn as `ARCS` visual-only bodies of consecutive chords
  (the same vertices, each triangle's in the same order), and only the arcs near the camera's
  footprint are shown: every other triangle projects outside the image;
- the floor's box, whose top face is two triangles each tested against every pixel, is hidden
  and redrawn as one triangle of the same colour in the same plane (z = 0) that contains it.
The new bodies are static (maximal coordinates) and made after every other body, on the first
rendered frame: geometric runs never have them, and no body id moves.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from kartci._bullet import pb
from kartci.sim.urdf import fixed_frames, parsed
from kartci.worlds.line_lab.world import LineLab

ARCS = 36  # 10 degrees each: 6 cm of line at r = 0.36 m, 2.5x a camera's footprint
Box = tuple[float, float, float, float]  # x0, y0, x1, y1 (m)


def _static_visual(client: int, verts: list[list[float]], idx: list[int],
                   rgba: list[float]) -> int:
    vis = pb.createVisualShape(pb.GEOM_MESH, vertices=verts, indices=idx, rgbaColor=rgba,
                               physicsClientId=client)
    # maximal coordinates: a static object costs the physics step less than a multibody
    body = int(pb.createMultiBody(0, -1, vis, useMaximalCoordinates=True,
                                  physicsClientId=client))
    # in no collision group: nothing can pair with it or hit it with a ray, whatever PyBullet
    # puts in place of the missing collision shape
    pb.setCollisionFilterGroupMask(body, -1, 0, 0, physicsClientId=client)
    return body


class RenderScene:
    """The lab's floor as one triangle and its ring as arcs shown only near the camera."""

    def __init__(self, lab: LineLab) -> None:
        c = self.client = lab.client
        body, (x0, y0), (x1, y1) = lab.floor_box
        pb.changeVisualShape(body, -1, rgbaColor=[1, 1, 1, 0], physicsClientId=c)
        w, h = x1 - x0, y1 - y0  # legs of 6 w and 6 h: the floor lies at 1/6-1/3 of each
        _static_visual(c, [[x0 - w, y0 - h, 0.0], [x0 + 5 * w, y0 - h, 0.0],
                           [x0 - w, y0 + 5 * h, 0.0]], [0, 1, 2], [1, 1, 1, 1])
        self.bodies: list[int] = []
        lo: list[np.ndarray] = []
        hi: list[np.ndarray] = []
        if lab.ring is not None:
            ring, verts, idx = lab.ring
            pb.changeVisualShape(ring, -1, rgbaColor=[0, 0, 0, 0], physicsClientId=c)
            tris = len(idx) // 3
            per = -(-tris // ARCS)
            for start in range(0, tris, per):
                part = idx[3 * start:3 * min(start + per, tris)]
                used = sorted(set(part))
                local = {v: i for i, v in enumerate(used)}
                pts = [verts[v] for v in used]
                self.bodies.append(_static_visual(c, pts, [local[v] for v in part],
                                                  [0, 0, 0, 1]))
                xy = np.asarray(pts)[:, :2]
                lo.append(xy.min(axis=0))
                hi.append(xy.max(axis=0))
        box_lo, box_hi = np.array(lo).reshape(-1, 2).T, np.array(hi).reshape(-1, 2).T
        self.x0, self.y0, self.x1, self.y1 = box_lo[0], box_lo[1], box_hi[0], box_hi[1]
        self.shown = np.ones(len(self.bodies), dtype=bool)

    @classmethod
    def of(cls, lab: LineLab) -> RenderScene:
        """The lab's scene, made once and shared by every camera in it."""
        if lab.render_scene is None:
            lab.render_scene = cls(lab)
        scene: RenderScene = lab.render_scene
        return scene

    def show(self, box: Box | None) -> None:
        """Show only the arcs whose bounding box meets `box`; all of them for None."""
        if box is None:
            want = np.ones(len(self.bodies), dtype=bool)
        else:
            x0, y0, x1, y1 = box
            want = (self.x0 <= x1) & (self.y0 <= y1) & (self.x1 >= x0) & (self.y1 >= y0)
        changed = want != self.shown
        if not changed.any():
            return
        for i in np.flatnonzero(changed).tolist():
            pb.changeVisualShape(self.bodies[i], -1, rgbaColor=[0, 0, 0, float(want[i])],
                                 physicsClientId=self.client)
        self.shown = want


def _radius(geometry: ET.Element | None) -> float | None:
    """Radius of a sphere around a URDF visual's geometry, about its origin; None for a mesh or
    anything it cannot read (such a link is never hidden)."""
    shape = geometry[0] if geometry is not None and len(geometry) else None
    try:
        if shape is None:
            return None
        if shape.tag == "box":
            size = [float(v) for v in shape.get("size", "").split()]
            return 0.5 * math.sqrt(sum(v * v for v in size)) if len(size) == 3 else None
        r, length = float(shape.get("radius", "nan")), float(shape.get("length", "0"))
    except ValueError:
        return None
    if not (math.isfinite(r) and math.isfinite(length)):
        return None
    return {"sphere": r, "cylinder": math.hypot(r, length / 2),
            "capsule": r + length / 2}.get(shape.tag)


def _spheres(urdf: Path) -> dict[str, list[tuple[np.ndarray, float] | None]]:
    """Bounding spheres (centre in base_link, radius, m) of each link's visuals, for links fixed to
    base_link or turning on a joint of one (a wheel: about its joint's origin, whatever its
    angle); None for a visual that cannot be bounded (a mesh). Other links are left out."""
    root = parsed(urdf)
    frames = fixed_frames(urdf)
    turning = {}
    for joint in root.iter("joint"):
        parent, child, origin = joint.find("parent"), joint.find("child"), joint.find("origin")
        if (joint.get("type") in ("revolute", "continuous") and parent is not None
                and child is not None and parent.get("link") in frames):
            ppos, prot = frames[parent.get("link", "")]
            xyz = np.fromstring(origin.get("xyz", "0 0 0") if origin is not None else "0 0 0",
                                sep=" ")
            turning[child.get("link", "")] = ppos + prot @ xyz
    out: dict[str, list[tuple[np.ndarray, float] | None]] = {}
    for link in root.iter("link"):
        name = link.get("name", "")
        if name not in frames and name not in turning:
            continue
        out[name] = []
        for vis in link.findall("visual"):
            origin = vis.find("origin")
            xyz = np.fromstring(origin.get("xyz", "0 0 0") if origin is not None else "0 0 0",
                                sep=" ")
            r = _radius(vis.find("geometry"))
            if r is None:
                out[name].append(None)
            elif name in frames:
                pos, rot = frames[name]
                out[name].append((pos + rot @ xyz, r))
            else:  # the visual swings about the joint's origin
                out[name].append((turning[name], r + float(np.linalg.norm(xyz))))
    return out


def unseen_links(urdf: Path, cameras: list[tuple[np.ndarray, np.ndarray]], fov_rad: float
                 ) -> list[str]:
    """Links of a robot that none of its own cameras (pose in base_link, looking along x, square
    images) can ever see: every visual's bounding sphere lies behind each camera or outside one of
    its four side planes (1 mm slack). The robot is rigid but for turning joints, so this holds in
    every pose; the renderer may skip such links for these cameras."""
    t = math.tan(fov_rad / 2)
    norm = math.sqrt(1 + t * t)

    def outside(c: np.ndarray, r: float) -> bool:
        for pos, rot in cameras:
            x, y, z = (rot.T @ (c - pos)).tolist()
            if not (x + r < 0.0 or max(abs(y), abs(z)) - t * x > (r + 0.001) * norm):
                return False
        return True

    return [name for name, spheres in _spheres(urdf).items()
            if spheres and all(s is not None and outside(*s) for s in spheres)]
