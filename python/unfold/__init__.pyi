from typing import Any, Callable, Dict, Mapping, Optional, Union
import os
import numpy as np
from . import shapes as shapes

__version__: str

class UnfoldError(ValueError): ...

class Mesh:
    points: np.ndarray
    cells: Dict[str, np.ndarray]
    point_data: Dict[str, np.ndarray]
    cell_data: Dict[str, np.ndarray]
    def __init__(
        self,
        points: np.ndarray,
        cells: Dict[str, np.ndarray],
        point_data: Dict[str, np.ndarray] = ...,
        cell_data: Dict[str, np.ndarray] = ...,
    ) -> None: ...

class PlacentaResult:
    points: np.ndarray
    cells: Dict[str, np.ndarray]
    arrays: Dict[str, np.ndarray]
    point_data: Dict[str, np.ndarray]
    cell_data: Dict[str, np.ndarray]
    original: Mesh
    report: Dict[str, Any]
    @property
    def mesh(self) -> Mesh: ...

def read_mesh(path: Union[str, os.PathLike[str]]) -> Mesh: ...
def write_mesh(
    path: Union[str, os.PathLike[str]],
    mesh_or_points: Union[Mesh, np.ndarray],
    cells: Optional[Mapping[str, np.ndarray]] = ...,
    point_data: Optional[Mapping[str, np.ndarray]] = ...,
    cell_data: Optional[Mapping[str, np.ndarray]] = ...,
    *,
    arrays: Optional[Mapping[str, np.ndarray]] = ...,
    ascii: bool = ...,
) -> None: ...
def placenta(
    points: np.ndarray,
    tets: np.ndarray,
    images: None = ...,
    template: str = ...,
    lam: float = ...,
    *,
    margin_mm: float = ...,
    voxel_mm: float = ...,
    solver: str = ...,
    tol: float = ...,
    max_iterations: Optional[int] = ...,
    name: str = ...,
    progress: Optional[Callable[[str, int, float], Any]] = ...,
) -> PlacentaResult: ...
