"""Argument coercion shared by the pipelines: numpy arrays of the dtypes and
shapes the native module takes, with :class:`UnfoldError` for what cannot be
one."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Dict, Mapping, Optional, Tuple

import numpy as np

from . import _native

if TYPE_CHECKING:
    from ._mesh import Mesh


def points(a, what: str = "points") -> np.ndarray:
    """``a`` as a C-contiguous float64 (n, 3) array.

    Raises:
        UnfoldError: ``a`` is not two-dimensional with 3 columns.
    """
    p = np.ascontiguousarray(np.asarray(a, dtype=np.float64))
    if p.ndim != 2 or p.shape[1] != 3:
        raise _native.UnfoldError(f"{what} must have shape (n, 3), got {p.shape}")
    return p


def indices(a, columns: int, what: str) -> np.ndarray:
    """``a`` as a C-contiguous int64 (m, columns) array of indices.

    Raises:
        UnfoldError: not integers, or not of shape (m, columns).
    """
    t = np.asarray(a)
    if t.size and t.dtype.kind not in "iu":
        raise _native.UnfoldError(f"{what} must be integers, got {t.dtype}")
    t = np.ascontiguousarray(t, dtype=np.int64)
    if t.ndim != 2 or t.shape[1] != columns:
        raise _native.UnfoldError(f"{what} must have shape (m, {columns}), got {t.shape}")
    return t


_FIELD_TYPES = (np.float64, np.float32, np.int64, np.int32, np.uint8)


def field(a) -> np.ndarray:
    """A point or cell array in a dtype the native module takes (bool as
    uint8, other integers as int32/int64, other floats as float64)."""
    a = np.asarray(a)
    if a.dtype == np.bool_:
        a = a.astype(np.uint8)
    elif a.dtype.kind in "iu" and a.dtype.type not in _FIELD_TYPES:
        a = a.astype(np.int64 if a.dtype.itemsize > 4 or a.dtype.kind == "u" else np.int32)
    elif a.dtype.kind == "f" and a.dtype.type not in _FIELD_TYPES:
        a = a.astype(np.float64)
    return np.ascontiguousarray(a)


def cells(c: Mapping[str, Any]) -> Dict[str, np.ndarray]:
    """A cell dict with every block int64 (m, k).

    Raises:
        UnfoldError: a block that is not a 2-D integer array.
    """
    out = {}
    for k, v in c.items():
        v = np.asarray(v)
        if v.ndim != 2 or (v.size and v.dtype.kind not in "iu"):
            raise _native.UnfoldError(
                f"cells['{k}']: expected a 2-D integer array, got shape {v.shape} of {v.dtype}"
            )
        out[k] = np.ascontiguousarray(v, dtype=np.int64)
    return out


def fields(d: Optional[Mapping[str, Any]]) -> Dict[str, np.ndarray]:
    """Point or cell arrays in the dtypes the native module takes."""
    return {k: field(v) for k, v in (d or {}).items()}


def mesh_args(m: Mesh) -> Tuple[np.ndarray, Dict[str, np.ndarray], Dict, Dict]:
    """A :class:`Mesh` as the native module's ``(points, cells, point_data, cell_data)``."""
    return points(m.points), cells(m.cells), fields(m.point_data), fields(m.cell_data)


def point3(p, what: str) -> Optional[Tuple[float, float, float]]:
    """A point given as three numbers (None stays None).

    Raises:
        UnfoldError: not three numbers.
    """
    if p is None:
        return None
    a = np.asarray(p, dtype=np.float64).ravel()
    if a.shape != (3,):
        raise _native.UnfoldError(f"{what} must be three coordinates X, Y, Z, got shape {a.shape}")
    return float(a[0]), float(a[1]), float(a[2])


def image(x, what: str) -> Tuple[np.ndarray, np.ndarray]:
    """An image as ``(float32 data, float64 4x4 affine)``: a ``(data,
    affine)`` pair, or anything with ``get_fdata()`` and ``affine`` (a
    nibabel image).

    Raises:
        UnfoldError: neither.
    """
    if hasattr(x, "get_fdata") and hasattr(x, "affine"):
        data, affine = x.get_fdata(dtype=np.float32), x.affine
    else:
        try:
            data, affine = x
        except (TypeError, ValueError):
            raise _native.UnfoldError(
                f"{what}: expected (data, affine) or a nibabel image, got {type(x).__name__}"
            ) from None
    data = np.ascontiguousarray(np.asarray(data, dtype=np.float32))
    affine = np.ascontiguousarray(np.asarray(affine, dtype=np.float64))
    return data, affine


def surface(x, what: str, noun: str) -> Tuple[np.ndarray, Dict[str, np.ndarray], Dict]:
    """A triangle surface given as a :class:`Mesh` or ``(points, triangles)``,
    as the native module's ``(points, {"triangle": ...}, point_data)``.

    Args:
        x: the surface.
        what: its name in messages.
        noun: what it is, for the message of a mesh without triangles
            ("a leaflet", "S").

    Raises:
        UnfoldError: neither form, or a mesh without triangles.
    """
    from ._mesh import Mesh

    if isinstance(x, Mesh):
        if "triangle" not in x.cells:
            raise _native.UnfoldError(f"{what}: has no triangles; {noun} is a triangle surface")
        p, t, data = x.points, x.cells["triangle"], fields(x.point_data)
    else:
        try:
            p, t = x
        except (TypeError, ValueError):
            raise _native.UnfoldError(
                f"{what}: expected a Mesh or (points, triangles), got {type(x).__name__}"
            ) from None
        data = {}
    return points(p, f"{what} points"), {"triangle": indices(t, 3, f"{what} triangles")}, data
