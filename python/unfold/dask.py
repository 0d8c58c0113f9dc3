"""``unfold batch`` + ``unfold cohort`` on a ``dask.distributed`` cluster.

:func:`run_cohort` runs the subjects of a batch manifest (the CSV ``unfold
batch`` reads) as tasks on a ``distributed.Client`` and writes into
``out_dir`` what ``unfold batch MANIFEST -o OUT_DIR`` followed by ``unfold
cohort OUT_DIR`` write: ``<id>/`` per subject, ``logs/<id>.log``,
``failures.csv``, ``subjects.csv``, ``cohort.csv``, ``cohort/`` and
``index.html``.

Each task runs its subject as its own process (``python -m unfold``, the
command line's program) in a temporary directory on the worker and returns
the files it wrote; the client puts them in place. Workers therefore need
no shared file system with the client for the outputs, but they must be
able to read the inputs the manifest names, at the same absolute paths.

dask is an optional dependency (``pip install 'unfold-organs[dask]'``); it
is imported only when :func:`run_cohort` runs.
"""

from __future__ import annotations

import os
import pathlib
import sys
import tempfile
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional, Union

from . import _native

__all__ = ["CohortSummary", "run_cohort"]


@dataclass
class CohortSummary:
    """What :func:`run_cohort` returns: the subjects by how they ended.

    Attributes:
        out_dir: the output directory.
        ran: ids run to the end, in the manifest's order.
        not_converged: ids whose solver stopped early (outputs written; the
            cohort table's ``converged`` column says so).
        skipped: ids whose outputs were done before with the same run hash.
        failed: id -> its one-line error (as in ``failures.csv``).
    """

    out_dir: pathlib.Path
    ran: List[str] = field(default_factory=list)
    not_converged: List[str] = field(default_factory=list)
    skipped: List[str] = field(default_factory=list)
    failed: Dict[str, str] = field(default_factory=dict)


