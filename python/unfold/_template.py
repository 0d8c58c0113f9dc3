"""Placenta templates written in Python: :class:`Template` and :func:`check_template`."""

from __future__ import annotations

import enum
from typing import Any, Dict, Optional, Sequence

import numpy as np

from . import _native

__all__ = ["Side", "Template", "check_template"]


class Side(enum.IntEnum):
    """The side labels the placenta pipeline hands a template (the ``side`` array)."""

    INTERIOR = 0
    FETAL = 1
    MATERNAL = 2
    MARGIN = 3


class Template:
    """A placenta template ``T(x, theta)`` in Python, for :func:`unfold.placenta`.

    The pipeline minimizes ``sum_m A_m T(label_m, x_m, theta) + lam sum_k V_k
    D(J_k)`` over the mapped positions ``x_m`` and the parameters ``theta``;
    ``A_m`` are the boundary vertices' normalized areas and ``label_m`` their
    :class:`Side`. Subclass this (or write any object with the same
    attributes and methods) and pass an instance as ``template=``; the Rust
    solver calls the methods for every boundary vertex with the GIL held, so
    it is slower than a Rust template but needs no Rust. The ``theta``
    Hessians are finite differences of :meth:`theta_gradient`.

    Attributes:
        name: what the report calls the template.
        parameter_names: the names of ``theta``'s entries, in order.
        symmetry: the rigid motions that leave the template term unchanged,
            which fix the flattened mesh's canonical frame: ``"none"`` (the
            frame is left as the optimization ends), ``"half-turn-about-z"``
            or ``"in-plane"`` (translations in x, y and rotations about z, as
            the parallel planes).

    Every method gets ``label`` (an ``int``, a :class:`Side`), ``x`` (float64,
    3 coordinates) and ``theta`` (float64, one per parameter name). A method
    that raises stops the run: :func:`unfold.placenta` raises that exception.
    Check your derivatives with :func:`check_template` first.
    """

    name: str = "python"
    parameter_names: Sequence[str] = ()
    symmetry: str = "none"

    def initial_theta(self, estimates: Dict[str, float]) -> Sequence[float]:
        """The starting ``theta`` from the mesh's estimates.

        Args:
            estimates: ``half_thickness_mm`` (the initial ``h`` of the planes),
                ``rx_mm``, ``ry_mm`` (half widths) and ``volume_mm3``.

        Returns:
            one number per parameter name (default: zeros).
        """
        return np.zeros(len(self.parameter_names))

    def value(self, label: int, x: np.ndarray, theta: np.ndarray) -> float:
        """``T(label, x, theta)``."""
        raise NotImplementedError

    def gradient(self, label: int, x: np.ndarray, theta: np.ndarray) -> Any:
        """``dT/dx``: as many numbers as ``x``."""
        raise NotImplementedError

    def hessian(self, label: int, x: np.ndarray, theta: np.ndarray) -> Any:
        """``d2T/dx2``, positive semidefinite (project it if the exact one is not): d x d."""
        raise NotImplementedError

    def theta_gradient(self, label: int, x: np.ndarray, theta: np.ndarray) -> Any:
        """``dT/dtheta``: one number per parameter."""
        raise NotImplementedError

    def update_theta(
        self, labels: np.ndarray, xs: np.ndarray, weights: np.ndarray, theta: np.ndarray
    ) -> Optional[Sequence[float]]:
        """The best ``theta`` for fixed positions, or None (the default) for none.

        Newton's method optimizes ``theta`` with the positions either way;
        gradient descent (``solver="gd"``, the paper's Algorithm 1) changes
        ``theta`` only through this update, so without one ``theta`` stays at
        :meth:`initial_theta`.

        Args:
            labels: uint8 (n,), every vertex's side.
            xs: float64 (n, d), the mapped positions.
            weights: float64 (n,), ``A_m`` (zero for vertices without a term).
            theta: the current parameters.
        """
        return None


def check_template(template: Any, label: int, x, theta, rel: float = 1e-6) -> None:
    """Checks a template's derivatives at one point against finite differences.

    Central differences with step ``1e-5 max(|v|, 1)``, each entry compared to
    ``rel max(1, max |entries|)``: ``dT/dx`` and ``dT/dtheta`` against
    differences of ``value``; the Hessian symmetric, positive semidefinite
    and equal to the differences of ``gradient`` wherever those are PSD.

    Args:
        template: a :class:`Template` (or an object like one).
        label: the side label to check at.
        x: a point (1 to 3 coordinates).
        theta: the parameters (one per parameter name).
        rel: the relative tolerance.

    Raises:
        UnfoldError: naming the first derivative entry that disagrees, e.g.
            ``template planes at label 1, x [...], theta [...]: dT/dx[2]:
            analytic 4, finite difference 2``; or an exception a method raised.
    """
    _native.check_template(
        template,
        int(label),
        np.ascontiguousarray(np.asarray(x, dtype=np.float64).ravel()),
        np.ascontiguousarray(np.asarray(theta, dtype=np.float64).ravel()),
        float(rel),
    )
