"""A placenta template written in Python, run by the Rust pipeline."""

import numpy as np
import pytest

import unfold
from unfold import Side


class PythonPlanes(unfold.Template):
    """The parallel planes z = +-h in Python: T = (x3 - s h)^2 on the fetal
    (s = 1) and maternal (s = -1) sides, 0 elsewhere (the Rust planes' formula)."""

    name = "python-planes"
    parameter_names = ["h"]
    symmetry = "in-plane"

    def __init__(self):
        self.calls = 0

    @staticmethod
    def sign(label):
        return {Side.FETAL: 1.0, Side.MATERNAL: -1.0}.get(label, 0.0)

    def initial_theta(self, estimates):
        return [estimates["half_thickness_mm"]]

    def value(self, label, x, theta):
        self.calls += 1
        s = self.sign(label)
        return (x[2] - s * theta[0]) ** 2 if s else 0.0

    def gradient(self, label, x, theta):
        s = self.sign(label)
        return [0.0, 0.0, 2.0 * (x[2] - s * theta[0]) if s else 0.0]

    def hessian(self, label, x, theta):
        h = np.zeros((3, 3))
        h[2, 2] = 2.0 if self.sign(label) else 0.0
        return h

    def theta_gradient(self, label, x, theta):
        s = self.sign(label)
        return [-2.0 * s * (x[2] - s * theta[0])]


class PythonPlanesWithUpdate(PythonPlanes):
    """With the closed-form h = (sum_F w x3 - sum_M w x3) / (sum_F w + sum_M w)."""

    def update_theta(self, labels, xs, weights, theta):
        f, m = labels == Side.FETAL, labels == Side.MATERNAL
        den = weights[f].sum() + weights[m].sum()
        if den == 0:
            return None
        return [(weights[f] @ xs[f, 2] - weights[m] @ xs[m, 2]) / den]


@pytest.fixture(scope="module")
def slab():
    return unfold.shapes.placenta_slab(6)


@pytest.fixture(scope="module")
def both(slab):
    template = PythonPlanes()
    py = unfold.placenta(slab.points, slab.cells["tetra"], template=template)
    rust = unfold.placenta(slab.points, slab.cells["tetra"])
    return py, rust, template


def test_python_planes_reach_the_rust_planes_optimum(both):
    py, rust, template = both
    assert template.calls > 0
    assert py.report["template"] == "python-planes"
    assert py.report["theta_initial"] == rust.report["theta_initial"]
    h_py, h_rust = py.report["theta"]["h"], rust.report["theta"]["h"]
    assert h_py != py.report["theta_initial"]["h"]
    assert abs(h_py - h_rust) <= 1e-9 * abs(h_rust)
    # The same objective minimized to the same gradient tolerance from the
    # same start: the maps agree to round-off over the slab's size.
    size = np.ptp(rust.points, axis=0).max()
    assert np.abs(py.points - rust.points).max() <= 1e-9 * size
    assert py.report["min_det_j"] > 0 and py.report["inverted_tets"] == 0


def test_gradient_descent_moves_h_through_update_theta(slab):
    kw = dict(solver="gd", max_iterations=30)
    fixed = unfold.placenta(slab.points, slab.cells["tetra"], template=PythonPlanes(), **kw)
    assert fixed.report["theta"] == fixed.report["theta_initial"]
    py = unfold.placenta(slab.points, slab.cells["tetra"], template=PythonPlanesWithUpdate(), **kw)
    rust = unfold.placenta(slab.points, slab.cells["tetra"], **kw)
    h_py, h_rust = py.report["theta"]["h"], rust.report["theta"]["h"]
    assert h_py != py.report["theta_initial"]["h"]
    assert abs(h_py - h_rust) <= 1e-9 * abs(h_rust)


def test_check_template_accepts_exact_derivatives():
    t = PythonPlanes()
    for label in Side:
        unfold.check_template(t, label, [1.0, -2.0, 3.5], [4.0])


def test_check_template_names_a_wrong_gradient():
    class Wrong(PythonPlanes):
        def gradient(self, label, x, theta):
            g = np.asarray(super().gradient(label, x, theta))
            return 2.0 * g

    with pytest.raises(unfold.UnfoldError, match=r"dT/dx\[2\]: analytic"):
        unfold.check_template(Wrong(), Side.FETAL, [1.0, -2.0, 3.5], [4.0])


def test_an_exception_in_a_template_method_is_raised(slab):
    class Raises(PythonPlanes):
        def hessian(self, label, x, theta):
            raise ZeroDivisionError("from the template")

    with pytest.raises(ZeroDivisionError, match="from the template"):
        unfold.placenta(slab.points, slab.cells["tetra"], template=Raises())


def test_a_wrong_shape_is_a_clear_error(slab):
    class Short(PythonPlanes):
        def gradient(self, label, x, theta):
            return [0.0, 0.0]

    with pytest.raises(unfold.UnfoldError, match=r"python-planes\.gradient returned 2 numbers"):
        unfold.placenta(slab.points, slab.cells["tetra"], template=Short())


def test_an_object_without_the_methods_is_refused(slab):
    with pytest.raises(unfold.UnfoldError, match="has no method initial_theta"):
        unfold.placenta(slab.points, slab.cells["tetra"], template=object())
