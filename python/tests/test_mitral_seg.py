"""unfold.mitral_seg: a valve cut from a label map built here (a saddle
annulus ring of label 1, two leaflet slabs of labels 2 and 3 below it
meeting at a coaptation line, 0.75 mm voxels, a rotated and moved affine)."""

import numpy as np
import pytest

import unfold


def _labels(voxel=0.75, radius=14.0, saddle=2.0, tenting=6.0, tube=1.2, cy=-4.0):
    half = radius + tube + 3 * voxel
    zlo = -tenting - saddle - 1.5 - 3 * voxel
    zhi = saddle + tube + 3 * voxel
    n = int(np.ceil(2 * half / voxel)) + 1
    nz = int(np.ceil((zhi - zlo) / voxel)) + 1
    i, j, k = np.meshgrid(np.arange(n), np.arange(n), np.arange(nz), indexing="ij")
    x, y, z = -half + i * voxel, -half + j * voxel, zlo + k * voxel
    r = np.hypot(x, y)
    t = np.arctan2(y, x)
    rr = (r / radius) ** 2
    mid = saddle * np.cos(2 * t) * rr - tenting * (1 - rr)
    labels = np.zeros((n, n, nz), dtype=np.int16)
    slab = (np.abs(z - mid) <= 0.75) & (r <= radius)
    labels[slab & (y > cy)] = 2
    labels[slab & (y <= cy)] = 3
    ts = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    ring = np.stack([radius * np.cos(ts), radius * np.sin(ts), saddle * np.cos(2 * ts)], 1)
    near = r > radius - 2 * tube
    pts = np.stack([x[near], y[near], z[near]], 1)
    d = np.min(np.linalg.norm(pts[:, None, :] - ring[None, :, :], axis=2), axis=1)
    sub = labels[near]
    sub[d <= tube] = 1
    labels[near] = sub
    c, s = np.cos(0.5), np.sin(0.5)
    rot = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    affine = np.eye(4)
    affine[:3, :3] = rot * voxel
    affine[:3, 3] = np.array([10.0, -20.0, 35.0]) - rot @ np.array([half, half, -zlo])
    length = np.sum(np.linalg.norm(np.roll(ring, -1, 0) - ring, axis=1))
    return labels, affine, length


def test_a_valve_from_a_label_map_maps_flip_free():
    labels, affine, length = _labels()
    res = unfold.mitral_seg(labels, affine, anterior_label=2, posterior_label=3, annulus_label=1)
    seg = res.report["segmentation"]
    assert seg["anterior_label"] == 2 and seg["annulus_label"] == 1
    assert seg["triangles"]["anterior"] > 100 and seg["triangles"]["posterior"] > 50
    assert res.report["flipped_triangles"] == 0
    assert abs(seg["annulus_label_length_mm"] / length - 1) < 0.05
    assert abs(res.report["annulus_length_mm"] / length - 1) < 0.1
    assert all(g["passed"] for g in seg["gates"])


def test_bad_label_maps_name_the_fix():
    labels, affine, _ = _labels()
    with pytest.raises(unfold.UnfoldError, match="label 7 has no voxel"):
        unfold.mitral_seg(labels, affine, anterior_label=7, posterior_label=3)
    with pytest.raises(unfold.UnfoldError, match="not a label map"):
        unfold.mitral_seg(labels * 0.37, affine, anterior_label=2, posterior_label=3)
