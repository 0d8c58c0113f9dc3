//! The objective `phi(X, theta) = sum_m w_m T(x_m, theta) + lambda sum_k V_k
//! D(J_k)` over a [`ParamMesh`], with fixed vertices; value, gradient and
//! PSD-projected Hessian assembled in parallel into a fixed sparsity pattern
//! (ALGORITHMS 1.1, 1.2, 2.1).

use crate::energy::{
    Eigen2, Eigen3, HessianMode, density2, density3, eval2, eval3, hessian2_eigen, hessian3_eigen,
};
use crate::{DistortionEnergy, ParamError, ParamMesh, RestElements, Template};
use nalgebra::{Matrix2, Matrix3, SMatrix, SVector};
use rayon::prelude::*;
use std::sync::Arc;
use unfold_linalg::sparse::{MultigridSettings, SpdPattern, VertexSolver};

/// The template part of the objective: `sum_m weights[m] T(m, labels[m],
/// x_m, theta)`; vertices with weight 0 carry no term.
#[derive(Debug, Clone, Copy)]
pub struct TemplateTerm<'a> {
    /// The template.
    pub template: &'a dyn Template,
    /// Per-vertex labels (template-specific meaning).
    pub labels: &'a [u8],
    /// Per-vertex weights (e.g. normalized boundary vertex areas).
    pub weights: &'a [f64],
}

/// The template parameters' part of the joint Newton system
/// `[A B; B^T C] [dx; dtheta] = -[g_x; g_theta]` (ALGORITHMS 1.5: theta
/// optimized jointly with X). `A` is the sparse Hessian in x.
#[derive(Debug, Clone, PartialEq)]
pub struct ThetaBlock {
    /// Number of parameters `p`.
    pub p: usize,
    /// `B = d2phi/(dx dtheta)`, dense, column-major (`p` columns of
    /// `len()`), zero on fixed vertices.
    pub b: Vec<f64>,
    /// `C = d2phi/dtheta2`, row-major `p x p`.
    pub c: Vec<f64>,
    /// `g_theta = dphi/dtheta`.
    pub g: Vec<f64>,
}

/// The smallest `det J` an accepted step may leave an element with
/// ([`Objective::max_step`]): `det(Ds) >= MIN_DET_J det(Dm)`. Relative
/// rounding errors of a determinant are about `1e-16` times its terms, so
/// with this margin the sign of every accepted element is certain; a
/// barrier energy never comes near it, a non-barrier one (ARAP) is kept
/// from stepping ever closer to flat.
pub const MIN_DET_J: f64 = 1e-8;

/// Slot marking "not stored" in the element slot maps.
const NONE: u32 = u32::MAX;

/// Stored entries of a triangle's symmetric 6x6 local Hessian (`r <= c`).
const TRI_SLOTS: usize = 21;

/// The vertex pairs `(a, b)`, `a <= b`, of a tet's corners: the 3x3 blocks
/// of its 12x12 local Hessian that are stored.
const TET_PAIRS: [(usize, usize); 10] = [
    (0, 0),
    (0, 1),
    (0, 2),
    (0, 3),
    (1, 1),
    (1, 2),
    (1, 3),
    (2, 2),
    (2, 3),
    (3, 3),
];

/// Tets whose local Hessians are computed together before they are
/// scattered.
const TET_CHUNK: usize = 8192;

/// From this many vertices on, a tet mesh's Newton systems are solved by
/// multigrid ([`LinearSolver::Auto`]); below, by Cholesky (on the placenta
/// meshes the two take about the same time at 10,000 to 13,000 vertices,
/// and the multigrid less and less from there).
pub const MULTIGRID_MIN_VERTICES: usize = 20_000;

/// Vertices per cell of the multigrid's background grid (its spacing is
/// `(MULTIGRID_VERTICES_PER_CELL V / n)^(1/3)` for a mesh of volume `V` and
/// `n` vertices).
pub const MULTIGRID_VERTICES_PER_CELL: f64 = 24.0;

/// How the Newton systems `H d = -g` of a tet mesh are solved.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LinearSolver {
    /// Cholesky below [`MULTIGRID_MIN_VERTICES`] vertices, multigrid from
    /// there.
    #[default]
    Auto,
    /// Sparse Cholesky, the vertices ordered by nested dissection: exact
    /// solves, memory and time growing faster than the mesh.
    Cholesky,
    /// Conjugate gradients preconditioned by multigrid on a background grid
    /// over the rest positions: memory linear in the mesh, solves to a
    /// relative residual of [`unfold_linalg::sparse::MULTIGRID_REL_TOL`].
    Multigrid,
}

/// The objective of a parameterization problem. The first Hessian builds
/// the sparsity pattern (with its symbolic Cholesky analysis, or the
/// multigrid's plan for a large tet mesh: [`Objective::linear_solver`]) and
/// the element -> value-slot maps, so every Newton iteration only evaluates
/// and scatters.
#[derive(Debug)]
pub struct Objective<'a> {
    mesh: &'a ParamMesh,
    energy: &'a dyn DistortionEnergy,
    lambda: f64,
    template: Option<TemplateTerm<'a>>,
    fixed: Vec<bool>,
    /// The Hessian's pattern and element slots (built on first use, or
    /// shared through [`Objective::with_layout`]).
    layout: Option<Arc<HessianLayout>>,
    /// Per-triangle local Hessians of the last assembly (reused storage).
    local2: Vec<[f64; TRI_SLOTS]>,
    /// A chunk of per-tet local Hessians (reused storage: up to
    /// [`TET_CHUNK`] x 1.15 KB, allocated and zeroed once per objective
    /// instead of once per Hessian).
    local3: Vec<[f64; 144]>,
    /// How Newton's systems are solved (tets).
    linear_solver: LinearSolver,
    /// Per template vertex (weight > 0), `dim^2` slots.
    vertex_slots: Vec<(u32, Vec<u32>)>,
    /// Per element, the smallest `det(Ds)` a step may leave:
    /// `MIN_DET_J det(Dm)`.
    floors: Vec<f64>,
}

/// The Hessian's assembly plan: the analysed sparsity pattern
/// ([`SpdPattern`]: ordering and symbolic factorization) and every
/// element's value slots. It depends only on the element connectivity and
/// the fixed vertices, not on positions, rest shapes or the energy, so
/// objectives over meshes with the same connectivity (the steps of a time
/// series) can share one: [`Objective::layout`] hands it out,
/// [`Objective::with_layout`] takes it.
#[derive(Debug)]
pub struct HessianLayout {
    pattern: SpdPattern,
    /// Per tet, the vertex-graph entry of each of its 10 vertex pairs
    /// ([`TET_PAIRS`]; `NONE` when a vertex is fixed); per triangle, 21
    /// value slots (the local pairs `r <= c` in row-major order, each
    /// stored once).
    element_slots: Vec<u32>,
    /// What it was built for: mapped dimension, element corners, fixed flags.
    dim: usize,
    elements: Vec<u32>,
    fixed: Vec<bool>,
    /// For a tet mesh solved by Cholesky, each graph entry's contributions
    /// in tet order, so the assembly sums them in parallel
    /// ([`TetGather`]); `None` otherwise (serial scatter).
    gather: Option<TetGather>,
}

/// The tet Hessian's assembly turned around: per vertex-graph entry (a
/// 3x3 block of the Hessian), the tets and corner pairs ([`TET_PAIRS`])
/// that add into it, in increasing tet order (compressed rows: entry `e`'s
/// items are `items[ptr[e]..ptr[e + 1]]`, each `10 k + pair`). Each
/// block's sum is then one task, `S_e = (((0 + H_k1) + H_k2) + ...)` over
/// its tets `k1 < k2 < ...`: the additions a serial scatter in tet order
/// makes, in the same order, so the values are bit for bit the serial
/// ones whatever the number of threads. Costs 4 bytes per (tet, pair) and
/// 9 sums per entry; built with a Cholesky layout only, where the factor
/// dwarfs it (a multigrid layout, for meshes too large for a factor, keeps
/// the serial scatter and its bounded memory).
#[derive(Debug)]
struct TetGather {
    ptr: Vec<usize>,
    items: Vec<u32>,
    /// Whether entry `e` is a diagonal block (only its `i <= j` entries
    /// are summed and stored).
    diagonal: Vec<bool>,
}

