"""Point-cloud files: PLY written and read back, foreign PLY layouts, broken files named in one
line; `kartci map` writes a map whose points lie on the hall's surfaces."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import kartci

from kartci.errors import LogError
from kartci.pointcloud import read_ply, voxel_downsample, write_ply


def test_ply_round_trip(tmp_path: Path) -> None:
    xyz = np.random.default_rng(0).uniform(-50, 50, (1000, 3))
    write_ply(tmp_path / "m.ply", xyz, "two\nlines")
    back = read_ply(tmp_path / "m.ply")
    assert np.array_equal(back, xyz.astype(np.float32).astype(float))


def test_foreign_ply_layouts(tmp_path: Path) -> None:
    (tmp_path / "a.ply").write_text("ply\nformat ascii 1.0\nelement vertex 2\nproperty float y\n"
                                    "property float x\nproperty float z\nend_header\n1 2 3\n"
                                    "4 5 6\n")
    assert read_ply(tmp_path / "a.ply").tolist() == [[2, 1, 3], [5, 4, 6]]
    rec = np.array([(1.0, 2.0, 3.0, 7)], dtype=[("x", "<f8"), ("y", "<f8"), ("z", "<f8"),
                                               ("i", "u1")])
    head = ("ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\n"
            "property double y\nproperty double z\nproperty uchar i\nend_header\n")
    (tmp_path / "b.ply").write_bytes(head.encode() + rec.tobytes())
    assert read_ply(tmp_path / "b.ply").tolist() == [[1, 2, 3]]


@pytest.mark.parametrize(("body", "says"), [
    (b"PCD v0.7\n", "not a PLY file"),
    (b"ply\nformat binary_big_endian 1.0\nelement vertex 1\nproperty float x\nproperty "
     b"float y\nproperty float z\nend_header\n" + bytes(12), "binary_big_endian"),
    (b"ply\nformat binary_little_endian 1.0\nelement vertex 9\nproperty float x\nproperty "
     b"float y\nproperty float z\nend_header\n" + bytes(12), "truncated"),
    (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float a\nend_header\n1\n", "no x, y"),
])
def test_broken_ply_is_one_clear_error(tmp_path: Path, body: bytes, says: str) -> None:
    (tmp_path / "x.ply").write_bytes(body)
    with pytest.raises(LogError, match=says):
        read_ply(tmp_path / "x.ply")


def test_voxel_downsample_keeps_one_centroid_per_voxel() -> None:
    pts = np.array([[0.1, 0.1, 0.1], [0.3, 0.3, 0.3], [1.5, 0.0, 0.0]])
    assert np.allclose(voxel_downsample(pts, 1.0), [[0.2, 0.2, 0.2], [1.5, 0.0, 0.0]])


@pytest.mark.long(reason="kartci runs end to end")
def test_kartci_map_writes_the_halls_surfaces(tmp_path: Path) -> None:
    """A coarse mapping run: the walls at x = 0 and 32 m, y = 0 and 20 m, the floor at 0 and
    the ceiling at 4 m all appear; nothing lies outside the hall."""
    out = tmp_path / "hall.ply"
    r = kartci("map", "winti/hall", "--out", out, "--step-m", "16", "--voxel-m", "0.5")
    assert r.returncode == 0, r.stderr
    xyz = read_ply(out)
    assert len(xyz) > 1000 and f"{len(xyz)} points" in r.stdout
    lo, hi = xyz.min(axis=0), xyz.max(axis=0)
    assert lo == pytest.approx([0.0, 0.0, 0.0], abs=0.3)
    assert hi == pytest.approx([32.0, 20.0, 4.0], abs=0.3)
    bad = kartci("map", "winti/nowhere", "--out", out)
    assert bad.returncode == 2 and "winti/nowhere" in bad.stderr
