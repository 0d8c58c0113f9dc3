"""``unfold ventricle-inverse`` on numpy arrays."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Union

import numpy as np

from . import _native
from ._convert import mesh_args, points as _points
from ._mesh import Mesh
from ._result import MapResult
from ._ventricle import _chart_settings, _landmarks, _surface

__all__ = ["InverseResult", "ventricle_inverse"]


@dataclass
class InverseResult(MapResult):
    """What :func:`ventricle_inverse` returns (``mapped.vtu`` and
    ``report.json``).

    Attributes:
        points: the points carried onto the heart, mm (RAS), float64 (n, 3);
            a point that could not be mapped sits at the centre of the base
            (``report["failed_points_at_mm"]``).
        cells: the input's cells (one ``"vertex"`` cell per point when it
            has none).
        arrays: the input's arrays plus ``inverse_status`` (0 mapped, 1 not
            a cylinder point, 2 off the disk, 3 streamline failed), ``xi``,
            ``zeta``, ``depth`` (the coordinates used) and, with ``layers``,
            ``layer``.
        report: ``report.json``'s keys: ``inputs``, ``points``, ``mapped``,
            ``failed``, ``failures``, ``first_failures``, the chart's
            settings, ``seconds``, ``memory`` (the field's prediction only)
            and ``provenance`` (``interface: "python"``).
    """


def ventricle_inverse(
    normalized: Union[Mesh, np.ndarray],
    points,
    triangles,
    *,
    anterior,
    inferior,
    apex=None,
    rim_near=None,
    coordinates: str = "auto",
    layers: Optional[int] = None,
    chamber: str = "lv",
    grid_mm: Optional[float] = None,
    hemisphere_mm: Optional[float] = None,
    display_exponent: Optional[float] = None,
    snap_mm: Optional[float] = None,
    normalized_name: str = "normalized",
    surface_name: str = "surface",
) -> InverseResult:
    """Carries a mesh given in the canonical cylinder back onto a heart,
    ``v = psi^-1(xi, zeta, depth)`` (``unfold ventricle-inverse``).

    The chart of the heart is built from S and its landmarks as
    :func:`ventricle` builds it; every point is mapped on its own, and one
    that cannot be (depth outside [0, 1], a disk position outside the
    flattened S, a failed streamline) gets a status instead of failing the
    call. The GIL is released while the Rust code runs.

    Args:
        normalized: what to carry: a :class:`Mesh` (e.g. a
            :func:`ventricle` result's ``mesh``, a label field drawn on the
            disk; its cells and arrays are kept) or (k, 3) points.
        points: (n, 3) vertices of the heart's S, mm (RAS).
        triangles: (m, 3) triangles of S.
        anterior, inferior, apex, rim_near: S's landmarks, as for
            :func:`ventricle`.
        coordinates: where the cylinder coordinates come from: "arrays"
            (the point arrays ``xi``, ``zeta``, ``depth``), "points" (the
            points as ``(X, Y, depth)`` on the displayed disk) or "auto"
            (default: the arrays when all three are there, else the points).
        layers: label this many transmural layers of equal depth
            (``layer``, 1 at S to ``layers`` at H; 1 to 100).
        chamber, grid_mm, hemisphere_mm, display_exponent, snap_mm: the
            chart's settings, as for :func:`ventricle`.
        normalized_name, surface_name: what messages and ``report`` call
            the inputs.

    Returns:
        An :class:`InverseResult`.

    Raises:
        UnfoldError: a bad setting, surface, landmark or coordinates, or no
            point mapped, with the command line's message.
    """
    sp, st = _surface((points, triangles), surface_name)
    if not isinstance(normalized, Mesh):
        normalized = Mesh(_points(normalized, f"{normalized_name} points"), {})
    mapped, report = _native.ventricle_inverse(
        mesh_args(normalized),
        sp,
        st,
        **_landmarks(anterior, inferior, apex, rim_near),
        coordinates=coordinates,
        layers=None if layers is None else int(layers),
        **_chart_settings(chamber, grid_mm, hemisphere_mm, display_exponent, snap_mm),
        normalized_name=normalized_name,
        surface_name=surface_name,
    )
    return InverseResult(**MapResult._fields(mapped, report))
