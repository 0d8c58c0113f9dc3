from typing import Any, Callable, Dict, Mapping, Optional, Sequence, Union
import enum
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
    template: Union[str, Template] = ...,
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

class Side(enum.IntEnum):
    INTERIOR = 0
    FETAL = 1
    MATERNAL = 2
    MARGIN = 3

class Template:
    name: str
    parameter_names: Sequence[str]
    symmetry: str
    def initial_theta(self, estimates: Dict[str, float]) -> Sequence[float]: ...
    def value(self, label: int, x: np.ndarray, theta: np.ndarray) -> float: ...
    def gradient(self, label: int, x: np.ndarray, theta: np.ndarray) -> Any: ...
    def hessian(self, label: int, x: np.ndarray, theta: np.ndarray) -> Any: ...
    def theta_gradient(self, label: int, x: np.ndarray, theta: np.ndarray) -> Any: ...
    def update_theta(
        self, labels: np.ndarray, xs: np.ndarray, weights: np.ndarray, theta: np.ndarray
    ) -> Optional[Sequence[float]]: ...

def check_template(
    template: Any, label: int, x: Any, theta: Any, rel: float = ...
) -> None: ...