impl TetGather {
    /// The gather of `entries` (per tet, the graph entry of each of its
    /// [`TET_PAIRS`], `NONE` when not stored) over a graph of `n_entries`
    /// entries; `None` when the items would not fit `u32`.
    fn new(entries: &[u32], n_entries: usize) -> Option<TetGather> {
        let pairs = TET_PAIRS.len();
        if entries.len() >= u32::MAX as usize {
            return None;
        }
        let mut ptr = vec![0usize; n_entries + 1];
        for &e in entries.iter().filter(|&&e| e != NONE) {
            ptr[e as usize + 1] += 1;
        }
        for e in 0..n_entries {
            ptr[e + 1] += ptr[e];
        }
        let mut next = ptr.clone();
        let mut items = vec![0u32; ptr[n_entries]];
        let mut diagonal = vec![false; n_entries];
        // Items in increasing index = tet order.
        for (item, &e) in entries.iter().enumerate() {
            if e != NONE {
                let e = e as usize;
                items[next[e]] = item as u32;
                next[e] += 1;
                let (la, lb) = TET_PAIRS[item % pairs];
                diagonal[e] |= la == lb;
            }
        }
        Some(TetGather {
            ptr,
            items,
            diagonal,
        })
    }
}

impl HessianLayout {
    /// The analysed sparsity pattern.
    pub fn pattern(&self) -> &SpdPattern {
        &self.pattern
    }

    /// Whether this layout serves an objective over `mesh` with these
    /// `fixed` flags (empty = none): the same dimension, the same element
    /// corners in the same order, the same fixed vertices.
    pub fn fits(&self, mesh: &ParamMesh, fixed: &[bool]) -> bool {
        let n = mesh.num_vertices();
        let same_fixed = if fixed.is_empty() {
            self.fixed.len() == n && self.fixed.iter().all(|&f| !f)
        } else {
            self.fixed == fixed
        };
        self.dim == mesh.dim()
            && same_fixed
            && self.elements.len() == mesh.num_elements() * (mesh.dim() + 1)
            && (0..mesh.num_elements()).all(|e| {
                let k = e * (self.dim + 1);
                self.elements[k..k + self.dim + 1] == *mesh.element(e)
            })
    }
}

impl<'a> Objective<'a> {
    /// An objective over `mesh` with distortion `energy` weighted by
    /// `lambda`, an optional template term, and `fixed[v]` vertices kept at
    /// their starting positions (empty = none fixed).
    pub fn new(
        mesh: &'a ParamMesh,
        energy: &'a dyn DistortionEnergy,
        lambda: f64,
        template: Option<TemplateTerm<'a>>,
        fixed: &[bool],
    ) -> Result<Self, ParamError> {
        let n = mesh.num_vertices();
        if !(lambda.is_finite() && lambda >= 0.0) {
            return Err(ParamError::Setting {
                name: "lambda",
                value: lambda,
                expected: "finite and >= 0",
            });
        }
        if let Some(t) = &template {
            for (what, len) in [
                ("template labels", t.labels.len()),
                ("template weights", t.weights.len()),
            ] {
                if len != n {
                    return Err(ParamError::Length {
                        what,
                        expected: n,
                        found: len,
                    });
                }
            }
            if let Some((vertex, &weight)) = t
                .weights
                .iter()
                .enumerate()
                .find(|(_, w)| !w.is_finite() || **w < 0.0)
            {
                return Err(ParamError::TemplateWeight { vertex, weight });
            }
        }
        let fixed = if fixed.is_empty() {
            vec![false; n]
        } else {
            fixed.to_vec()
        };
        if fixed.len() != n {
            return Err(ParamError::Length {
                what: "fixed flags",
                expected: n,
                found: fixed.len(),
            });
        }
        Ok(Objective {
            mesh,
            energy,
            lambda,
            template,
            fixed,
            layout: None,
            local2: Vec::new(),
            local3: Vec::new(),
            linear_solver: LinearSolver::Auto,
            vertex_slots: Vec::new(),
            floors: element_floors(mesh),
        })
    }

    /// The rest mesh.
    pub fn mesh(&self) -> &ParamMesh {
        self.mesh
    }

    /// Mapped dimension (2 or 3).
    pub fn dim(&self) -> usize {
        self.mesh.dim()
    }

    /// Number of unknowns (`dim * vertices`, fixed ones included).
    pub fn len(&self) -> usize {
        self.dim() * self.mesh.num_vertices()
    }

    /// Whether the problem has no unknowns.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Per-vertex fixed flags.
    pub fn fixed(&self) -> &[bool] {
        &self.fixed
    }

    /// Whether the template parameters are unknowns of the Newton system
    /// (a template with parameters that wants them optimized; any number of
    /// them: the Newton step eliminates them through their dense `p x p`
    /// Schur complement, at a cost of `p` extra solves per iteration).
    pub fn joint_theta(&self, theta: &[f64]) -> bool {
        matches!(&self.template, Some(t) if !theta.is_empty() && t.template.optimize_theta())
    }

