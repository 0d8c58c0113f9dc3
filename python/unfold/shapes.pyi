from typing import Optional
from . import Mesh

def placenta_slab(cells_radial: Optional[int] = ...) -> Mesh: ...
