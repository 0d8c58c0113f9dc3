"""The synthetic shapes of ``unfold demo`` (``unfold_mesh::shapes``)."""

from __future__ import annotations

from typing import Optional

from . import _native
from ._mesh import Mesh

__all__ = ["placenta_slab"]


def placenta_slab(cells_radial: Optional[int] = None) -> Mesh:
    """The demo's placenta-like tet slab in its own frame (point array ``side``).

    Args:
        cells_radial: the resolution (cells across the radius); None for the
            library's default.
    """
    return Mesh._from_tuple(_native.placenta_slab(cells_radial))
