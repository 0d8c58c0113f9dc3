from typing import Optional, Sequence, Tuple
import numpy as np
from . import Mesh

class VentricleCup:
    surface: Mesh
    anatomy: Mesh
    anatomy_points: np.ndarray
    anterior: np.ndarray
    inferior: np.ndarray
    apex: np.ndarray

class MitralValve:
    anterior: Mesh
    posterior: Mesh
    annulus: np.ndarray

def placenta_slab(cells_radial: Optional[int] = ...) -> Mesh: ...
def ventricle_cup(rings: Optional[int] = ...) -> VentricleCup: ...
def mitral_valve() -> MitralValve: ...
def ellipsoid_mask(
    radii_mm: Sequence[float] = ...,
    spacing_mm: float = ...,
    margin_voxels: int = ...,
) -> Tuple[np.ndarray, np.ndarray]: ...
