"""``python -m unfold ARGS``: the ``unfold`` command line.

The same program as the ``unfold`` binary (``unfold::program``): the same
subcommands, outputs, one-line errors and exit codes (0 done, 1 failed, 2 a
usage error, 3 outputs written but the solver did not converge). It is how
:func:`unfold.dask.run_cohort` runs a subject on a worker without the binary
installed there.
"""

import sys

from . import _native


def main() -> int:
    """Runs the command line ``sys.argv[1:]``.

    Returns:
        The exit code.
    """
    return _native.main(["unfold", *sys.argv[1:]])


if __name__ == "__main__":
    sys.exit(main())
