"""``unfold placenta`` on numpy arrays."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Dict, Mapping, Optional, Tuple, Union

import numpy as np

from . import _native
from ._convert import image
from ._mesh import Mesh
from ._result import MapResult

__all__ = ["PlacentaResult", "placenta"]


@dataclass
class PlacentaResult(MapResult):
    """What :func:`placenta` returns.

    Attributes:
        points: the flattened mesh's points in the template frame, float64
            (n, 3) (``flattened.vtu`` of the command line).
        cells: ``{"tetra": (m, 4) int64}``, the input's tets (oriented).
        arrays: the flattened mesh's arrays under the command line's names:
            ``side`` (per point: 0 interior, 1 fetal, 2 maternal, 3 margin),
            ``log2_det_j`` and ``sym_dirichlet`` (per tet).
        point_data: the per-point arrays of ``arrays``.
        cell_data: the per-tet arrays of ``arrays``.
        original: the input as the pipeline used it (``original.vtu``).
        images: each image of ``images`` pulled into the template grid,
            name -> ``(data, affine)``: float32 data (nx, ny, nz) or (nx, ny,
            nz, nt) indexed ``[i, j, k, t]`` as nibabel's, and its 4x4 RAS
            affine; the command line's ``<name>_flat.nii.gz`` (which stores
            label maps pulled by nearest neighbour in their integer type).
        report: ``report.json``'s keys: ``mesh`` (the ``name`` given), the
            library report's keys, ``memory`` and ``provenance``. The last two
            differ from the command line's: ``memory`` holds the prediction
            only (no budget, ``limit_source`` "unknown"); ``provenance`` has
            ``interface: "python"``, no command line, no input hashes and no
            run hash.
    """

    original: Mesh
    images: Dict[str, Tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)


def placenta(
    points,
    tets,
    images=None,
    template: Union[str, Any] = "planes",
    lam: float = 1.0,
    *,
    margin_mm: Optional[float] = None,
    gamma: float = 20.0,
    rings: int = 3,
    fix_h: Optional[float] = None,
    voxel_mm: float = 3.0,
    solver: str = "newton",
    energy: str = "symmetric-dirichlet",
    tol: float = 1e-4,
    max_iterations: Optional[int] = None,
    name: str = "mesh",
    progress: Optional[Callable[[str, int, float], Any]] = None,
    interp: str = "linear",
    spacing_mm: Optional[float] = None,
    frame_check: bool = True,
) -> PlacentaResult:
    """Flattens a placenta tet mesh onto a template (``unfold placenta``).

    Minimizes ``phi(X, theta) = sum_m A_m T(x_m, theta) + lam sum_k V_k D(J_k)``
    (template term over the fetal, maternal and margin boundary vertices plus
    the distortion, symmetric Dirichlet unless ``energy`` says otherwise), flip-free, with the command line's
    defaults. The GIL is released while the Rust code runs.

    Args:
        points: (n, 3) vertex positions, mm, scanner frame (RAS).
        tets: (m, 4) vertex indices.
        images: images in the mesh's scanner frame to pull into the template
            (``--image``): a dict name -> image, each a ``(data, affine)``
            pair (data 3D or 4D indexed ``[i, j, k, t]``, affine 4x4
            voxel-to-RAS) or a nibabel image (``get_fdata()`` and
            ``affine``). The result's ``images`` holds them by name.
        template: "planes" (default), "ellipsoid" or "single-plane", or a
            Python template: an :class:`unfold.Template` (any object with its
            attributes and methods), called by the Rust solver.
        lam: the distortion weight lambda (``--lambda``).
        margin_mm: ``--margin-mm`` (None: five voxels of voxel_mm, 15 mm at
            3 mm). voxel_mm: ``--voxel-mm``. gamma, rings: ``--gamma``,
            ``--rings`` (the parcellation's affinity). fix_h: ``--fix-h``, the
            half thickness h held at this value (planes, single-plane).
        solver: "newton" (default) or "gd". tol: ``--tol``.
        energy: the distortion energy D (``--energy``):
            "symmetric-dirichlet" (default), "mips", "arap" or "area-ratio".
        max_iterations: ``--max-iterations`` (None: the solver's default).
        name: what messages and ``report["mesh"]`` call the mesh.
        progress: called as ``progress(stage, iteration, value)`` with the GIL
            held: at each stage (iteration 0, value NaN) and at most every
            0.1 s during the optimization (value: the objective). An exception
            it raises stops further calls and is raised after the run.
        interp: how the images are sampled, "linear" (default) or "nearest"
            (label maps) (``--interp``).
        spacing_mm: isotropic voxel size of the template-space images, mm
            (``--spacing-mm``; None: each image's own spacing).
        frame_check: check that the mesh lies in each image's foreground
            (False: ``--no-frame-check``).

    Returns:
        A :class:`PlacentaResult`.

    Raises:
        UnfoldError: bad settings or an unusable mesh, with the command
            line's message, which names the flag (``--lambda`` for ``lam``,
            ``--margin-mm`` for ``margin_mm``, ...) or the problem (e.g.
            several connected components); a Python
            template's method returning the wrong number of values or a
            non-finite one.
        Exception: whatever a Python template's method raised (the run
            stops at its first exception).
    """
    if images is not None and not isinstance(images, Mapping):
        raise _native.UnfoldError(
            f"images must be a dict name -> (data, affine) or nibabel image, got "
            f"{type(images).__name__}"
        )
    pulled = [(str(k), *image(v, str(k))) for k, v in (images or {}).items()]
    p = np.ascontiguousarray(np.asarray(points, dtype=np.float64))
    t = np.asarray(tets)
    if t.size and t.dtype.kind not in "iu":
        raise _native.UnfoldError(f"tets must be integers, got {t.dtype}")
    t = np.ascontiguousarray(t, dtype=np.int64)
    if p.ndim != 2 or t.ndim != 2:
        raise _native.UnfoldError(
            f"points must have shape (n, 3) and tets (m, 4), got {p.shape} and {t.shape}"
        )
    flat, original, report, flat_images = _native.placenta(
        p,
        t,
        template=template,
        lam=float(lam),
        margin_mm=None if margin_mm is None else float(margin_mm),
        gamma=float(gamma),
        rings=int(rings),
        fix_h=None if fix_h is None else float(fix_h),
        voxel_mm=float(voxel_mm),
        solver=solver,
        energy=energy,
        tol=float(tol),
        max_iterations=max_iterations,
        name=name,
        progress=progress,
        images=pulled,
        interp=interp,
        spacing_mm=None if spacing_mm is None else float(spacing_mm),
        frame_check=bool(frame_check),
    )
    return PlacentaResult(
        **MapResult._fields(flat, report),
        original=Mesh._from_tuple(original),
        images=dict(flat_images),
    )
