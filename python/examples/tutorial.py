"""unfold from Python: a short tutorial (run it: `python tutorial.py [OUT_DIR]`).

Each `# %%` block is a cell (VS Code, PyCharm and Jupyter's jupytext open the
file as a notebook). It needs only the package (`pip install ./python`) and
numpy; its outputs go to OUT_DIR (default `unfold-tutorial/`) and open in
ParaView, 3D Slicer or meshio.
"""

# %% 1. A placenta mesh.
# Your own tet mesh (VTU, VTK, gmsh, medit, ...) is `unfold.read_mesh(path)`;
# here, the synthetic slab of `unfold demo`, a Mesh of numpy arrays.
import pathlib
import sys

import numpy as np

import unfold

out = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "unfold-tutorial")
out.mkdir(parents=True, exist_ok=True)

slab = unfold.shapes.placenta_slab(8)
points, tets = slab.points, slab.cells["tetra"]
print(f"slab: {len(points)} points, {len(tets)} tets")

# %% 2. Flatten it onto the parallel planes (the command line's defaults).
# The GIL is released while Rust works; `progress` is called at each stage
# and at most every 0.1 s during the optimization.
def progress(stage, iteration, value):
    if np.isnan(value):  # a new stage
        print(f"  {stage}")

result = unfold.placenta(points, tets, template="planes", progress=progress)
r = result.report
print(f"{r['template']}: h = {r['theta']['h']:.4f} mm, template error {r['template_error_mm']:.4f} mm, "
      f"Dirichlet excess {r['dirichlet_excess_percent']:.2f} %, min det J {r['min_det_j']:.3f}")

# The flattened mesh, with the command line's arrays (side, log2_det_j,
# sym_dirichlet), written for ParaView:
unfold.write_mesh(out / "flattened.vtu", result.mesh)
print(f"arrays: {sorted(result.arrays)}")

# %% 3. Your own template, in Python.
# Two coaxial cylinders around the y axis (through z = -R) at radii R + h
# (fetal side) and R - h (maternal side): a curved shell instead of planes
# (the Python twin of `examples/cylinder_template.rs`).
#   rho = |(x1, x3 + R)|,  n = (x1, 0, x3 + R) / rho,  T = (rho - r)^2
#   dT/dx = 2 (rho - r) n,  dT/dh = -+ 2 (rho - r)
#   d2T/dx2 = 2 n n^T + 2 max(rho - r, 0) / rho (P - n n^T),  P = diag(1, 0, 1)
R = 150.0


class Cylinders(unfold.Template):
    name = "cylinders"
    parameter_names = ["h"]

    def initial_theta(self, estimates):
        return [estimates["half_thickness_mm"]]

    @staticmethod
    def parts(label, x, h):
        s = {unfold.Side.FETAL: 1.0, unfold.Side.MATERNAL: -1.0}.get(label, 0.0)
        rho = max(np.hypot(x[0], x[2] + R), 1e-12)
        n = np.array([x[0], 0.0, x[2] + R]) / rho * s * s
        return s * s * (rho - R - s * h), n, rho, s

    def value(self, label, x, theta):
        return self.parts(label, x, theta[0])[0] ** 2

    def gradient(self, label, x, theta):
        d, n, _, _ = self.parts(label, x, theta[0])
        return 2.0 * d * n

    def hessian(self, label, x, theta):
        d, n, rho, _ = self.parts(label, x, theta[0])
        nn = np.outer(n, n)
        return 2.0 * nn + 2.0 * max(d, 0.0) / rho * (np.diag([1.0, 0.0, 1.0]) - nn)

    def theta_gradient(self, label, x, theta):
        d, _, _, s = self.parts(label, x, theta[0])
        return [-2.0 * s * d]


# Check the derivatives before a long run (raises UnfoldError naming the
# first entry that disagrees with finite differences):
cylinders = Cylinders()
for label in (unfold.Side.FETAL, unfold.Side.MATERNAL, unfold.Side.MARGIN):
    unfold.check_template(cylinders, label, [10.0, -3.0, 8.0], [9.0])

curved = unfold.placenta(points, tets, template=cylinders)
rc = curved.report
print(f"{rc['template']}: h = {rc['theta']['h']:.4f} mm, template error "
      f"{rc['template_error_mm']:.4f} mm, inverted tets {rc['inverted_tets']}")
unfold.write_mesh(out / "cylinders.vtu", curved.mesh)

# %% 4. The heart and the valve: the same pattern.
# A ventricle's enclosing surface with its landmarks: everything inside
# (here the cup's own anatomy mesh) is carried into the cylinder, with the
# AHA segment of every point.
cup = unfold.shapes.ventricle_cup()
heart = unfold.ventricle(cup.surface.points, cup.surface.cells["triangle"],
                         anterior=cup.anterior, inferior=cup.inferior, apex=cup.apex,
                         anatomy=cup.anatomy, grid_mm=2.0)
segments = np.unique(heart.arrays["aha"])
print(f"ventricle: {len(heart.points)} points in the cylinder, AHA segments {segments.tolist()}")
unfold.write_mesh(out / "ventricle.vtu", heart.mesh)

# A mitral valve: two leaflets and the annulus ring, laid out flat.
valve = unfold.shapes.mitral_valve()
flat = unfold.mitral(valve.anterior, valve.posterior, valve.annulus)
print(f"mitral: {len(flat.points)} points, arrays {sorted(flat.arrays)}")
unfold.write_mesh(out / "valve2d.vtu", flat.mesh)

# %% 5. Errors are Python exceptions with the command line's messages.
try:
    unfold.placenta(points, tets, lam=-1.0)
except unfold.UnfoldError as e:
    print(f"UnfoldError: {e}")

print(f"wrote flattened.vtu, cylinders.vtu, ventricle.vtu and valve2d.vtu in {out}")
