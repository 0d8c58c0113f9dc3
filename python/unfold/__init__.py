"""unfold: map anatomical shapes onto canonical templates, numpy in, numpy out.

The functions run the same Rust library as the ``unfold`` command line, with
its defaults and its one-line error messages:

* :func:`read_mesh` / :func:`write_mesh`: every mesh format of ``unfold
  convert`` (VTK XML and legacy, PLY, OBJ, STL, gmsh, medit) as a
  :class:`Mesh` of numpy arrays (meshio's layout);
* :func:`tet_mesh`: ``unfold mesh`` on a mask, returning a
  :class:`TetMeshResult`;
* :func:`placenta`: ``unfold placenta`` on a tet mesh (and images), returning
  a :class:`PlacentaResult`;
* :func:`ventricle`: ``unfold ventricle`` on an enclosing surface, its
  landmarks and an anatomy, returning a :class:`VentricleResult`;
* :func:`ventricle_inverse`: ``unfold ventricle-inverse``, a mesh in the
  cylinder carried back onto a heart, returning an :class:`InverseResult`;
* :func:`mitral`: ``unfold mitral`` on one valve, returning a
  :class:`MitralResult`; :func:`mitral_seg` the same from a label map
  (``unfold mitral --seg``);
* :func:`deform`: ``unfold deform`` on a tet or triangle mesh with soft
  targets, a start (tangled or not) and fixed vertices, returning a
  :class:`DeformResult`;
* :class:`Template`: a placenta template written in Python (value,
  gradient, Hessian and parameter gradient as numpy), checked by
  :func:`check_template`;
* :mod:`unfold.shapes`: the synthetic shapes of ``unfold demo`` and a mask;
* :mod:`unfold.cohort`: ``compare(study, column, ...)``, ``unfold cohort
  --compare`` on a batch's output, the maps as numpy arrays;
* :mod:`unfold.dask`: ``unfold batch`` + ``unfold cohort`` on a Dask cluster
  (imported on its own: ``import unfold.dask``; needs the ``dask`` extra);
* ``python -m unfold ARGS``: the ``unfold`` command line itself.

Each result is a :class:`MapResult`: ``points`` (the mapped points, float64
(n, 3)), ``cells``, ``arrays`` (the command line's output arrays by name),
``report`` (the keys of the command line's report) and ``mesh`` (all of it
as a :class:`Mesh` for :func:`write_mesh`).

Every failure raises :class:`UnfoldError` (a ``ValueError``) whose message is
the command line's.
"""

from ._native import UnfoldError, __version__
from ._mesh import Mesh, read_mesh, write_mesh
from ._result import MapResult
from ._placenta import PlacentaResult, placenta
from ._template import Side, Template, check_template
from ._tet_mesh import TetMeshResult, tet_mesh
from ._ventricle import VentricleResult, ventricle
from ._ventricle_inverse import InverseResult, ventricle_inverse
from ._mitral import MitralResult, mitral, mitral_seg
from ._deform import DeformResult, deform
from . import cohort, shapes

__all__ = [
    "DeformResult",
    "InverseResult",
    "MapResult",
    "Mesh",
    "MitralResult",
    "PlacentaResult",
    "Side",
    "Template",
    "TetMeshResult",
    "UnfoldError",
    "VentricleResult",
    "__version__",
    "check_template",
    "deform",
    "mitral",
    "mitral_seg",
    "placenta",
    "read_mesh",
    "shapes",
    "tet_mesh",
    "ventricle",
    "ventricle_inverse",
    "write_mesh",
]
