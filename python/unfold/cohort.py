"""Group comparisons of a cohort in template space.

``compare(study, column, ...)`` runs ``unfold cohort STUDY --compare COLUMN
...`` on the output directory of a batch (``unfold batch`` or
``unfold.dask.run_cohort``) and returns its results as Python objects: the
placenta maps as numpy arrays on the images' common grid, the ventricle and
mitral tables as lists of dicts, and ``compare.json``.
"""

import csv
import io
import json
import os

from . import _native

__all__ = ["compare"]


def _cell(text):
    """A table cell: a float when it is a number, None when empty, else the text."""
    if text == "":
        return None
    try:
        return float(text)
    except ValueError:
        return text


def _rows(text):
    return [{k: _cell(v) for k, v in row.items()} for row in csv.DictReader(io.StringIO(text))]


def compare(study, column, covariates=None, permutations=1000, seed=0):
    """Compares the groups of ``column`` (or tests its continuous effect).

    Args:
        study: a batch's output directory (with ``subjects.csv``).
        column: a column of ``subjects.csv``: categorical when one of its
            values is not a number (groups), else continuous.
        covariates: numeric columns as nuisance covariates (a list, or one
            comma-separated string).
        permutations: relabelings, the identity included (all the distinct
            ones when they are fewer).
        seed: seed of the random relabelings; the same seed gives the same
            results.

    Returns:
        A dict: ``images`` (per placenta image name: ``"t"`` or ``"F"``,
        ``"p"``, ``"pfwe"`` as float32 arrays of the common grid's shape,
        NaN / 1 where untested, and ``"affine"``, 4x4), ``ventricle``,
        ``mitral`` (the valves' measurements) and ``mitral_segments`` (the
        maps' Carpentier-segment means) (the tables' rows as dicts, numbers
        as floats, empty cells None; empty lists without those organs) and ``compare``
        (``compare.json``: the column, its kind, covariates, permutations,
        seed, subjects left out, and per analysis its design and counts).

    Raises:
        unfold.UnfoldError: the command line's one-line message (an unknown
        column, one group, a non-numeric covariate, too few subjects, ...).
    """
    if covariates is None:
        covariates = []
    elif isinstance(covariates, str):
        covariates = [c for c in covariates.split(",") if c]
    else:
        covariates = [str(c) for c in covariates]
    if isinstance(permutations, bool) or int(permutations) != permutations or permutations < 1:
        raise _native.UnfoldError(f"permutations must be a whole number >= 1, got {permutations!r}")
    if isinstance(seed, bool) or int(seed) != seed or seed < 0:
        raise _native.UnfoldError(f"seed must be a whole number >= 0, got {seed!r}")
    text, maps, tables = _native.compare(
        os.fspath(study), str(column), covariates, int(permutations), int(seed)
    )
    summary = json.loads(text)
    images = {}
    for a in summary["analyses"]:
        if a["organ"] != "placenta":
            continue
        stat_file, pfwe_file, p_file = a["files"]
        statistic = "t" if a["statistic"] == "t" else "F"
        data, affine = maps[stat_file]
        images[a["name"]] = {
            statistic: data,
            "p": maps[p_file][0],
            "pfwe": maps[pfwe_file][0],
            "affine": affine,
        }
    result = {
        "images": images,
        "ventricle": [],
        "mitral": [],
        "mitral_segments": [],
        "compare": summary,
    }
    for name, text in tables.items():
        key = "mitral_segments" if name.startswith("mitral_segments_") else name.split("_", 1)[0]
        if key in result and key not in ("images", "compare"):
            result[key] = _rows(text)
    return result
