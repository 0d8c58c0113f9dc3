"""``unfold mesh`` on a numpy mask."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from . import _native
from ._convert import image
from ._mesh import Mesh
from ._result import MapResult

__all__ = ["TetMeshResult", "tet_mesh"]


@dataclass
class TetMeshResult(MapResult):
    """What :func:`tet_mesh` returns.

    Attributes:
        points: the mesh's vertices, float64 (n, 3), mm in the mask's world
            (RAS) frame.
        cells: ``{"tetra": (m, 4) int64}``.
        arrays: empty (the command line's mesh file holds the tets only), as
            ``point_data`` and ``cell_data``.
        report: the figures ``unfold mesh`` prints: ``mask``, ``mask_voxels``,
            ``mask_volume_mm3``, ``size_mm``, ``smooth_voxels``, ``dilate``,
            ``level``, ``graded_collapses``, ``components``,
            ``dropped_components``, ``quality`` (tets, vertices, boundary
            triangles, volume, dihedral angle range) and ``provenance``
            (``unfold mesh`` writes no report.json).
    """



def tet_mesh(
    mask,
    affine=None,
    *,
    size_mm: Optional[float] = None,
    smooth_voxels: float = 1.5,
    dilate: int = 0,
    threshold: Optional[float] = None,
    label: Optional[float] = None,
    level: Optional[float] = None,
    grade: bool = False,
    keep_all_components: bool = False,
    name: str = "mask",
) -> TetMeshResult:
    """A tet mesh of a segmentation (``unfold mesh``).

    Optional dilation, Gaussian smoothing of the mask, then the level set
    ``c`` of the smoothed mask meshed by isosurface stuffing in world
    coordinates; the largest connected component is kept (with a warning on
    stderr naming the others' sizes) unless ``keep_all_components``. The GIL
    is released while the Rust code runs.

    Args:
        mask: a 3D array (i, j, k), 0 outside and one other value inside (a
            label map with ``label``, any values with ``threshold``), or a
            nibabel image (then ``affine`` is its own).
        affine: 4x4 voxel-to-RAS affine (mm).
        size_mm: lattice cube side, mm (``--size-mm``; None: the smallest
            voxel spacing).
        smooth_voxels: Gaussian smoothing, voxels (``--smooth-voxels``; 0:
            none).
        dilate: 3x3x3 box dilations before smoothing, 0 or 1 (``--dilate``).
        threshold: voxels above it are inside (``--threshold``; None: the
            mask's one value besides 0 is inside).
        label: voxels equal to it are inside (``--label``: one structure of
            a label map; not with ``threshold``).
        level: the level of the smoothed mask in (0, 1) (``--level``; None: the
            level that keeps the mask's volume).
        grade: coarser tets inside (``--grade``).
        keep_all_components: keep every connected component.
        name: what messages and ``report["mask"]`` call the mask.

    Returns:
        A :class:`TetMeshResult`.

    Raises:
        UnfoldError: a bad setting or mask, with the command line's message
            (e.g. a label map without ``label`` or ``threshold``).
    """
    if affine is None and not hasattr(mask, "affine"):
        raise _native.UnfoldError(f"{name}: give the mask's 4x4 affine (or a nibabel image)")
    data, aff = image(mask if affine is None else (mask, affine), name)
    (points, cells, _, _), report = _native.tet_mesh(
        data,
        aff,
        size_mm=None if size_mm is None else float(size_mm),
        smooth_voxels=float(smooth_voxels),
        dilate=int(dilate),
        threshold=None if threshold is None else float(threshold),
        label=None if label is None else float(label),
        level=None if level is None else float(level),
        grade=bool(grade),
        keep_all_components=bool(keep_all_components),
        name=name,
    )
    return TetMeshResult(**MapResult._fields(Mesh(points, dict(cells)), report))
