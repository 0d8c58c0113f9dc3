"""``unfold mitral`` on one valve given as numpy arrays."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Tuple, Union

import numpy as np

from . import _native
from ._convert import points as _points, surface
from ._mesh import Mesh
from ._result import MapResult

__all__ = ["MitralResult", "mitral", "mitral_seg"]

Leaflet = Union[Mesh, Tuple[np.ndarray, np.ndarray]]


def _leaflet(x, what: str):
    return surface(x, what, "a leaflet")


@dataclass
class MitralResult(MapResult):
    """What :func:`mitral` returns.

    Attributes:
        points: the valve laid out in 2D at ``(u, v, 0)``, float64 (n, 3)
            (``valve2d.vtu``): the anterior leaflet's vertices, then the
            posterior's.
        cells: ``{"triangle": (m, 3) int64}``, both leaflets.
        arrays: the command line's arrays (``leaflet``, ``u_gradient``,
            ``u_interval``, ``checker``, ``carpentier``, ``area_energy``,
            ``angle_energy``, ``length_energy``, ``coaptation``,
            ``coaptation_distance_mm``, ``tenting_mm``, ``uv``, ...).
        point_data: the per-point arrays of ``arrays``.
        cell_data: the per-triangle arrays of ``arrays``.
        original: the valve in 3D with the same arrays (``valve3d.vtu``).
        report: ``report.json``'s keys: ``inputs`` (the ``name`` given), the
            library report's (measurements, distortion, ...) and
            ``provenance`` (``interface: "python"``).
    """

    original: Mesh


def mitral(
    anterior: Leaflet,
    posterior: Leaflet,
    annulus=None,
    *,
    annulus_mode: str = "landmark",
    init: str = "auto",
    relax: str = "sd",
    energy: str = "symmetric-dirichlet",
    iterations: int = 5,
    step_scale: Optional[float] = None,
    coaptation_mm: float = 2.0,
    tolerance_mm: Optional[float] = None,
    cut_posteromedial: bool = False,
    name: str = "valve",
) -> MitralResult:
    """Lays one mitral valve out in 2D (``unfold mitral``).

    The annulus first (arc length ``u`` and height ``v`` above its plane),
    the leaflets below it, relaxed flip-free (symmetric Dirichlet, projected
    Newton) by default; clinical maps and measurements. The GIL is released
    while the Rust code runs.

    Args:
        anterior: the anterior leaflet, a triangle surface with disk topology:
            a :class:`Mesh` (its triangles and point arrays) or ``(points,
            triangles)``.
        posterior: the posterior leaflet, likewise.
        annulus: (k, 3) the annulus ring's points in ring order, or None to
            find it from the leaflets' shared boundary (as ``unfold mitral``
            without ``--annulus``).
        annulus_mode: "landmark" (default), "least-squares" or "straight".
        init: "auto" (default), "longitudes" or "tutte".
        relax: "sd" (default) or "spring".
        energy: the distortion energy D of the "sd" relaxation
            (``--energy``): "symmetric-dirichlet" (default), "mips", "arap"
            or "area-ratio".
        iterations: spring relaxation steps (``--iterations``).
        step_scale: spring step scale (None: the library's).
        coaptation_mm: coaptation threshold, mm.
        tolerance_mm: distance within which a leaflet boundary vertex lies on
            the ring, mm (None: the library's).
        cut_posteromedial: a second cut at the posteromedial commissure.
        name: what messages and ``report["inputs"]`` call the valve.

    Returns:
        A :class:`MitralResult`.

    Raises:
        UnfoldError: a bad setting, leaflet or ring, with the command line's
            message.
    """
    valve2d, valve3d, report = _native.mitral(
        _leaflet(anterior, f"{name}: anterior leaflet"),
        _leaflet(posterior, f"{name}: posterior leaflet"),
        None if annulus is None else _points(annulus, "annulus"),
        annulus_mode=annulus_mode,
        init=init,
        relax=relax,
        energy=energy,
        iterations=int(iterations),
        step_scale=None if step_scale is None else float(step_scale),
        coaptation_mm=float(coaptation_mm),
        tolerance_mm=None if tolerance_mm is None else float(tolerance_mm),
        cut_posteromedial=bool(cut_posteromedial),
        name=name,
    )
    return MitralResult(**MapResult._fields(valve2d, report), original=Mesh._from_tuple(valve3d))


def mitral_seg(
    labels,
    affine,
    *,
    anterior_label: int,
    posterior_label: int,
    annulus_label: Optional[int] = None,
    annulus_mode: str = "landmark",
    init: str = "auto",
    relax: str = "sd",
    energy: str = "symmetric-dirichlet",
    coaptation_mm: float = 2.0,
    tolerance_mm: Optional[float] = None,
    cut_posteromedial: bool = False,
    name: str = "valve",
) -> MitralResult:
    """Cuts one mitral valve from a label map and lays it out in 2D
    (``unfold mitral --seg LABELS --anterior-label A --posterior-label P``).

    Each leaflet's atrial surface is what is seen of its label from the
    atrium along the annulus plane's normal (the annulus label, when given,
    sets the plane and the atrial side); the annulus ring is the leaflets'
    outer edge. ``report["segmentation"]`` says how the surfaces were made
    (labels, voxels, grid, atrial side, triangles, the cut's gates).

    Args:
        labels: (nx, ny, nz) integer labels, indexed ``[i, j, k]`` as
            nibabel's ``get_fdata()``.
        affine: (4, 4) voxel indices to world mm (any voxel size, rotation).
        anterior_label, posterior_label: the leaflets' labels.
        annulus_label: the annulus' label, or None.
        the rest: as :func:`mitral`.

    Returns:
        A :class:`MitralResult`.

    Raises:
        UnfoldError: a label missing or empty, a map that is not integer
            labels, leaflets that do not touch, with the command line's
            message.
    """
    valve2d, valve3d, report = _native.mitral_seg(
        np.ascontiguousarray(labels, dtype=np.float32),
        np.ascontiguousarray(affine, dtype=np.float64),
        anterior_label=int(anterior_label),
        posterior_label=int(posterior_label),
        annulus_label=None if annulus_label is None else int(annulus_label),
        annulus_mode=annulus_mode,
        init=init,
        relax=relax,
        energy=energy,
        coaptation_mm=float(coaptation_mm),
        tolerance_mm=None if tolerance_mm is None else float(tolerance_mm),
        cut_posteromedial=bool(cut_posteromedial),
        name=name,
    )
    return MitralResult(**MapResult._fields(valve2d, report), original=Mesh._from_tuple(valve3d))
