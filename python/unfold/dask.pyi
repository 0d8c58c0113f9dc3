import os
import pathlib
from typing import Any, Callable, Dict, List, Optional, Union

class CohortSummary:
    out_dir: pathlib.Path
    ran: List[str]
    not_converged: List[str]
    skipped: List[str]
    failed: Dict[str, str]
    def __init__(
        self,
        out_dir: pathlib.Path,
        ran: List[str] = ...,
        not_converged: List[str] = ...,
        skipped: List[str] = ...,
        failed: Dict[str, str] = ...,
    ) -> None: ...

def run_cohort(
    manifest: Union[str, os.PathLike],
    client: Any,
    out_dir: Union[str, os.PathLike],
    *,
    max_memory: Optional[int] = ...,
    jobs: Optional[int] = ...,
    progress: Optional[Callable[[str, str, int, int], None]] = ...,
) -> CohortSummary: ...
