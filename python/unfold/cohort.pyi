import os
from typing import Any, Dict, List, Optional, Sequence, Union

def compare(
    study: Union[str, os.PathLike],
    column: str,
    covariates: Optional[Union[str, Sequence[str]]] = ...,
    permutations: int = ...,
    seed: int = ...,
) -> Dict[str, Any]: ...
