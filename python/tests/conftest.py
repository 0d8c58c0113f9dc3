"""Shared fixtures: the unfold command line to compare with."""

import os
import pathlib
import shutil

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def unfold_bin():
    """The CLI: $UNFOLD_BIN, else target/debug/unfold, else target/release/unfold, else PATH."""
    candidates = [os.environ.get("UNFOLD_BIN")]
    candidates += [str(ROOT / "target" / p / "unfold") for p in ("debug", "release")]
    candidates.append(shutil.which("unfold"))
    for c in candidates:
        if c and os.access(c, os.X_OK):
            return c
    pytest.fail("no unfold binary: build it (cargo build) or set UNFOLD_BIN")
