from typing import Any, Callable, Dict, Mapping, Optional, Sequence, Tuple, Union
import enum
import os
import numpy as np
from . import cohort as cohort
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

class MapResult:
    points: np.ndarray
    cells: Dict[str, np.ndarray]
    arrays: Dict[str, np.ndarray]
    point_data: Dict[str, np.ndarray]
    cell_data: Dict[str, np.ndarray]
    report: Dict[str, Any]
    @property
    def mesh(self) -> Mesh: ...

class PlacentaResult(MapResult):
    original: Mesh
    images: Dict[str, Tuple[np.ndarray, np.ndarray]]

class TetMeshResult(MapResult): ...

class VentricleResult(MapResult):
    anatomy: Mesh
    disk: Mesh
    transferred: Optional[Mesh]
    surface: Optional[Mesh]

class InverseResult(MapResult): ...

class MitralResult(MapResult):
    original: Mesh

class DeformResult(MapResult): ...

_Point = Union[Sequence[float], np.ndarray]
_Image = Union[Tuple[np.ndarray, np.ndarray], Any]
_Surface = Union[Mesh, Tuple[np.ndarray, np.ndarray]]

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
    images: Optional[Mapping[str, _Image]] = ...,
    template: Union[str, Template] = ...,
    lam: float = ...,
    *,
    margin_mm: Optional[float] = ...,
    gamma: float = ...,
    rings: int = ...,
    fix_h: Optional[float] = ...,
    voxel_mm: float = ...,
    solver: str = ...,
    energy: str = ...,
    tol: float = ...,
    max_iterations: Optional[int] = ...,
    name: str = ...,
    progress: Optional[Callable[[str, int, float], Any]] = ...,
    interp: str = ...,
    spacing_mm: Optional[float] = ...,
    frame_check: bool = ...,
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

def tet_mesh(
    mask: Any,
    affine: Optional[np.ndarray] = ...,
    *,
    size_mm: Optional[float] = ...,
    smooth_voxels: float = ...,
    dilate: int = ...,
    threshold: Optional[float] = ...,
    label: Optional[float] = ...,
    level: Optional[float] = ...,
    grade: bool = ...,
    keep_all_components: bool = ...,
    name: str = ...,
) -> TetMeshResult: ...
def ventricle(
    points: Optional[np.ndarray] = ...,
    triangles: Optional[np.ndarray] = ...,
    *,
    anterior: _Point,
    inferior: _Point,
    apex: Optional[_Point] = ...,
    rim_near: Optional[_Point] = ...,
    anatomy: Union[Mesh, np.ndarray, None] = ...,
    surface_voxel_mm: Optional[float] = ...,
    surface_margin_mm: Optional[float] = ...,
    surface_smoothing: Optional[int] = ...,
    chamber: str = ...,
    grid_mm: Optional[float] = ...,
    hemisphere_mm: Optional[float] = ...,
    display_exponent: Optional[float] = ...,
    snap_mm: Optional[float] = ...,
    to_surface: Optional[_Surface] = ...,
    to_anterior: Optional[_Point] = ...,
    to_inferior: Optional[_Point] = ...,
    to_apex: Optional[_Point] = ...,
    to_rim_near: Optional[_Point] = ...,
    to_hemisphere: Optional[float] = ...,
    anatomy_name: str = ...,
    surface_name: str = ...,
    to_name: str = ...,
) -> VentricleResult: ...
def ventricle_inverse(
    normalized: Union[Mesh, np.ndarray],
    points: np.ndarray,
    triangles: np.ndarray,
    *,
    anterior: _Point,
    inferior: _Point,
    apex: Optional[_Point] = ...,
    rim_near: Optional[_Point] = ...,
    coordinates: str = ...,
    layers: Optional[int] = ...,
    chamber: str = ...,
    grid_mm: Optional[float] = ...,
    hemisphere_mm: Optional[float] = ...,
    display_exponent: Optional[float] = ...,
    snap_mm: Optional[float] = ...,
    normalized_name: str = ...,
    surface_name: str = ...,
) -> InverseResult: ...
def mitral(
    anterior: _Surface,
    posterior: _Surface,
    annulus: Optional[np.ndarray] = ...,
    *,
    annulus_mode: str = ...,
    init: str = ...,
    relax: str = ...,
    energy: str = ...,
    iterations: int = ...,
    step_scale: Optional[float] = ...,
    coaptation_mm: float = ...,
    tolerance_mm: Optional[float] = ...,
    cut_posteromedial: bool = ...,
    name: str = ...,
) -> MitralResult: ...
def mitral_seg(
    labels: np.ndarray,
    affine: np.ndarray,
    *,
    anterior_label: int,
    posterior_label: int,
    annulus_label: Optional[int] = ...,
    annulus_mode: str = ...,
    init: str = ...,
    relax: str = ...,
    energy: str = ...,
    coaptation_mm: float = ...,
    tolerance_mm: Optional[float] = ...,
    cut_posteromedial: bool = ...,
    name: str = ...,
) -> MitralResult: ...
def deform(
    points: np.ndarray,
    cells: Union[np.ndarray, Mapping[str, np.ndarray]],
    vertices: Optional[np.ndarray] = ...,
    targets: Optional[np.ndarray] = ...,
    *,
    init: Optional[np.ndarray] = ...,
    fixed: Optional[np.ndarray] = ...,
    fixed_boundary: bool = ...,
    weight: float = ...,
    energy: str = ...,
    solver: str = ...,
    tol: float = ...,
    max_iterations: Optional[int] = ...,
    point_data: Optional[Mapping[str, np.ndarray]] = ...,
    cell_data: Optional[Mapping[str, np.ndarray]] = ...,
    name: str = ...,
    targets_name: str = ...,
    init_name: str = ...,
    fixed_name: str = ...,
) -> DeformResult: ...
