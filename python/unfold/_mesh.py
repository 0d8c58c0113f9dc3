"""Meshes as numpy arrays and the mesh files unfold reads and writes."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Dict, Mapping, Optional, Union

import numpy as np

from . import _convert, _native

__all__ = ["Mesh", "read_mesh", "write_mesh"]


@dataclass
class Mesh:
    """A mesh in meshio's layout.

    Attributes:
        points: float64 array (n, 3), millimetres.
        cells: one int64 array (m, k) per cell type, keyed by meshio's type
            names (``"tetra"`` (m, 4), ``"triangle"`` (m, 3), ``"line"``
            (m, 2), ``"vertex"``, ``"quad"``, ``"hexahedron"``, ``"wedge"``,
            ``"pyramid"``; variable-size cells by size: ``"polygon5"``,
            ``"polyline3"``, ``"polyvertex2"``).
        point_data: arrays over the points, (n,) or (n, k).
        cell_data: arrays over the cells, (m,) or (m, k), the cells taken in
            the order of the ``cells`` dict's blocks.
    """

    points: np.ndarray
    cells: Dict[str, np.ndarray]
    point_data: Dict[str, np.ndarray] = field(default_factory=dict)
    cell_data: Dict[str, np.ndarray] = field(default_factory=dict)

    @classmethod
    def _from_tuple(cls, t) -> "Mesh":
        points, cells, point_data, cell_data = t
        return cls(points, dict(cells), dict(point_data), dict(cell_data))


def read_mesh(path: Union[str, "os.PathLike[str]"]) -> Mesh:
    """Reads a mesh file; the format comes from the extension.

    Raises:
        UnfoldError: the file cannot be read (the message names it).
    """
    return Mesh._from_tuple(_native.read_mesh(os.fspath(path)))


def write_mesh(
    path: Union[str, "os.PathLike[str]"],
    mesh_or_points: Union[Mesh, np.ndarray],
    cells: Optional[Mapping[str, np.ndarray]] = None,
    point_data: Optional[Mapping[str, np.ndarray]] = None,
    cell_data: Optional[Mapping[str, np.ndarray]] = None,
    *,
    arrays: Optional[Mapping[str, np.ndarray]] = None,
    ascii: bool = False,
) -> None:
    """Writes a mesh file atomically; the format comes from the extension.

    Args:
        path: the file to write (.vtu .vtk .ply .obj .stl .msh .mesh ...).
        mesh_or_points: a :class:`Mesh`, or points (n, 3).
        cells: with points, the cells by meshio type name.
        point_data: arrays over the points.
        cell_data: arrays over the cells (in the order of ``cells``).
        arrays: more point arrays (an alias of ``point_data``, merged into it).
        ascii: text instead of binary where the format has both.

    Raises:
        UnfoldError: a bad array (shape, index out of range, type) or a file
            that cannot be written.
    """
    if isinstance(mesh_or_points, Mesh):
        m = mesh_or_points
        points, cells = m.points, m.cells if cells is None else cells
        point_data = {**m.point_data, **(point_data or {})}
        cell_data = {**m.cell_data, **(cell_data or {})}
    else:
        points = mesh_or_points
        if cells is None:
            cells = {}
    point_data = {**(point_data or {}), **(arrays or {})}
    points = np.ascontiguousarray(np.asarray(points, dtype=np.float64))
    if points.ndim != 2:
        raise _native.UnfoldError(f"points must have shape (n, 3), got {points.shape}")
    _native.write_mesh(
        os.fspath(path),
        points,
        _convert.cells(cells),
        _convert.fields(point_data),
        _convert.fields(cell_data),
        ascii,
    )
