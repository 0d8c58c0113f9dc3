"""unfold: map anatomical shapes onto canonical templates, numpy in, numpy out.

The functions run the same Rust library as the ``unfold`` command line, with
its defaults and its one-line error messages:

* :func:`read_mesh` / :func:`write_mesh`: every mesh format of ``unfold
  convert`` (VTK XML and legacy, PLY, OBJ, STL, gmsh, medit) as a
  :class:`Mesh` of numpy arrays (meshio's layout);
* :func:`placenta`: ``unfold placenta`` on a tet mesh, returning a
  :class:`PlacentaResult`;
* :class:`Template`: a placenta template written in Python (value,
  gradient, Hessian and parameter gradient as numpy), checked by
  :func:`check_template`;
* :mod:`unfold.shapes`: the synthetic shapes of ``unfold demo``.
* :mod:`unfold.dask`: ``unfold batch`` + ``unfold cohort`` on a Dask cluster
  (imported on its own: ``import unfold.dask``; needs the ``dask`` extra);
* ``python -m unfold ARGS``: the ``unfold`` command line itself.

Every failure raises :class:`UnfoldError` (a ``ValueError``) whose message is
the command line's.
"""

from ._native import UnfoldError, __version__
from ._mesh import Mesh, read_mesh, write_mesh
from ._placenta import PlacentaResult, placenta
from ._template import Side, Template, check_template
from . import shapes

__all__ = [
    "Mesh",
    "PlacentaResult",
    "Side",
    "Template",
    "UnfoldError",
    "__version__",
    "check_template",
    "placenta",
    "read_mesh",
    "shapes",
    "write_mesh",
]