    /// The template term, if any.
    pub fn template(&self) -> Option<&TemplateTerm<'a>> {
        self.template.as_ref()
    }

    /// The distortion energy.
    pub fn energy(&self) -> &dyn DistortionEnergy {
        self.energy
    }

    /// Checks the length of a position vector.
    pub fn check_len(&self, x: &[f64]) -> Result<(), ParamError> {
        if x.len() != self.len() {
            return Err(ParamError::Length {
                what: "positions",
                expected: self.len(),
                found: x.len(),
            });
        }
        Ok(())
    }

    /// `sum_k V_k D(J_k)` (without lambda): the distortion part; INFINITY
    /// when a barrier energy meets an inverted element. Summed in a fixed
    /// order ([`ordered_sum`]), so the value does not depend on the thread
    /// count or the scheduling.
    pub fn distortion(&self, x: &[f64]) -> f64 {
        let m = self.mesh;
        match &m.elements {
            RestElements::Tets { tets, dm_inv } => ordered_sum(tets.len(), |k| {
                m.weight[k] * density3(self.energy, &jacobian3(x, &tets[k], &dm_inv[k]))
            }),
            RestElements::Tris { tris, dm_inv } => ordered_sum(tris.len(), |k| {
                m.weight[k] * density2(self.energy, &jacobian2(x, &tris[k], &dm_inv[k]))
            }),
        }
    }

    /// The template part `sum_m w_m T(x_m, theta)` (0 without a template).
    pub fn template_value(&self, x: &[f64], theta: &[f64]) -> f64 {
        let Some(t) = &self.template else { return 0.0 };
        let d = self.dim();
        (0..self.mesh.num_vertices())
            .filter(|&v| t.weights[v] > 0.0)
            .map(|v| {
                t.weights[v]
                    * t.template
                        .value(v, t.labels[v], &x[d * v..d * v + d], theta)
            })
            .sum()
    }

    /// `phi(x, theta)`.
    pub fn value(&self, x: &[f64], theta: &[f64]) -> f64 {
        let dist = self.distortion(x);
        if !dist.is_finite() {
            return f64::INFINITY;
        }
        self.lambda * dist + self.template_value(x, theta)
    }

    /// `phi` and its gradient in `x` (zero on fixed vertices).
    pub fn value_gradient(&self, x: &[f64], theta: &[f64], grad: &mut [f64]) -> f64 {
        let d = self.dim();
        grad.iter_mut().for_each(|g| *g = 0.0);
        let m = self.mesh;
        let lambda = self.lambda;
        // Element gradients in parallel, then a serial scatter.
        let energy = self.energy;
        let value = match &m.elements {
            RestElements::Tets { tets, dm_inv } => {
                element_gradients::<3, 4, 12>(tets, dm_inv, &m.weight, lambda, x, grad, |f| {
                    eval3(energy, f, HessianMode::None).map(|e| (e.value, e.grad))
                })
            }
            RestElements::Tris { tris, dm_inv } => {
                element_gradients::<2, 3, 6>(tris, dm_inv, &m.weight, lambda, x, grad, |f| {
                    eval2(energy, f, HessianMode::None).map(|e| (e.value, e.grad))
                })
            }
        };
        let mut value = value;
        if let Some(t) = &self.template {
            let mut g = [0.0; 3];
            for v in 0..m.num_vertices() {
                let w = t.weights[v];
                if w > 0.0 {
                    let xv = &x[d * v..d * v + d];
                    value += w * t.template.value(v, t.labels[v], xv, theta);
                    t.template.gradient(v, t.labels[v], xv, theta, &mut g[..d]);
                    for i in 0..d {
                        grad[d * v + i] += w * g[i];
                    }
                }
            }
        }
        for (v, &f) in self.fixed.iter().enumerate() {
            if f {
                grad[d * v..d * v + d].iter_mut().for_each(|g| *g = 0.0);
            }
        }
        value
    }

    /// The Hessian's sparsity pattern (built and analysed on first use).
    pub fn pattern(&mut self) -> Result<&SpdPattern, ParamError> {
        Ok(&self.built_layout()?.pattern)
    }

    /// The Hessian's assembly plan (built on first use), to share with
    /// objectives over the same connectivity ([`Objective::with_layout`]).
    pub fn layout(&mut self) -> Result<Arc<HessianLayout>, ParamError> {
        Ok(Arc::clone(self.built_layout()?))
    }

    /// The layout this objective built or was given, if any (no Hessian
    /// was needed yet otherwise): what a [`crate::LayoutCache`] keeps.
    pub fn layout_if_built(&self) -> Option<Arc<HessianLayout>> {
        self.layout.clone()
    }

    /// This objective with a layout built by another one over the same
    /// connectivity and fixed vertices, skipping the ordering and symbolic
    /// analysis.
    ///
    /// # Errors
    /// [`ParamError::LayoutMismatch`] when `layout` does not
    /// [`fit`](HessianLayout::fits) this mesh and fixed set.
    pub fn with_layout(mut self, layout: Arc<HessianLayout>) -> Result<Self, ParamError> {
        if !layout.fits(self.mesh, &self.fixed) {
            return Err(ParamError::LayoutMismatch);
        }
        self.vertex_slots = self.template_slots(&layout.pattern);
        self.layout = Some(layout);
        Ok(self)
    }

    fn built_layout(&mut self) -> Result<&Arc<HessianLayout>, ParamError> {
        if self.layout.is_none() {
            self.build_pattern()?;
        }
        self.layout.as_ref().ok_or(ParamError::Internal {
            what: "the Hessian layout was not built",
        })
    }

    /// Stores a freshly built pattern and slots as this objective's layout.
    fn set_layout(
        &mut self,
        pattern: SpdPattern,
        element_slots: Vec<u32>,
        gather: Option<TetGather>,
    ) {
        self.vertex_slots = self.template_slots(&pattern);
        let dim = self.dim();
        let elements = (0..self.mesh.num_elements())
            .flat_map(|e| self.mesh.element(e).iter().copied())
            .collect();
        self.layout = Some(Arc::new(HessianLayout {
            pattern,
            element_slots,
            dim,
            elements,
            fixed: self.fixed.clone(),
            gather,
        }));
    }

    fn build_pattern(&mut self) -> Result<(), ParamError> {
        if self.dim() == 2 {
            self.build_pattern_tris()
        } else {
            self.build_pattern_tets()
        }
    }

    /// How this objective's Newton systems are solved: triangles always by
    /// Cholesky; tets as [`Objective::set_linear_solver`] says, by default
    /// ([`LinearSolver::Auto`]) by Cholesky below
    /// [`MULTIGRID_MIN_VERTICES`] vertices and by multigrid from there (the
    /// count includes fixed vertices, so that the memory estimate of the
    /// mesh alone, [`crate::memory::mesh_newton_memory`], predicts the
    /// solver a run will use).
    pub fn linear_solver(&self) -> LinearSolver {
        if self.dim() == 2 {
            return LinearSolver::Cholesky;
        }
        match self.linear_solver {
            LinearSolver::Auto => {
                if self.mesh.num_vertices() >= MULTIGRID_MIN_VERTICES {
                    LinearSolver::Multigrid
                } else {
                    LinearSolver::Cholesky
                }
            }
            chosen => chosen,
        }
    }

    /// Chooses how Newton's systems of a tet mesh are solved (before the
    /// pattern is built; a layout built already keeps its solver).
    pub fn set_linear_solver(&mut self, solver: LinearSolver) {
        self.linear_solver = solver;
    }

    /// The vertex graph of the Hessian as the upper triangle in compressed
    /// columns: column `b` holds the free vertices `a <= b` sharing an
    /// element with the free vertex `b` (sorted, `b` itself last); a fixed
    /// vertex's column holds only itself.
    fn vertex_graph(&self) -> (Vec<usize>, Vec<usize>) {
        let nv = self.mesh.num_vertices();
        let fixed = &self.fixed;
        let free = |v: u32| !fixed[v as usize];
        // (column b, row a) pairs, a <= b, both free; every diagonal.
        let mut pairs: Vec<[u32; 2]> = (0..nv as u32).map(|v| [v, v]).collect();
        for e in 0..self.mesh.num_elements() {
            let vs = self.mesh.element(e);
            for &b in vs {
                for &a in vs {
                    if a < b && free(a) && free(b) {
                        pairs.push([b, a]);
                    }
                }
            }
        }
        unfold_mesh::topology::sort_dedup_pairs(&mut pairs);
        let mut col_ptr = vec![0usize; nv + 1];
        for p in &pairs {
            col_ptr[p[0] as usize + 1] += 1;
        }
        for v in 0..nv {
            col_ptr[v + 1] += col_ptr[v];
        }
        let row_idx: Vec<usize> = pairs.iter().map(|p| p[1] as usize).collect();
        (col_ptr, row_idx)
    }

    /// The tet Hessian's pattern at the vertex level
    /// ([`SpdPattern::from_vertex_graph_with`], 3x3 blocks), solved by a
    /// nested-dissection Cholesky factorization or by multigrid
    /// ([`Objective::linear_solver`]); each tet keeps the graph entry of
    /// each of its 10 vertex pairs ([`TET_PAIRS`]), whose 3x3 blocks get
    /// their slots through [`SpdPattern::block_slot`] at assembly.
    fn build_pattern_tets(&mut self) -> Result<(), ParamError> {
        const D: usize = 3;
        let nv = self.mesh.num_vertices();
        let (col_ptr, row_idx) = self.vertex_graph();
        if row_idx.len() >= NONE as usize {
            return Err(ParamError::Linalg(unfold_linalg::LinalgError::TooLarge {
                rows: D * nv,
                cols: D * nv,
            }));
        }
        let solver = match self.linear_solver() {
            LinearSolver::Multigrid => VertexSolver::Multigrid(MultigridSettings::new(
                self.mesh.rest.iter().map(|p| [p.x, p.y, p.z]).collect(),
                multigrid_spacing(self.mesh),
            )),
            _ => VertexSolver::CholeskyNestedDissection,
        };
        let fixed = &self.fixed;
        let free = |v: u32| !fixed[v as usize];
        let mut slots = Vec::with_capacity(self.mesh.num_elements() * TET_PAIRS.len());
        for e in 0..self.mesh.num_elements() {
            let vs = self.mesh.element(e);
            for &(la, lb) in &TET_PAIRS {
                let (a, b) = (vs[la].min(vs[lb]), vs[la].max(vs[lb]));
                let entry = if free(a) && free(b) {
                    let (lo, hi) = (col_ptr[b as usize], col_ptr[b as usize + 1]);
                    row_idx[lo..hi]
                        .binary_search(&(a as usize))
                        .map_or(NONE, |k| (lo + k) as u32)
                } else {
                    NONE
                };
                slots.push(entry);
            }
        }
        let gather = match solver {
            VertexSolver::Multigrid(_) => None,
            _ => TetGather::new(&slots, row_idx.len()),
        };
        let pattern = SpdPattern::from_vertex_graph_with(nv, D, col_ptr, row_idx, solver)?;
        self.set_layout(pattern, slots, gather);
        Ok(())
    }

    /// The slots of each free template vertex's `d x d` block (upper
    /// triangle; the rest `NONE`).
    fn template_slots(&self, pattern: &SpdPattern) -> Vec<(u32, Vec<u32>)> {
        let d = self.dim();
        let mut vertex_slots = Vec::new();
        if let Some(t) = &self.template {
            for v in 0..self.mesh.num_vertices() as u32 {
                if t.weights[v as usize] > 0.0 && !self.fixed[v as usize] {
                    let mut s = Vec::with_capacity(d * d);
                    for i in 0..d {
                        for j in 0..d {
                            let (p, q) = ((d * v as usize + i) as u32, (d * v as usize + j) as u32);
                            s.push(if p <= q {
                                pattern.slot(p, q).map_or(NONE, |s| s as u32)
                            } else {
                                NONE
                            });
                        }
                    }
                    vertex_slots.push((v, s));
                }
            }
        }
        vertex_slots
    }

    /// The PSD-projected Hessian of `phi` in `x` as values in
    /// [`Objective::pattern`]'s slots; rows and columns of fixed vertices
    /// are the identity. When the template parameters are unknowns too
    /// ([`Objective::joint_theta`]), each template vertex's joint
    /// `(x, theta)` block is projected as a whole and the parameter part of
    /// the system is returned.
    pub fn hessian(
        &mut self,
        x: &[f64],
        theta: &[f64],
        values: &mut Vec<f64>,
    ) -> Result<Option<ThetaBlock>, ParamError> {
        self.hessian_with(x, theta, values, HessianMode::Projected)
    }

    /// As [`Objective::hessian`], with the element Hessians evaluated in
    /// `mode` ([`HessianMode::Exact`]: unprojected, possibly indefinite).
    pub fn hessian_with(
        &mut self,
        x: &[f64],
        theta: &[f64],
        values: &mut Vec<f64>,
        mode: HessianMode,
    ) -> Result<Option<ThetaBlock>, ParamError> {
        let layout = Arc::clone(self.built_layout()?);
        let pattern = &layout.pattern;
        values.clear();
        values.resize(pattern.nnz(), 0.0);
        let d = self.dim();
        let m = self.mesh;
        let lambda = self.lambda;
        match &m.elements {
            RestElements::Tets { tets, dm_inv } => {
                let energy = self.energy;
                let local_hessians = |start: usize, chunk: &mut [[f64; 144]]| {
                    chunk.par_iter_mut().enumerate().for_each(|(i, h)| {
                        let k = start + i;
                        let f = jacobian3(x, &tets[k], &dm_inv[k]);
                        let eigen = match mode {
                            HessianMode::None => None,
                            _ => hessian3_eigen(energy, &f, mode),
                        };
                        match eigen {
                            Some(eigen) => {
                                vertex_hessian3(&eigen, &dm_inv[k], lambda * m.weight[k], h)
                            }
                            None => *h = [0.0; 144],
                        }
                    });
                };
                let mut local = std::mem::take(&mut self.local3);
                local.resize(TET_CHUNK.min(tets.len()), [0.0; 144]);
                match &layout.gather {
                    Some(gather) => {
                        gather_tets(&layout, gather, tets, local_hessians, &mut local, values)
                    }
                    None => scatter_tets(&layout, tets, local_hessians, &mut local, values),
                }
                self.local3 = local;
            }
            RestElements::Tris { tris, dm_inv } => {
                let mut local = std::mem::take(&mut self.local2);
                local.resize(tris.len(), [0.0; TRI_SLOTS]);
                let energy = self.energy;
                local.par_iter_mut().enumerate().for_each(|(k, h)| {
                    let f = jacobian2(x, &tris[k], &dm_inv[k]);
                    match hessian2_eigen(energy, &f, mode) {
                        Some(eigen) => vertex_hessian2(&eigen, &dm_inv[k], lambda * m.weight[k], h),
                        None => *h = [0.0; TRI_SLOTS],
                    }
                });
                for (k, h) in local.iter().enumerate() {
                    let s = &layout.element_slots[k * TRI_SLOTS..(k + 1) * TRI_SLOTS];
                    for (slot, v) in s.iter().zip(h) {
                        if *slot != NONE {
                            values[*slot as usize] += v;
                        }
                    }
                }
                self.local2 = local;
            }
        }
        let joint = self.joint_theta(theta);
        let mut block = None;
        if let Some(t) = &self.template {
            let p = theta.len();
            let mut tb = ThetaBlock {
                p,
                b: vec![0.0; p * self.len()],
                c: vec![0.0; p * p],
                g: vec![0.0; p],
            };
            let mut h = [0.0; 9];
            let mut slot_of = vec![None; self.mesh.num_vertices()];
            for (i, (v, _)) in self.vertex_slots.iter().enumerate() {
                slot_of[*v as usize] = Some(i);
            }
            let mut gt = vec![0.0; p];
            let mut ct = vec![0.0; if joint { p * p } else { 0 }];
            for v in 0..self.mesh.num_vertices() {
                let w = t.weights[v];
                if w <= 0.0 {
                    continue;
                }
                let xv = &x[d * v..d * v + d];
                if joint {
                    t.template
                        .theta_gradient(v, t.labels[v], xv, theta, &mut gt);
                    for (gj, gtj) in tb.g.iter_mut().zip(&gt) {
                        *gj += w * gtj;
                    }
                }
                if self.fixed[v] {
                    if joint {
                        t.template.theta_hessian(v, t.labels[v], xv, theta, &mut ct);
                        for (k, cv) in ct.iter().enumerate() {
                            tb.c[k] += w * cv;
                        }
                    }
                    continue;
                }
                let Some(si) = slot_of[v] else { continue };
                if joint {
                    let j = joint_block(t.template, v, t.labels[v], xv, theta);
                    let m = d + p;
                    for r in 0..d {
                        for c in 0..d {
                            h[r * d + c] = j[r * m + c];
                        }
                        for c in 0..p {
                            tb.b[c * self.len() + d * v + r] += w * j[r * m + d + c];
                        }
                    }
                    for r in 0..p {
                        for c in 0..p {
                            tb.c[r * p + c] += w * j[(d + r) * m + d + c];
                        }
                    }
                } else {
                    t.template
                        .hessian(v, t.labels[v], xv, theta, &mut h[..d * d]);
                }
                for (slot, hv) in self.vertex_slots[si].1.iter().zip(&h[..d * d]) {
                    if *slot != NONE {
                        values[*slot as usize] += w * hv;
                    }
                }
            }
            if joint {
                block = Some(tb);
            }
        }
        for (v, &f) in self.fixed.iter().enumerate() {
            if f {
                for i in 0..d {
                    let p = (d * v + i) as u32;
                    if let Some(s) = pattern.slot(p, p) {
                        values[s] = 1.0;
                    }
                }
            }
        }
        Ok(block)
    }

    /// The triangle Hessian's pattern at the vertex level
    /// ([`SpdPattern::from_vertex_graph`], 2x2 blocks): the graph of the
    /// free vertices sharing a triangle (each fixed vertex alone on the
    /// diagonal), built from the sorted unique vertex pairs; each triangle's
    /// 36 local entries get their slots through [`SpdPattern::block_slot`]
    /// (the entries of a vertex pair `a <= b` only, the rest `NONE`).
    fn build_pattern_tris(&mut self) -> Result<(), ParamError> {
        const D: usize = 2;
        let nv = self.mesh.num_vertices();
        let fixed = &self.fixed;
        let free = |v: u32| !fixed[v as usize];
        let (col_ptr, row_idx) = self.vertex_graph();
        let pattern = SpdPattern::from_vertex_graph(nv, D, col_ptr.clone(), row_idx.clone())?;
        let nve = D + 1;
        let ld = D * nve;
        let mut slots = Vec::with_capacity(self.mesh.num_elements() * TRI_SLOTS);
        let mut entry = [[usize::MAX; 3]; 3];
        for e in 0..self.mesh.num_elements() {
            let vs = self.mesh.element(e);
            for (ra, &va) in vs.iter().enumerate() {
                for (rb, &vb) in vs.iter().enumerate() {
                    entry[ra][rb] = if va <= vb && free(va) && free(vb) {
                        let (lo, hi) = (col_ptr[vb as usize], col_ptr[vb as usize + 1]);
                        row_idx[lo..hi]
                            .binary_search(&(va as usize))
                            .map_or(usize::MAX, |k| lo + k)
                    } else {
                        usize::MAX
                    };
                }
            }
            // The 21 entries r <= c of the symmetric local matrix, each
            // stored once: as (r, c) when its row vertex has the smaller
            // index, transposed otherwise (a triangle's corners are
            // distinct: ParamMesh refuses degenerate ones).
            for r in 0..ld {
                for c in r..ld {
                    let (la, lb) = (r / D, c / D);
                    let (i, j) = (r % D, c % D);
                    let (k, i, j) = if vs[la] <= vs[lb] {
                        (entry[la][lb], i, j)
                    } else {
                        (entry[lb][la], j, i)
                    };
                    let s = if k == usize::MAX {
                        NONE
                    } else {
                        pattern.block_slot(k, i, j).map_or(NONE, |s| s as u32)
                    };
                    slots.push(s);
                }
            }
        }
        self.set_layout(pattern, slots, None);
        Ok(())
    }

    /// Lets the template improve its parameters for fixed `x`
    /// ([`Template::update_theta`]); false when it has no such update.
    pub fn update_theta(&self, x: &[f64], theta: &mut [f64]) -> bool {
        match &self.template {
            Some(t) if !theta.is_empty() => {
                t.template
                    .update_theta(t.labels, x, self.dim(), t.weights, theta)
            }
            _ => false,
        }
    }

    /// The largest step along `dir` before an element's `det J` falls to
    /// [`MIN_DET_J`] (or to half its current value when it is already
    /// below): the solvers' flip bound (ALGORITHMS 1.3) with a margin that
    /// keeps every accepted iterate's orientation above rounding noise.
    /// Infinite for an energy that
    /// [admits inversion](DistortionEnergy::admits_inversion) (the
    /// untangler's steps go through flips).
    pub fn max_step(&self, x: &[f64], dir: &[f64]) -> f64 {
        use crate::linesearch::{max_step_tets_above, max_step_tris_above};
        if self.energy.admits_inversion() {
            return f64::INFINITY;
        }
        match &self.mesh.elements {
            RestElements::Tets { tets, .. } => max_step_tets_above(tets, x, dir, &self.floors),
            RestElements::Tris { tris, .. } => max_step_tris_above(tris, x, dir, &self.floors),
        }
    }
}

