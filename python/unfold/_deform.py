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
            numbers (the command line's output mesh).
        cells: the input's cells.
        arrays: the input's point and cell arrays (the command line keeps
            them).
        point_data: the per-point arrays of ``arrays``.
        cell_data: the per-cell arrays of ``arrays``.
        report: ``OUT.report.json``'s keys: ``mesh``, ``targets_file`` (the
            names given), ``output`` (empty: no file), ``repair``, the
            library's ``objective``, ``distortion``, ``iterations``,
            ``converged``, ``inverted_tets``, ... and ``provenance``
            (``interface: "python"``). Not converging is not an error:
            ``converged`` is False.
    """


def deform(
    points,
    tets,
    vertices,
    targets,
    *,
    weight: float = 1.0,
    energy: str = "symmetric-dirichlet",
    solver: str = "newton",
    tol: float = 1e-4,
    max_iterations: Optional[int] = None,
    point_data: Optional[Mapping[str, Any]] = None,
    cell_data: Optional[Mapping[str, Any]] = None,
    name: str = "mesh",
    targets_name: str = "targets",
) -> DeformResult:
    """Deforms a tet mesh towards soft point targets (``unfold deform``).

    Minimizes ``sum_k V_k D(J_k) + W sum_b |x_b - t_b|^2`` over the vertex
    positions ``x`` (``V_k`` the rest volumes normalized to sum 1, ``D`` the
    distortion of tet ``k``'s Jacobian against its rest shape, the input),
    starting from the input, every iterate flip-free. The mesh is repaired
    first (coincident vertices welded, degenerate tets dropped) as the command
    line does. The GIL is released while the Rust code runs.

    Args:
        points: (n, 3) rest positions; every tet positively oriented.
        tets: (m, 4) vertex indices, or a cell dict (``{"tetra": ...}``).
        vertices: (k,) 0-based indices of the targeted vertices, each once
            (the targets file's first column).
        targets: (k, 3) their targets.
        weight: W of the target term (``--weight``).
        energy: "symmetric-dirichlet" (default) or "arap" (``--energy``).
        solver: "newton" (default) or "gd" (``--solver``).
        tol: gradient norm to stop at (``--tol``).
        max_iterations: ``--max-iterations`` (None: 200 for newton, 100000
            for gd).
        point_data: point arrays kept on the output. cell_data: cell arrays.
        name: what messages and ``report["mesh"]`` call the mesh.
        targets_name: what messages and ``report["targets_file"]`` call the
            targets.

    Returns:
        A :class:`DeformResult`.

    Raises:
        UnfoldError: a bad setting, target or mesh (not tets, an inverted
            tet), with the command line's message.
    """
    cells = _cells(tets if isinstance(tets, Mapping) else {"tetra": tets})
    v = np.asarray(vertices)
    if v.size and v.dtype.kind not in "iu":
        raise _native.UnfoldError(f"{targets_name}: vertices must be integers, got {v.dtype}")
    v = np.ascontiguousarray(v.reshape(-1), dtype=np.int64)
    t = np.ascontiguousarray(np.asarray(targets, dtype=np.float64))
    if t.ndim == 1 and t.size == 3:
        t = t.reshape(1, 3)
    deformed, report = _native.deform(
        _points(points),
        cells,
        v,
        t,
        point_data=fields(point_data),
        cell_data=fields(cell_data),
        weight=float(weight),
        energy=energy,
        solver=solver,
        tol=float(tol),
        max_iterations=max_iterations,
        name=name,
        targets_name=targets_name,
    )
    return DeformResult(**MapResult._fields(deformed, report))