def _worker_memory() -> Optional[int]:
    """The memory one task of this dask worker may use: its limit over its threads."""
    try:
        from distributed import get_worker

        w = get_worker()
        limit = w.memory_manager.memory_limit
        return int(limit // max(w.state.nthreads, 1)) if limit else None
    except Exception:  # not in a worker, or a distributed without these attributes
        return None


def _run_subject(
    id: str,
    organ: str,
    args: List[str],
    recorded: Optional[str],
    max_memory: Optional[int],
) -> Dict[str, Any]:
    """One subject, on a worker (a dask task): skipped if ``recorded`` is its
    run hash, else run as ``python -m unfold ARGS -o TMP/<id>``.

    Returns:
        ``id``, ``status``, ``exit_code``, ``message``, ``seconds``, ``files``
        (relative path -> bytes of what the run wrote) and ``log`` (its stdout
        and stderr; None for a skip).
    """
    ended: Dict[str, Any] = {"id": id, "exit_code": None, "message": "", "seconds": 0.0,
                             "files": {}, "log": None}
    if recorded is not None and _native.run_hash(args) == recorded:
        ended["status"] = "skipped"
        return ended
    if max_memory is None:
        max_memory = _worker_memory()
    with tempfile.TemporaryDirectory(prefix="unfold-dask-") as tmp:
        out = pathlib.Path(tmp) / id
        log = pathlib.Path(tmp) / "run.log"
        status, code, message, seconds = _native.run_subject(
            id, organ, args, str(out), str(log), [sys.executable, "-m", "unfold"], max_memory
        )
        files = {}
        if status in ("done", "not converged") and out.is_dir():
            for p in sorted(out.rglob("*")):
                rel = p.relative_to(out).as_posix()
                if p.is_file() and rel != ".unfold-run.json":
                    files[rel] = p.read_bytes()
        ended.update(status=status, exit_code=code, message=message, seconds=seconds,
                     files=files, log=log.read_bytes() if log.is_file() else b"")
    return ended


def run_cohort(
    manifest: Union[str, os.PathLike],
    client: Any,
    out_dir: Union[str, os.PathLike],
    *,
    max_memory: Optional[int] = None,
    jobs: Optional[int] = None,
    progress: Optional[Callable[[str, str, int, int], None]] = None,
) -> CohortSummary:
    """``unfold batch MANIFEST -o OUT_DIR`` + ``unfold cohort OUT_DIR`` on a dask cluster.

    The manifest is read and checked first (relative paths in it resolve
    against its directory, made absolute, so the workers get absolute
    paths). A subject whose ``out_dir/<id>/`` records the run hash of the
    same command line and input contents is skipped (decided on the worker,
    which reads the inputs). Every other subject is a task: it runs in a
    temporary directory on a worker and returns its files, which the client
    puts in place as ``out_dir/<id>/`` (the previous set replaced whole) with
    its log in ``out_dir/logs/<id>.log``. A failed subject (or a task the
    cluster lost) fails alone: its one-line error goes to ``failures.csv``.
    Then the cohort tables, statistics, figures and report of ``out_dir``.

    Args:
        manifest: the batch manifest (CSV; see ``unfold batch --help``).
        client: a ``distributed.Client``.
        out_dir: the output directory (created; on the client's machine).
        max_memory: the most memory, bytes, one subject may use (the
            command line's ``--max-memory``); None: the worker's memory limit
            over its threads, else what the worker's machine has available.
        jobs: the most subjects submitted at a time (None: all at once; the
            cluster's workers and threads set how many run).
        progress: called on the client as each subject ends, with ``(id,
            status, ended_so_far, total)``; ``status`` is ``done``, ``not
            converged``, ``skipped`` or ``failed``.

    Returns:
        A :class:`CohortSummary`. Failed subjects do not raise: see its
        ``failed``.

    Raises:
        UnfoldError: an unusable manifest (before anything runs), an
            ``out_dir`` that is a file, or writing the cohort tables.
        ImportError: dask.distributed is not installed.
        ValueError: ``jobs`` < 1 or ``max_memory`` < 1.
    """
    try:
        from distributed import as_completed
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError(
            "unfold.dask needs dask.distributed: pip install 'unfold-organs[dask]'"
        ) from e
    if jobs is not None and jobs < 1:
        raise ValueError(f"jobs must be at least 1, got {jobs}")
    if max_memory is not None and max_memory < 1:
        raise ValueError(f"max_memory must be at least 1 byte, got {max_memory}")
    manifest = os.path.abspath(os.fspath(manifest))
    out = pathlib.Path(os.path.abspath(os.fspath(out_dir)))
    plan = _native.plan(manifest)
    _native.prepare_output(str(out))
    subjects = plan.subjects()
    total = len(subjects)
    pending = list(reversed(subjects))
    ids: Dict[Any, str] = {}
    ended: List[Any] = []
    summary = CohortSummary(out_dir=out)
    by_status = {"done": summary.ran, "not converged": summary.not_converged,
                 "skipped": summary.skipped}

    def submit() -> Any:
        sid, organ, args = pending.pop()
        recorded = _native.recorded_hash(str(out / sid))
        fut = client.submit(_run_subject, sid, organ, args, recorded, max_memory, pure=False,
                            key=f"unfold-{sid}-{os.urandom(4).hex()}")
        ids[fut.key] = sid
        return fut

    window = total if jobs is None else min(jobs, total)
    running = as_completed([submit() for _ in range(window)])
    for fut in running:
        sid = ids[fut.key]
        try:
            r = fut.result()
        except Exception as e:  # the task could not run: the subject fails alone
            r = {"id": sid, "status": "failed", "exit_code": None, "seconds": 0.0,
                 "message": f"the task failed on the cluster: {type(e).__name__}: {e}",
                 "files": {}, "log": None}
        if r["files"] or r["log"] is not None:
            try:
                _native.place_subject(str(out), sid, list(r["files"].items()), r["log"])
            except _native.UnfoldError as e:  # out_dir/<id> holds somebody's files
                r = dict(r, status="failed", exit_code=None, message=str(e))
        ended.append((sid, r["status"], r["exit_code"], r["message"], r["seconds"]))
        if r["status"] == "failed":
            summary.failed[sid] = r["message"]
        else:
            by_status[r["status"]].append(sid)
        fut.release()
        if pending:
            running.add(submit())
        if progress is not None:
            progress(sid, r["status"], len(ended), total)
    order = {s[0]: i for i, s in enumerate(subjects)}
    for ids_ in (summary.ran, summary.not_converged, summary.skipped):
        ids_.sort(key=order.__getitem__)
    summary.failed = dict(sorted(summary.failed.items(), key=lambda kv: order[kv[0]]))
    _native.finish(plan, str(out), ended)
    return summary