/// The tets' Hessians into `values` (zero on entry): `local_hessians(start,
/// chunk)` fills the local Hessians of tets `start..start + chunk.len()` in
/// `local`, a chunk of [`TET_CHUNK`] at a time (the buffer stays TET_CHUNK
/// x 1.15 KB whatever the mesh), each chunk scattered serially in tet order
/// before the next.
fn scatter_tets(
    layout: &HessianLayout,
    tets: &[[u32; 4]],
    local_hessians: impl Fn(usize, &mut [[f64; 144]]),
    local: &mut [[f64; 144]],
    values: &mut [f64],
) {
    for start in (0..tets.len()).step_by(TET_CHUNK) {
        let chunk = &mut local[..TET_CHUNK.min(tets.len() - start)];
        local_hessians(start, chunk);
        for (i, h) in chunk.iter().enumerate() {
            let k = start + i;
            let entries = &layout.element_slots[k * TET_PAIRS.len()..][..TET_PAIRS.len()];
            scatter_tet(&layout.pattern, &tets[k], entries, h, values);
        }
    }
}

/// As [`scatter_tets`], with the sums done per graph entry in parallel
/// ([`TetGather`]): for each chunk of local Hessians, every entry adds the
/// blocks of its tets in that chunk (its cursor moves through its items,
/// which are in tet order) into its own 3x3 accumulator; the accumulators
/// are then stored in their value slots. Every slot receives the same
/// additions in the same order as in [`scatter_tets`], so `values` are bit
/// for bit the same, for any number of threads.
fn gather_tets(
    layout: &HessianLayout,
    gather: &TetGather,
    tets: &[[u32; 4]],
    local_hessians: impl Fn(usize, &mut [[f64; 144]]),
    local: &mut [[f64; 144]],
    values: &mut [f64],
) {
    const P: usize = TET_PAIRS.len();
    let n_entries = gather.diagonal.len();
    let mut sums = vec![[0.0f64; 9]; n_entries];
    let mut cursor: Vec<usize> = gather.ptr[..n_entries].to_vec();
    for start in (0..tets.len()).step_by(TET_CHUNK) {
        let len = TET_CHUNK.min(tets.len() - start);
        let chunk = &mut local[..len];
        local_hessians(start, chunk);
        let chunk = &*chunk;
        let end_item = (start + len) * P;
        sums.par_iter_mut()
            .zip(cursor.par_iter_mut())
            .enumerate()
            .with_min_len(256)
            .for_each(|(e, (acc, c))| {
                let end = gather.ptr[e + 1];
                while *c < end && (gather.items[*c] as usize) < end_item {
                    let item = gather.items[*c] as usize;
                    let (k, (la, lb)) = (item / P, TET_PAIRS[item % P]);
                    let h = &chunk[k - start];
                    let flip = tets[k][la] > tets[k][lb];
                    for i in 0..3 {
                        let j0 = if la == lb { i } else { 0 };
                        for j in j0..3 {
                            let (bi, bj) = if flip { (j, i) } else { (i, j) };
                            acc[3 * bi + bj] += h[12 * (3 * la + i) + 3 * lb + j];
                        }
                    }
                    *c += 1;
                }
            });
    }
    let pattern = &layout.pattern;
    for (e, acc) in sums.iter().enumerate() {
        for i in 0..3 {
            let j0 = if gather.diagonal[e] { i } else { 0 };
            for j in j0..3 {
                if let Some(s) = pattern.block_slot(e, i, j) {
                    values[s] = acc[3 * i + j];
                }
            }
        }
    }
}

