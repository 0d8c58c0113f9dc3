"""What every pipeline function returns: :class:`MapResult`."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any, Dict

import numpy as np

from ._mesh import Mesh

__all__ = ["MapResult"]


@dataclass
class MapResult:
    """A pipeline's mapped mesh and its report (the base of every ``*Result``).

    Attributes:
        points: the mapped points, float64 (n, 3).
        cells: the cells by type name (``"tetra"``, ``"triangle"``, ...), int64.
        arrays: the command line's output arrays by name (``point_data`` and
            ``cell_data`` together).
        point_data: the per-point arrays of ``arrays``.
        cell_data: the per-cell arrays of ``arrays``.
        report: the keys of the command line's ``report.json``.
    """

    points: np.ndarray
    cells: Dict[str, np.ndarray]
    arrays: Dict[str, np.ndarray]
    point_data: Dict[str, np.ndarray]
    cell_data: Dict[str, np.ndarray]
    report: Dict[str, Any]

    @property
    def mesh(self) -> Mesh:
        """The mapped mesh with its arrays as a :class:`Mesh` (to pass to ``write_mesh``)."""
        return Mesh(self.points, self.cells, self.point_data, self.cell_data)

    @staticmethod
    def _fields(mesh: Any, report_json: str) -> Dict[str, Any]:
        """The base fields from a native mesh tuple and the report's JSON text."""
        m = mesh if isinstance(mesh, Mesh) else Mesh._from_tuple(mesh)
        return dict(
            points=m.points,
            cells=dict(m.cells),
            arrays={**m.point_data, **m.cell_data},
            point_data=dict(m.point_data),
            cell_data=dict(m.cell_data),
            report=json.loads(report_json),
        )
