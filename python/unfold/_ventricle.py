"""``unfold ventricle`` on numpy arrays."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Dict, Optional, Tuple, Union

import numpy as np

from . import _native
from ._convert import mesh_args, point3, points as _points, surface
from ._mesh import Mesh
from ._result import MapResult

__all__ = ["VentricleResult", "ventricle"]


@dataclass
class VentricleResult(MapResult):
    """What :func:`ventricle` returns.

    Attributes:
        points: the anatomy in the canonical cylinder, ``(X, Y, depth)``,
            float64 (n, 3) (``normalized.vtu``).
        cells: the anatomy's cells (one ``"vertex"`` cell per point when it
            has none, as the command line writes them).
        arrays: the command line's arrays: ``xi``, ``zeta``, ``depth`` and
            (LV) ``aha`` per point, plus the anatomy's own.
        point_data: the per-point arrays of ``arrays``.
        cell_data: the per-cell arrays of ``arrays``.
        anatomy: the input anatomy with the same arrays (``anatomy.vtu``).
        disk: the surface S flattened to the disk, arrays ``xi``, ``zeta``
            (``disk.vtu``).
        transferred: the anatomy carried into the second heart
            (``transferred.vtu``), or None without a transfer.
        surface: S when it was built from the anatomy (``surface.vtu``),
            None when it was given.
        report: ``report.json``'s keys: ``inputs``, the library report's,
            ``transfer`` (with one), ``enclosing_surface`` (with a built
            S), ``memory`` (the field's prediction only)
            and ``provenance`` (``interface: "python"``).
    """

    anatomy: Mesh
    disk: Mesh
    transferred: Optional[Mesh]
    surface: Optional[Mesh] = None

    @property
    def mesh(self) -> Mesh:
        """The normalized anatomy as a :class:`Mesh` (to pass to ``write_mesh``)."""
        return Mesh(self.points, self.cells, self.point_data, self.cell_data)


def _opt_float(x) -> Optional[float]:
    return None if x is None else float(x)


def _landmarks(anterior, inferior, apex, rim_near, prefix: str = "") -> Dict[str, Any]:
    """A heart's landmarks as the native functions take them."""
    return {
        f"{prefix}{name}": point3(p, f"{prefix}{name}")
        for name, p in [("anterior", anterior), ("inferior", inferior), ("apex", apex),
                        ("rim_near", rim_near)]
    }


def _chart_settings(chamber, grid_mm, hemisphere_mm, display_exponent,
                    snap_mm) -> Dict[str, Any]:
    """The chart's settings as the native functions take them."""
    return dict(chamber=chamber, grid_mm=_opt_float(grid_mm),
                hemisphere_mm=_opt_float(hemisphere_mm),
                display_exponent=_opt_float(display_exponent), snap_mm=_opt_float(snap_mm))


def _surface(s, what: str) -> Tuple[np.ndarray, np.ndarray]:
    p, cells, _ = surface(s, what, "S")
    return p, cells["triangle"]


def ventricle(
    points=None,
    triangles=None,
    *,
    anterior,
    inferior,
    apex=None,
    rim_near=None,
    anatomy: Union[Mesh, np.ndarray, None] = None,
    surface_voxel_mm: Optional[float] = None,
    surface_margin_mm: Optional[float] = None,
    surface_smoothing: Optional[int] = None,
    chamber: str = "lv",
    grid_mm: Optional[float] = None,
    hemisphere_mm: Optional[float] = None,
    display_exponent: Optional[float] = None,
    snap_mm: Optional[float] = None,
    to_surface: Union[Mesh, Tuple[np.ndarray, np.ndarray], None] = None,
    to_anterior=None,
    to_inferior=None,
    to_apex=None,
    to_rim_near=None,
    to_hemisphere: Optional[float] = None,
    anatomy_name: str = "anatomy",
    surface_name: str = "surface",
    to_name: str = "second surface",
) -> VentricleResult:
    """Carries the anatomy inside a heart chamber into the canonical cylinder
    (``unfold ventricle``).

    The enclosing surface S (disk topology, its boundary loop the basal rim)
    is flattened to the unit disk (LV) or half disk (RV) with the landmarks in
    place, the Laplace field between S and a hemisphere H is solved on a
    grid, and every anatomy point ``v`` goes to ``psi(v) = (phi(v_S), d(v))``,
    ``d(v) = len(v_S -> v) / len(v_S -> v_H)`` along the streamline through
    ``v``. The GIL is released while the Rust code runs.

    Without ``points`` and ``triangles``, S is built from the anatomy as the
    command line does without ``--surface``: voxelized, dilated, filled,
    its boundary smoothed and cut at the basal plane; the rim landmarks
    given on the anatomy's rim are carried onto S's.

    Args:
        points: (n, 3) vertices of S, mm (RAS); None (with ``triangles``)
            to build S from ``anatomy``.
        triangles: (m, 3) triangles of S.
        anterior: the anterior RV insertion point (LV) or first septal corner
            (RV), X, Y, Z on the rim of S (``--anterior``).
        inferior: the inferior RV insertion point or second septal corner.
        apex: the apex (None: the vertex of S farthest from the rim's
            centroid).
        rim_near: a point near the basal rim when S has several openings.
        anatomy: what to map: a :class:`Mesh` (its points are mapped, its
            cells and arrays kept) or (k, 3) points; None maps S's own
            vertices. Required, as a :class:`Mesh` with cells (tets or
            triangles), when S is built from it.
        surface_voxel_mm: with S built: the voxel size, mm (None: 0.5,
            ``--surface-voxel-mm``).
        surface_margin_mm: with S built: how far S stays from the anatomy,
            mm (None: the default, ``--surface-margin-mm``).
        surface_smoothing: with S built: Taubin iterations (None: the
            default, ``--surface-smoothing``).
        chamber: "lv" (default) or "rv".
        grid_mm: Laplace grid spacing, mm (None: the command line's default).
        hemisphere_mm: radius of H, mm (None: the default).
        display_exponent: LV disk display exponent (None: 1/3).
        snap_mm: largest distance from a rim landmark to the rim, mm (None:
            the default).
        to_surface: a second heart's S (a :class:`Mesh` or ``(points,
            triangles)``) to carry the anatomy into, with ``to_anterior``,
            ``to_inferior`` (required) and ``to_apex``, ``to_rim_near``.
        to_hemisphere: instead, carry the anatomy onto a hemisphere of this
            radius, mm.
        anatomy_name, surface_name, to_name: what messages and ``report``
            call the inputs.

    Returns:
        A :class:`VentricleResult`.

    Raises:
        UnfoldError: a bad setting, surface, landmark or anatomy, with the
            command line's message.
    """
    if points is None and triangles is None:
        if anatomy is None:
            raise _native.UnfoldError(
                "give S (points and triangles) or the anatomy to build it from"
            )
        sp = st = None
    elif points is None or triangles is None:
        raise _native.UnfoldError(
            "give both points and triangles of S, or neither (S built from the anatomy)"
        )
    else:
        sp, st = _surface((points, triangles), surface_name)
    if anatomy is None:
        anatomy = Mesh(sp, {"triangle": st})
    elif not isinstance(anatomy, Mesh):
        anatomy = Mesh(_points(anatomy, f"{anatomy_name} points"), {})
    to_points = to_triangles = None
    if to_surface is not None:
        to_points, to_triangles = _surface(to_surface, to_name)
    normalized, anat, disk, transferred, report, built = _native.ventricle(
        sp,
        st,
        mesh_args(anatomy),
        **_landmarks(anterior, inferior, apex, rim_near),
        surface_voxel_mm=_opt_float(surface_voxel_mm),
        surface_margin_mm=_opt_float(surface_margin_mm),
        surface_smoothing=None if surface_smoothing is None else int(surface_smoothing),
        **_chart_settings(chamber, grid_mm, hemisphere_mm, display_exponent, snap_mm),
        to_points=to_points,
        to_triangles=to_triangles,
        **_landmarks(to_anterior, to_inferior, to_apex, to_rim_near, prefix="to_"),
        to_hemisphere=_opt_float(to_hemisphere),
        anatomy_name=anatomy_name,
        surface_name=surface_name,
        to_name=to_name,
    )
    return VentricleResult(
        **MapResult._fields(normalized, report),
        anatomy=Mesh._from_tuple(anat),
        disk=Mesh._from_tuple(disk),
        transferred=None if transferred is None else Mesh._from_tuple(transferred),
        surface=None if built is None else Mesh._from_tuple(built),
    )