/// Adds a tet's 12x12 local Hessian `h` (row-major, local DOF `3 v + i`)
/// into `values`: for each vertex pair `(a, b)` of [`TET_PAIRS`] with graph
/// entry `e` (not `NONE`), the block `h[3a.., 3b..]` goes to
/// `block_slot(e, i, j)`, transposed when corner `a` has the larger vertex
/// index (the graph stores the pair as (smaller, larger)); on a diagonal
/// block only `i <= j`.
#[inline]
fn scatter_tet(
    pattern: &SpdPattern,
    tet: &[u32; 4],
    entries: &[u32],
    h: &[f64; 144],
    values: &mut [f64],
) {
    for (&(la, lb), &e) in TET_PAIRS.iter().zip(entries) {
        if e == NONE {
            continue;
        }
        let flip = tet[la] > tet[lb];
        for i in 0..3 {
            let j0 = if la == lb { i } else { 0 };
            for j in j0..3 {
                let (bi, bj) = if flip { (j, i) } else { (i, j) };
                if let Some(s) = pattern.block_slot(e as usize, bi, bj) {
                    values[s] += h[12 * (3 * la + i) + 3 * lb + j];
                }
            }
        }
    }
}

/// The multigrid background grid's spacing for `mesh`:
/// `(MULTIGRID_VERTICES_PER_CELL V / n)^(1/3)` with `V` the rest volume
/// and `n` the vertex count (about that many vertices per grid cell).
fn multigrid_spacing(mesh: &ParamMesh) -> f64 {
    let volume: f64 = mesh.measure.iter().map(|m| m.abs()).sum();
    let n = mesh.num_vertices().max(1) as f64;
    (MULTIGRID_VERTICES_PER_CELL * volume / n).cbrt()
}

/// `MIN_DET_J det(Dm)` per element: `det(Dm) = 1 / det(Dm^-1)`.
fn element_floors(mesh: &ParamMesh) -> Vec<f64> {
    match &mesh.elements {
        RestElements::Tets { dm_inv, .. } => dm_inv
            .iter()
            .map(|m| MIN_DET_J / m.determinant().abs())
            .collect(),
        RestElements::Tris { dm_inv, .. } => dm_inv
            .iter()
            .map(|m| MIN_DET_J / m.determinant().abs())
            .collect(),
    }
}

/// `J = Ds Dm^-1` of the simplex `t` with `N = D + 1` corners at positions
/// `x` (`D` per vertex), with `Ds = [x_1 - x_0 | ... | x_D - x_0]` (columns)
/// (ALGORITHMS 1.1): one kernel for tets (`D = 3`) and triangles in the
/// plane (`D = 2`), [`jacobian3`] and [`jacobian2`].
#[inline]
pub fn jacobian<const D: usize, const N: usize>(
    x: &[f64],
    t: &[u32; N],
    dm_inv: &SMatrix<f64, D, D>,
) -> SMatrix<f64, D, D> {
    const { assert!(N == D + 1) };
    let p = |v: u32| {
        let i = D * v as usize;
        SVector::<f64, D>::from_fn(|r, _| x[i + r])
    };
    let a = p(t[0]);
    let columns: [SVector<f64, D>; D] = std::array::from_fn(|c| p(t[c + 1]) - a);
    SMatrix::<f64, D, D>::from_columns(&columns) * dm_inv
}

/// `J = Ds Dm^-1` of tet `t` at positions `x` (3 per vertex): [`jacobian`]
/// with `D = 3`.
#[inline]
pub fn jacobian3(x: &[f64], t: &[u32; 4], dm_inv: &Matrix3<f64>) -> Matrix3<f64> {
    jacobian::<3, 4>(x, t, dm_inv)
}

/// `J = Ds Dm^-1` of triangle `t` at planar positions `x` (2 per vertex):
/// [`jacobian`] with `D = 2`.
#[inline]
pub fn jacobian2(x: &[f64], t: &[u32; 3], dm_inv: &Matrix2<f64>) -> Matrix2<f64> {
    jacobian::<2, 3>(x, t, dm_inv)
}

/// `P[v][j] = dF_ij / dx_{v,i}` for the `N = D + 1` corners:
/// `P[0] = -sum_k Dm^-1[k]`, `P[v] = Dm^-1[v-1]` (rows of `Dm^-1`).
#[inline]
fn corner_map<const D: usize, const N: usize>(dm_inv: &SMatrix<f64, D, D>) -> [[f64; D]; N] {
    const { assert!(N == D + 1) };
    let mut p = [[0.0; D]; N];
    for j in 0..D {
        for k in 0..D {
            p[k + 1][j] = dm_inv[(k, j)];
            p[0][j] -= dm_inv[(k, j)];
        }
    }
    p
}

/// Vertex gradient of a simplex from `G = dE/dF`:
/// `dE/dx_{v,i} = sum_j G_ij P[v][j]` ([`corner_map`]), at local DOF
/// `D v + i` (`L = D N` of them).
#[inline]
fn vertex_gradient<const D: usize, const N: usize, const L: usize>(
    g: &SMatrix<f64, D, D>,
    dm_inv: &SMatrix<f64, D, D>,
) -> [f64; L] {
    const { assert!(L == D * N) };
    let p = corner_map::<D, N>(dm_inv);
    let mut out = [0.0; L];
    for v in 0..N {
        for i in 0..D {
            out[D * v + i] = (0..D).map(|j| g[(i, j)] * p[v][j]).sum();
        }
    }
    out
}

/// Terms per chunk of [`ordered_sum`].
const SUM_CHUNK: usize = 2048;

