"""The synthetic shapes of ``unfold demo`` (``unfold_mesh::shapes``), and a
mask to mesh, so tutorials and tests need no files."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import numpy as np

from . import _native
from ._mesh import Mesh

__all__ = [
    "MitralValve",
    "VentricleCup",
    "ellipsoid_mask",
    "mitral_valve",
    "placenta_slab",
    "ventricle_cup",
]


def placenta_slab(cells_radial: Optional[int] = None) -> Mesh:
    """The demo's placenta-like tet slab in its own frame (point array ``side``).

    Args:
        cells_radial: the resolution (cells across the radius); None for the
            library's default.
    """
    return Mesh._from_tuple(_native.placenta_slab(cells_radial))


@dataclass
class VentricleCup:
    """The demo's ventricle: a cup-shaped chamber and the anatomy inside it.

    Attributes:
        surface: the enclosing surface S (triangles, disk topology, its
            boundary loop the basal rim), for :func:`unfold.ventricle`.
        anatomy: a smaller cup strictly inside S (triangles).
        anatomy_points: (k, 3) points strictly inside S.
        anterior: the anterior RV insertion point (a rim vertex of S), (3,).
        inferior: the inferior RV insertion point, (3,).
        apex: the apex (a vertex of S), (3,).
    """

    surface: Mesh
    anatomy: Mesh
    anatomy_points: np.ndarray
    anterior: np.ndarray
    inferior: np.ndarray
    apex: np.ndarray


def ventricle_cup(rings: Optional[int] = None) -> VentricleCup:
    """The demo's ventricle cup (``unfold demo``'s ``ventricle_*.vtu``).

    Args:
        rings: rings of latitude of S (its resolution); None for the
            library's default.
    """
    s, a, pts, ant, inf, apex = _native.ventricle_cup_shape(rings)
    return VentricleCup(Mesh._from_tuple(s), Mesh._from_tuple(a), pts, ant[0], inf[0], apex[0])


@dataclass
class MitralValve:
    """The demo's mitral valve.

    Attributes:
        anterior: the anterior leaflet (triangles, disk topology).
        posterior: the posterior leaflet.
        annulus: (k, 3) the annulus ring in ring order.
    """

    anterior: Mesh
    posterior: Mesh
    annulus: np.ndarray


def mitral_valve() -> MitralValve:
    """The demo's mitral valve (``unfold demo``'s ``valve_*.vtu``), for
    :func:`unfold.mitral`."""
    a, p, ring = _native.mitral_valve_shape()
    return MitralValve(Mesh._from_tuple(a), Mesh._from_tuple(p), ring)


def ellipsoid_mask(
    radii_mm: Sequence[float] = (20.0, 14.0, 8.0),
    spacing_mm: float = 2.0,
    margin_voxels: int = 3,
) -> Tuple[np.ndarray, np.ndarray]:
    """A binary mask of an axis-aligned ellipsoid centred at the origin, for
    :func:`unfold.tet_mesh`: voxel ``[i, j, k]`` is 1 when its centre ``x``
    has ``sum (x_a / r_a)^2 <= 1``.

    Args:
        radii_mm: the semi-axes, mm.
        spacing_mm: the isotropic voxel size, mm.
        margin_voxels: empty voxels around the ellipsoid on every side.

    Returns:
        ``(mask, affine)``: uint8 (nx, ny, nz) and the 4x4 voxel-to-RAS
        affine (diagonal spacing, the origin at the grid's centre).
    """
    r = np.asarray(radii_mm, dtype=np.float64)
    n = (2 * np.ceil(r / spacing_mm) + 1 + 2 * margin_voxels).astype(int)
    origin = -spacing_mm * (n - 1) / 2.0
    affine = np.diag([spacing_mm, spacing_mm, spacing_mm, 1.0])
    affine[:3, 3] = origin
    axes = [origin[a] + spacing_mm * np.arange(n[a]) for a in range(3)]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    mask = ((x / r[0]) ** 2 + (y / r[1]) ** 2 + (z / r[2]) ** 2 <= 1.0).astype(np.uint8)
    return mask, affine
