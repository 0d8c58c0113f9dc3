"""``unfold deform`` on numpy arrays."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping, Optional

import numpy as np

from . import _native
from ._convert import cells as _cells
from ._convert import fields, points as _points
from ._result import MapResult

__all__ = ["DeformResult", "deform"]


@dataclass
class DeformResult(MapResult):
    """What :func:`deform` returns.

    Attributes:
        points: the deformed positions, float64 (n, 3), on the input's vertex
            numbers (the command line's output mesh; z = 0 for triangles).
        cells: the input's cells.
        arrays: the input's point and cell arrays (the command line keeps
            them) and the cell arrays ``det_j`` (mapped over rest volume or
            area) and ``inverted`` (1 where ``det_j <= 0``).
        point_data: the per-point arrays of ``arrays``.
        cell_data: the per-cell arrays of ``arrays``.
        report: ``OUT.report.json``'s keys: ``mesh``, ``targets_file``,
            ``init``, ``fixed_file`` (the names given, None when absent),
            ``output`` (empty: no file), ``repair``, the library's
            ``injective``, ``start`` and ``end`` (inverted and folded
            counts), ``untangle``, ``fixed``, ``objective``, ``iterations``,
            ``converged``, ... and ``provenance`` (``interface: "python"``).
            Not converging or finding no injective map is not an error:
            ``converged`` or ``injective`` is False.
    """


def deform(
    points,
    cells,
    vertices=None,
    targets=None,
    *,
    init=None,
    fixed=None,
    fixed_boundary: bool = False,
    weight: float = 1.0,
    energy: str = "symmetric-dirichlet",
    solver: str = "newton",
    tol: float = 1e-4,
    max_iterations: Optional[int] = None,
    point_data: Optional[Mapping[str, Any]] = None,
    cell_data: Optional[Mapping[str, Any]] = None,
    name: str = "mesh",
    targets_name: str = "targets",
    init_name: str = "init",
    fixed_name: str = "fixed",
) -> DeformResult:
    """Maps a tet mesh (into space) or a triangle mesh (to the plane) with the
    least distortion, flip-free, from any start (``unfold deform``).

    Minimizes ``sum_k V_k D(J_k) + W sum_b |x_b - t_b|^2`` over the vertex
    positions ``x`` with the ``fixed`` vertices held exactly at their start
    (``V_k`` the rest volumes or areas normalized to sum 1, ``D`` the
    distortion of element ``k``'s Jacobian against its rest shape, the input
    ``points``). The start is ``init`` (tangled or not: a start that inverts
    elements is untangled first) or, for tets, the input itself; every
    iterate after the untangling is flip-free. A tet mesh without ``init``
    is repaired first (coincident vertices welded, degenerate tets dropped)
    as the command line does. The GIL is released while the Rust code runs.

    Args:
        points: (n, 3) rest positions; every tet positively oriented.
        cells: (m, 4) tets or (m, 3) triangles (a plane or a surface), or a
            cell dict (``{"tetra": ...}`` or ``{"triangle": ...}``).
        vertices: (k,) 0-based indices of the vertices with soft targets,
            each once (the targets file's first column), or None.
        targets: (k, 3) their targets (z = 0 for triangles), or None.
        init: the start (``--init``): (n, 3) for tets; (n, 2), or (n, 3)
            with z = 0, for triangles (required for them). None: the input.
        fixed: 0-based indices of vertices kept exactly at their start
            (``--fixed``), each once.
        fixed_boundary: fix every boundary vertex too (``--fixed-boundary``).
        weight: W of the target term (``--weight``).
        energy: the distortion energy (``--energy``): every energy of the
            registry ("symmetric-dirichlet", the default, "mips", "arap", ...).
        solver: "newton" (default) or "gd" (``--solver``).
        tol: gradient norm to stop at (``--tol``).
        max_iterations: ``--max-iterations`` (None: 1000 for newton, 100000
            for gd).
        point_data: point arrays kept on the output. cell_data: cell arrays.
        name: what messages and ``report["mesh"]`` call the mesh.
        targets_name, init_name, fixed_name: what messages and the report's
            ``targets_file``, ``init`` and ``fixed_file`` call those inputs
            (None in the report when not given).

    Returns:
        A :class:`DeformResult`; its cell arrays ``det_j`` and ``inverted``
        show where the map is inverted. No injective map found is not an
        error: ``report["injective"]`` is False.

    Raises:
        ValueError: ``init`` or ``cells`` of the wrong shape, ``vertices``
            without ``targets``.
        UnfoldError: nothing to do, a bad setting, target, fixed vertex or
            mesh (an inverted tet, a triangle mesh without ``init``, an
            ``init`` off the plane), with the command line's message.
    """
    if isinstance(cells, Mapping):
        c = _cells(cells)
    else:
        a = np.asarray(cells)
        if a.ndim != 2 or a.shape[1] not in (3, 4):
            raise ValueError(
                f"cells: expected (m, 4) tets or (m, 3) triangles, got shape {a.shape}"
            )
        c = _cells({"tetra" if a.shape[1] == 4 else "triangle": a})
    p = _points(points)
    if (vertices is None) != (targets is None):
        raise ValueError("give vertices and targets together (or neither)")
    v = t = None
    if vertices is not None:
        v = np.asarray(vertices)
        if v.size and v.dtype.kind not in "iu":
            raise _native.UnfoldError(f"{targets_name}: vertices must be integers, got {v.dtype}")
        v = np.ascontiguousarray(v.reshape(-1), dtype=np.int64)
        t = np.ascontiguousarray(np.asarray(targets, dtype=np.float64))
        if t.ndim == 1 and t.size == 3:
            t = t.reshape(1, 3)
    start = None
    if init is not None:
        start = np.asarray(init, dtype=np.float64)
        n = len(p)
        if start.ndim != 2 or start.shape[0] != n or start.shape[1] not in (2, 3):
            raise ValueError(
                f"{init_name}: expected shape ({n}, 3) or, for triangles, ({n}, 2), "
                f"got {start.shape}"
            )
        if start.shape[1] == 2:
            start = np.column_stack([start, np.zeros(n)])
        start = np.ascontiguousarray(start)
    f = None
    if fixed is not None:
        f = np.asarray(fixed)
        if f.size and f.dtype.kind not in "iu":
            raise _native.UnfoldError(f"{fixed_name}: vertices must be integers, got {f.dtype}")
        f = np.ascontiguousarray(f.reshape(-1), dtype=np.int64)
    deformed, report = _native.deform(
        p,
        c,
        v,
        t,
        init=start,
        fixed=f,
        fixed_boundary=bool(fixed_boundary),
        point_data=fields(point_data),
        cell_data=fields(cell_data),
        weight=float(weight),
        energy=energy,
        solver=solver,
        tol=float(tol),
        max_iterations=max_iterations,
        name=name,
        targets_name=targets_name,
        init_name=init_name,
        fixed_name=fixed_name,
    )
    return DeformResult(**MapResult._fields(deformed, report))