/// `sum_{k < n} term(k)` in a fixed order: the chunks of [`SUM_CHUNK`]
/// consecutive terms are summed in parallel, each from its first term to
/// its last, then the chunk sums in chunk order. The same bits for any
/// thread count and scheduling (a parallel iterator's `sum` splits the
/// range where work is stolen, so its rounding varies from run to run).
fn ordered_sum(n: usize, term: impl Fn(usize) -> f64 + Sync) -> f64 {
    let chunks: Vec<f64> = (0..n.div_ceil(SUM_CHUNK))
        .into_par_iter()
        .map(|c| {
            (c * SUM_CHUNK..((c + 1) * SUM_CHUNK).min(n))
                .map(&term)
                .sum::<f64>()
        })
        .collect();
    chunks.iter().sum()
}

/// `sum_k lambda V_k psi(J_k)` over the simplices `elements` and its
/// gradient added into `grad` (`D` per vertex): `eval` gives `psi` and
/// `dpsi/dF` of a Jacobian ([`jacobian`]), or `None` for an infinite value
/// (an inverted element under a barrier; no gradient then). The element
/// values and gradients ([`vertex_gradient`] of `lambda V_k dpsi/dF`) are
/// evaluated in parallel, then summed and scattered serially in element
/// order (so the result does not depend on the thread count).
fn element_gradients<const D: usize, const N: usize, const L: usize>(
    elements: &[[u32; N]],
    dm_inv: &[SMatrix<f64, D, D>],
    weight: &[f64],
    lambda: f64,
    x: &[f64],
    grad: &mut [f64],
    eval: impl Fn(&SMatrix<f64, D, D>) -> Option<(f64, SMatrix<f64, D, D>)> + Sync,
) -> f64 {
    let parts: Vec<(f64, [f64; L])> = (0..elements.len())
        .into_par_iter()
        .map(|k| {
            let f = jacobian::<D, N>(x, &elements[k], &dm_inv[k]);
            match eval(&f) {
                Some((value, g)) => {
                    let w = lambda * weight[k];
                    (w * value, vertex_gradient::<D, N, L>(&(g * w), &dm_inv[k]))
                }
                None => (f64::INFINITY, [0.0; L]),
            }
        })
        .collect();
    let mut v = 0.0;
    for (k, (val, g)) in parts.iter().enumerate() {
        v += val;
        for (a, &vi) in elements[k].iter().enumerate() {
            for i in 0..D {
                grad[D * vi as usize + i] += g[D * a + i];
            }
        }
    }
    v
}

/// `H_x = w (sum_ab hs_ab c_a c_b^T + sum_k l_k w_k w_k^T)` (12x12,
/// row-major over local DOF `3 v + i`) from the element's Hessian modes
/// ([`Eigen3`]): `c_a = C^T vec(D_a)` and `w_k = C^T vec(m_k)` with
/// `(C^T m)[3 v + i] = sum_j P[v][j] m_ij` the vertex form of a 3x3 mode
/// (the chain rule through `F = [x1 - x0, x2 - x0, x3 - x0] Dm^-1`;
/// [`corner_map`]). This is `w C^T H_F C` with `H_F = eigen.matrix()`,
/// `H_x[(v,i),(u,k)] = w sum_{j,l} P[v][j] P[u][l] H_F[i+3j, k+3l]`, in about
/// a third of the multiply-adds. Pair modes with a zero eigenvalue (clamped
/// ones) are skipped.
#[inline]
#[allow(clippy::needless_range_loop)]
fn vertex_hessian3(eigen: &Eigen3, dm_inv: &Matrix3<f64>, w: f64, out: &mut [f64; 144]) {
    let p = corner_map::<3, 4>(dm_inv);
    let vertex = |m: &Matrix3<f64>| {
        let mut c = [0.0; 12];
        for v in 0..4 {
            for i in 0..3 {
                c[3 * v + i] = p[v][0] * m[(i, 0)] + p[v][1] * m[(i, 1)] + p[v][2] * m[(i, 2)];
            }
        }
        c
    };
    let c = eigen.scaling_modes.each_ref().map(vertex);
    // e_a = w sum_b hs_ab c_b
    let mut e = [[0.0; 12]; 3];
    for a in 0..3 {
        for b in 0..3 {
            let h = w * eigen.scaling[a][b];
            for r in 0..12 {
                e[a][r] += h * c[b][r];
            }
        }
    }
    for r in 0..12 {
        for col in r..12 {
            out[12 * r + col] = c[0][r] * e[0][col] + c[1][r] * e[1][col] + c[2][r] * e[2][col];
        }
    }
    for (&l, m) in eigen.values.iter().zip(&eigen.modes) {
        if l == 0.0 {
            continue;
        }
        let wk = vertex(m);
        let lw = l * w;
        for r in 0..12 {
            let x = lw * wk[r];
            for col in r..12 {
                out[12 * r + col] += x * wk[col];
            }
        }
    }
    for r in 1..12 {
        for col in 0..r {
            out[12 * r + col] = out[12 * col + r];
        }
    }
}

/// `H_x = w sum_k l_k (C^T m_k)(C^T m_k)^T` (the 21 entries `r <= c` of
/// the symmetric 6x6, row-major over local DOF `2 v + i`) from the
/// element's Hessian eigensystem ([`Eigen2`]), with
/// `(C^T m)[2 v + i] = sum_j P[v][j] m_ij` the vertex form of a 2x2 mode
/// (the chain rule through `F = [x1 - x0, x2 - x0] Dm^-1`). Modes with a zero
/// eigenvalue (clamped ones) are skipped.
#[inline]
fn vertex_hessian2(eigen: &Eigen2, dm_inv: &Matrix2<f64>, w: f64, out: &mut [f64; TRI_SLOTS]) {
    let p = corner_map::<2, 3>(dm_inv);
    *out = [0.0; TRI_SLOTS];
    for (&l, m) in eigen.values.iter().zip(&eigen.modes) {
        if l == 0.0 {
            continue;
        }
        let mut c = [0.0; 6];
        for v in 0..3 {
            for i in 0..2 {
                c[2 * v + i] = p[v][0] * m[(i, 0)] + p[v][1] * m[(i, 1)];
            }
        }
        let lw = l * w;
        let mut k = 0;
        for r in 0..6 {
            let x = lw * c[r];
            for cc in &c[r..] {
                out[k] += x * cc;
                k += 1;
            }
        }
    }
}

/// The joint `(x, theta)` Hessian block of one template vertex (row-major
/// `(d + p)^2`), projected to positive semidefinite by clamping its
/// eigenvalues at 0.
fn joint_block(t: &dyn Template, v: usize, label: u8, x: &[f64], theta: &[f64]) -> Vec<f64> {
    let (d, p) = (x.len(), theta.len());
    let m = d + p;
    let mut hx = [0.0; 9];
    let mut mixed = vec![0.0; d * p];
    let mut c = vec![0.0; p * p];
    t.hessian(v, label, x, theta, &mut hx[..d * d]);
    t.mixed_hessian(v, label, x, theta, &mut mixed);
    t.theta_hessian(v, label, x, theta, &mut c);
    let mut full = nalgebra::DMatrix::<f64>::zeros(m, m);
    for r in 0..d {
        for k in 0..d {
            full[(r, k)] = hx[r * d + k];
        }
        for j in 0..p {
            full[(r, d + j)] = mixed[r * p + j];
            full[(d + j, r)] = mixed[r * p + j];
        }
    }
    for i in 0..p {
        for j in 0..p {
            full[(d + i, d + j)] = c[i * p + j];
        }
    }
    let eig = nalgebra::SymmetricEigen::new(full.clone());
    if eig.eigenvalues.iter().all(|&l| l >= 0.0) {
        return full.transpose().as_slice().to_vec();
    }
    let clamped = nalgebra::DVector::from_iterator(m, eig.eigenvalues.iter().map(|&l| l.max(0.0)));
    let proj = &eig.eigenvectors
        * nalgebra::DMatrix::from_diagonal(&clamped)
        * eig.eigenvectors.transpose();
    proj.transpose().as_slice().to_vec()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::energy::SymmetricDirichlet;
    use proptest::prelude::*;
    use unfold_mesh::TriMesh;
    use unfold_mesh::nalgebra::Point3;

    /// A bumpy `w x h` grid surface and its flattening `(x, y)`, jittered.
    fn grid(w: usize, h: usize, jitter: &[f64]) -> (TriMesh, Vec<f64>) {
        let id = |x: usize, y: usize| (y * w + x) as u32;
        let mut positions = Vec::new();
        let mut flat = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let (fx, fy) = (x as f64, y as f64);
                positions.push(Point3::new(
                    fx,
                    fy,
                    0.3 * (fx * 0.9).sin() * (fy * 0.7).cos(),
                ));
                let k = 2 * (y * w + x);
                flat.push(fx + 0.15 * jitter[k % jitter.len()]);
                flat.push(fy + 0.15 * jitter[(k + 1) % jitter.len()]);
            }
        }
        let mut triangles = Vec::new();
        for y in 0..h - 1 {
            for x in 0..w - 1 {
                triangles.push([id(x, y), id(x + 1, y), id(x + 1, y + 1)]);
                triangles.push([id(x, y), id(x + 1, y + 1), id(x, y + 1)]);
            }
        }
        (TriMesh::new(positions, triangles), flat)
    }

    proptest! {
        /// The assembled exact Hessian (through the pattern's slots) times
        /// `v` equals the finite difference of the gradient along `v` on
        /// the free unknowns, with the fixed ones decoupled: their rows are
        /// the identity and their entries of `v` do not reach free rows.
        #[test]
        fn assembled_hessian_matches_the_gradient_with_fixed_vertices(
            w in 2usize..7,
            h in 2usize..7,
            jitter in prop::collection::vec(-1.0..1.0f64, 16),
            fixed_bits in any::<u64>(),
            dir in prop::collection::vec(-1.0..1.0f64, 16),
        ) {
            let (mesh, x) = grid(w, h, &jitter);
            let pm = ParamMesh::from_triangles(&mesh).unwrap();
            let nv = w * h;
            let fixed: Vec<bool> = (0..nv).map(|v| fixed_bits >> (v % 64) & 1 == 1).collect();
            let mut obj = Objective::new(&pm, &SymmetricDirichlet, 1.0, None, &fixed).unwrap();
            let mut values = Vec::new();
            obj.hessian_with(&x, &[], &mut values, HessianMode::Exact).unwrap();
            let v: Vec<f64> = (0..2 * nv).map(|i| dir[i % dir.len()] + 0.01 * i as f64).collect();
            let hv = obj.pattern().unwrap().multiply(&values, &v);
            let free_v: Vec<f64> = (0..2 * nv)
                .map(|i| if fixed[i / 2] { 0.0 } else { v[i] })
                .collect();
            let eps = 1e-6;
            let grad_at = |s: f64| {
                let xs: Vec<f64> = x.iter().zip(&free_v).map(|(a, b)| a + s * b).collect();
                let mut g = vec![0.0; xs.len()];
                obj.value_gradient(&xs, &[], &mut g);
                g
            };
            let (gp, gm) = (grad_at(eps), grad_at(-eps));
            let scale = hv.iter().map(|x| x.abs()).fold(1.0, f64::max);
            for i in 0..2 * nv {
                if fixed[i / 2] {
                    prop_assert_eq!(hv[i], v[i], "fixed dof {}", i);
                } else {
                    let fd = (gp[i] - gm[i]) / (2.0 * eps);
                    prop_assert!((hv[i] - fd).abs() <= 1e-6 * scale, "dof {}: {} vs {}", i, hv[i], fd);
                }
            }
        }

        /// A layout shared with an objective over the same connectivity
        /// (another rest shape: a time step) assembles exactly the values
        /// that objective would build itself.
        #[test]
        fn a_shared_layout_assembles_the_same_hessian(
            w in 2usize..7,
            h in 2usize..7,
            jitter in prop::collection::vec(-1.0..1.0f64, 16),
            fixed_bits in any::<u64>(),
        ) {
            let (mesh, x) = grid(w, h, &jitter);
            let mut moved = mesh.clone();
            for p in &mut moved.positions {
                p.z += 0.2 * p.x;
            }
            let (pm, pm2) = (
                ParamMesh::from_triangles(&mesh).unwrap(),
                ParamMesh::from_triangles(&moved).unwrap(),
            );
            let nv = w * h;
            let fixed: Vec<bool> = (0..nv).map(|v| fixed_bits >> (v % 64) & 1 == 1).collect();
            let mut first = Objective::new(&pm, &SymmetricDirichlet, 1.0, None, &fixed).unwrap();
            let layout = first.layout().unwrap();
            let mut shared = Objective::new(&pm2, &SymmetricDirichlet, 1.0, None, &fixed)
                .unwrap()
                .with_layout(layout)
                .unwrap();
            let mut own = Objective::new(&pm2, &SymmetricDirichlet, 1.0, None, &fixed).unwrap();
            let (mut a, mut b) = (Vec::new(), Vec::new());
            shared.hessian_with(&x, &[], &mut a, HessianMode::Projected).unwrap();
            own.hessian_with(&x, &[], &mut b, HessianMode::Projected).unwrap();
            prop_assert_eq!(a, b);
        }
    }

    /// A small placenta slab's rest data (868 vertices, 3,456 tets) and
    /// its side labels.
    fn slab() -> (ParamMesh, Vec<u8>) {
        let shape = unfold_mesh::shapes::placenta_slab(&unfold_mesh::shapes::PlacentaParams {
            cells_radial: 8,
            cells_through: 3,
            ..Default::default()
        })
        .unwrap();
        (ParamMesh::from_tets(&shape.mesh).unwrap(), shape.side)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(8))]

        /// Tets, with either linear solver's layout: the assembled exact
        /// Hessian times `v` equals the finite difference of the gradient
        /// along `v`, fixed rows the identity.
        #[test]
        fn assembled_tet_hessian_matches_the_gradient(
            jitter in prop::collection::vec(-1.0..1.0f64, 32),
            fixed_bits in any::<u64>(),
            dir in prop::collection::vec(-1.0..1.0f64, 32),
            multigrid in any::<bool>(),
        ) {
            let (pm, _) = slab();
            let nv = pm.num_vertices();
            let x: Vec<f64> = pm
                .rest_flat()
                .iter()
                .enumerate()
                .map(|(i, r)| r * 1.1 + 0.2 * jitter[(i * 7) % jitter.len()])
                .collect();
            let fixed: Vec<bool> = (0..nv).map(|v| (fixed_bits >> (v % 61)) & 7 == 0).collect();
            let mut obj = Objective::new(&pm, &SymmetricDirichlet, 1.0, None, &fixed).unwrap();
            let solver = if multigrid { LinearSolver::Multigrid } else { LinearSolver::Cholesky };
            obj.set_linear_solver(solver);
            prop_assert_eq!(obj.linear_solver(), solver);
            let mut values = Vec::new();
            obj.hessian_with(&x, &[], &mut values, HessianMode::Exact).unwrap();
            prop_assert_eq!(obj.pattern().unwrap().multigrid_sizes().is_some(), multigrid);
            let v: Vec<f64> = (0..3 * nv).map(|i| dir[i % dir.len()] + 0.01 * (i % 13) as f64).collect();
            let hv = obj.pattern().unwrap().multiply(&values, &v);
            let free_v: Vec<f64> = (0..3 * nv)
                .map(|i| if fixed[i / 3] { 0.0 } else { v[i] })
                .collect();
            let eps = 1e-6;
            let grad_at = |s: f64| {
                let xs: Vec<f64> = x.iter().zip(&free_v).map(|(a, b)| a + s * b).collect();
                let mut g = vec![0.0; xs.len()];
                obj.value_gradient(&xs, &[], &mut g);
                g
            };
            let (gp, gm) = (grad_at(eps), grad_at(-eps));
            let scale = hv.iter().map(|x| x.abs()).fold(1e-3, f64::max);
            for i in 0..3 * nv {
                if fixed[i / 3] {
                    prop_assert_eq!(hv[i], v[i], "fixed dof {}", i);
                } else {
                    let fd = (gp[i] - gm[i]) / (2.0 * eps);
                    prop_assert!((hv[i] - fd).abs() <= 1e-6 * scale, "dof {}: {} vs {}", i, hv[i], fd);
                }
            }
        }
    }

    #[test]
    fn newton_with_multigrid_reaches_the_cholesky_minimizer() {
        use crate::solver::{Executor, ProjectedNewton, Solver, Stopping};
        use unfold_mesh::shapes::side;
        // The slab stretched by 1.2 along z, its fetal and maternal sides
        // held there: the free lateral wall relaxes.
        let (pm, sides) = slab();
        let fixed: Vec<bool> = sides
            .iter()
            .map(|&s| s == side::FETAL || s == side::MATERNAL)
            .collect();
        let mut x0 = pm.rest_flat();
        for z in x0.iter_mut().skip(2).step_by(3) {
            *z *= 1.2;
        }
        let solve = |solver: LinearSolver| {
            let mut obj = Objective::new(&pm, &SymmetricDirichlet, 1.0, None, &fixed).unwrap();
            obj.set_linear_solver(solver);
            let mut x = x0.clone();
            let report = Executor::new(&ProjectedNewton::default())
                .stopping(Stopping {
                    grad_tol: 1e-9,
                    ..ProjectedNewton::default().default_stopping()
                })
                .run(&mut obj, &mut x, &mut [])
                .unwrap();
            assert!(
                report.converged && report.iterations >= 2,
                "{solver:?}: {report:?}"
            );
            (x, report.value)
        };
        let (xc, vc) = solve(LinearSolver::Cholesky);
        let (xm, vm) = solve(LinearSolver::Multigrid);
        assert!((vc - vm).abs() <= 1e-10 * vc.abs(), "{vc} vs {vm}");
        let diff = xc
            .iter()
            .zip(&xm)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(diff < 1e-6, "positions differ by {diff} mm");
    }

    #[test]
    fn a_layout_refuses_another_connectivity_or_fixed_set() {
        let (mesh, _) = grid(4, 3, &[0.1, -0.2, 0.3]);
        let pm = ParamMesh::from_triangles(&mesh).unwrap();
        let mut fixed = vec![false; 12];
        fixed[0] = true;
        let layout = Objective::new(&pm, &SymmetricDirichlet, 1.0, None, &fixed)
            .unwrap()
            .layout()
            .unwrap();
        assert!(layout.fits(&pm, &fixed));
        assert!(!layout.fits(&pm, &[]));
        let err = |o: Result<Objective<'_>, ParamError>| match o {
            Err(e @ ParamError::LayoutMismatch) => e.to_string(),
            other => panic!("expected an error, got {other:?}"),
        };
        // Another fixed set.
        let m = err(Objective::new(&pm, &SymmetricDirichlet, 1.0, None, &[])
            .unwrap()
            .with_layout(layout.clone()));
        assert!(m.contains("another connectivity or fixed set"), "{m}");
        // Another connectivity: one triangle's corners rotated.
        let mut other = mesh.clone();
        other.triangles[2].rotate_left(1);
        let pm2 = ParamMesh::from_triangles(&other).unwrap();
        err(Objective::new(&pm2, &SymmetricDirichlet, 1.0, None, &fixed)
            .unwrap()
            .with_layout(layout.clone()));
        // Another size.
        let (small, _) = grid(3, 3, &[0.0]);
        let pm3 = ParamMesh::from_triangles(&small).unwrap();
        err(
            Objective::new(&pm3, &SymmetricDirichlet, 1.0, None, &fixed[..9])
                .unwrap()
                .with_layout(layout),
        );
    }

    /// The assembly of `obj` at `x` in `mode` with `layout`'s pattern and
    /// slots but the serial scatter (no gather), and with the gather as
    /// `layout` has it, on a pool of `threads` threads.
    fn assemble_both(
        pm: &ParamMesh,
        fixed: &[bool],
        x: &[f64],
        mode: HessianMode,
        threads: usize,
    ) -> (Vec<f64>, Vec<f64>) {
        let mut obj = Objective::new(pm, &SymmetricDirichlet, 1.0, None, fixed).unwrap();
        let layout = obj.layout().unwrap();
        assert!(layout.gather.is_some(), "a Cholesky tet layout gathers");
        let serial = Arc::new(HessianLayout {
            pattern: layout.pattern.clone(),
            element_slots: layout.element_slots.clone(),
            dim: layout.dim,
            elements: layout.elements.clone(),
            fixed: layout.fixed.clone(),
            gather: None,
        });
        let mut obj_serial = Objective::new(pm, &SymmetricDirichlet, 1.0, None, fixed)
            .unwrap()
            .with_layout(serial)
            .unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let (mut a, mut b) = (Vec::new(), Vec::new());
            obj_serial.hessian_with(x, &[], &mut a, mode).unwrap();
            obj.hessian_with(x, &[], &mut b, mode).unwrap();
            (a, b)
        })
    }

    /// The distortion sums to the same bits with 1, 2 or 3 threads, and to
    /// the serial sum of its chunks.
    #[test]
    fn the_distortion_does_not_depend_on_the_threads() {
        let shape = unfold_mesh::shapes::placenta_slab(&unfold_mesh::shapes::PlacentaParams {
            cells_radial: 10,
            cells_through: 4,
            ..Default::default()
        })
        .unwrap();
        let pm = ParamMesh::from_tets(&shape.mesh).unwrap();
        let x: Vec<f64> = pm
            .rest_flat()
            .iter()
            .enumerate()
            .map(|(i, r)| r * 1.1 + 0.01 * ((i * 7919) % 13) as f64)
            .collect();
        let energy = SymmetricDirichlet;
        let obj = Objective::new(&pm, &energy, 1.0, None, &[]).unwrap();
        let values: Vec<u64> = (1..4)
            .map(|threads| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap()
                    .install(|| obj.distortion(&x).to_bits())
            })
            .collect();
        assert!(values.iter().all(|&v| v == values[0]), "{values:?}");
        let n = pm.num_elements();
        assert!(
            n > 2 * SUM_CHUNK,
            "{n} elements: too few for several chunks"
        );
        let serial: f64 = (0..n.div_ceil(SUM_CHUNK))
            .map(|c| {
                (c * SUM_CHUNK..((c + 1) * SUM_CHUNK).min(n))
                    .map(|k| {
                        let RestElements::Tets { tets, dm_inv } = &pm.elements else {
                            unreachable!()
                        };
                        pm.weight[k] * density3(&energy, &jacobian3(&x, &tets[k], &dm_inv[k]))
                    })
                    .sum::<f64>()
            })
            .sum();
        assert_eq!(values[0], serial.to_bits());
    }

    proptest! {
        /// The vertex Hessian from the modes equals `w C^T H_F C` with the
        /// assembled 9x9 `H_F`, entry by entry (the formula it replaced).
        #[test]
        fn the_vertex_hessian_from_modes_is_the_chain_rule_of_the_assembled_one(
            entries in prop::collection::vec(-2.0..2.0f64, 9),
            rest in prop::collection::vec(-1.0..1.0f64, 9),
            w in 0.1..3.0f64,
            exact in any::<bool>(),
        ) {
            let f = Matrix3::from_column_slice(&entries);
            let dm = Matrix3::identity() + Matrix3::from_column_slice(&rest) * 0.4;
            let Some(dm_inv) = dm.try_inverse() else { return Ok(()) };
            let mode = if exact { HessianMode::Exact } else { HessianMode::Projected };
            let Some(eigen) = hessian3_eigen(&SymmetricDirichlet, &f, mode) else {
                return Ok(());
            };
            let hf = eigen.matrix();
            let p = corner_map::<3, 4>(&dm_inv);
            let mut out = [0.0; 144];
            vertex_hessian3(&eigen, &dm_inv, w, &mut out);
            let scale = hf.norm() * w * dm_inv.norm().powi(2);
            for v in 0..4 {
                for i in 0..3 {
                    for u in 0..4 {
                        for k in 0..3 {
                            let mut reference = 0.0;
                            for j in 0..3 {
                                for l in 0..3 {
                                    reference += p[v][j] * p[u][l] * hf[(i + 3 * j, k + 3 * l)];
                                }
                            }
                            let got = out[12 * (3 * v + i) + 3 * u + k];
                            prop_assert!(
                                (got - w * reference).abs() <= 1e-12 * scale,
                                "({v},{i}),({u},{k}): {got} against {}", w * reference
                            );
                        }
                    }
                }
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(6))]

        /// The parallel assembly (each block's tets summed by one task in
        /// tet order) gives the serial scatter's values bit for bit, with
        /// any fixed set, either Hessian mode and 1 to 3 threads.
        #[test]
        fn parallel_tet_assembly_equals_the_serial_scatter(
            jitter in prop::collection::vec(-1.0..1.0f64, 32),
            fixed_bits in any::<u64>(),
            exact in any::<bool>(),
            threads in 1usize..4,
        ) {
            let (pm, _) = slab();
            let nv = pm.num_vertices();
            let x: Vec<f64> = pm
                .rest_flat()
                .iter()
                .enumerate()
                .map(|(i, r)| r * 1.1 + 0.2 * jitter[(i * 7) % jitter.len()])
                .collect();
            let fixed: Vec<bool> = (0..nv).map(|v| (fixed_bits >> (v % 61)) & 7 == 0).collect();
            let mode = if exact { HessianMode::Exact } else { HessianMode::Projected };
            let (serial, parallel) = assemble_both(&pm, &fixed, &x, mode, threads);
            prop_assert_eq!(serial.len(), parallel.len());
            let scale = serial.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            prop_assert!(scale > 0.0);
            for (k, (a, b)) in serial.iter().zip(&parallel).enumerate() {
                prop_assert!(a.to_bits() == b.to_bits(), "slot {}: {} vs {}", k, a, b);
            }
        }
    }

    #[test]
    fn tet_assembly_is_the_same_for_every_thread_count() {
        let (pm, _) = slab();
        let x: Vec<f64> = pm
            .rest_flat()
            .iter()
            .enumerate()
            .map(|(i, r)| r * (1.0 + 0.01 * (i % 5) as f64))
            .collect();
        let (serial, one) = assemble_both(&pm, &[], &x, HessianMode::Projected, 1);
        let (_, two) = assemble_both(&pm, &[], &x, HessianMode::Projected, 2);
        let (_, four) = assemble_both(&pm, &[], &x, HessianMode::Projected, 4);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&one), bits(&serial));
        assert_eq!(bits(&two), bits(&one));
        assert_eq!(bits(&four), bits(&one));
    }
}
