//! Hessian layouts kept across the solves of a run or a series.
//!
//! An objective's [`HessianLayout`] (the sparsity pattern's fill-reducing
//! ordering and symbolic Cholesky analysis, or the multigrid's plan, and
//! every element's value slots) depends only on the element connectivity,
//! the fixed vertices and the linear solver, not on positions, rest shapes,
//! the energy or the template. The solves of a series on one mesh (the time
//! steps of a valve series, the stages of a placenta flattening, the
//! untangler's stages) can therefore analyse the pattern once: a
//! [`LayoutCache`] hands a fitting layout to each new objective
//! ([`LayoutCache::attach`], [`LayoutCache::reuse`]) and keeps the layouts
//! objectives built ([`LayoutCache::keep`]). A solve with a cached layout
//! gives the same result as one without, bit for bit (the layout is the
//! same data, built by the same code).

use crate::objective::LinearSolver;
use crate::{HessianLayout, Objective, ParamError};
use std::sync::{Arc, Mutex, MutexGuard};

/// One kept layout and, for a multigrid layout (whose background grid is
/// laid over the rest positions), the rest positions it was built on.
#[derive(Debug)]
struct Kept {
    layout: Arc<HessianLayout>,
    rest: Option<Vec<f64>>,
}

impl Kept {
    /// `layout`, built by `objective`, with the objective's rest positions
    /// when it is a multigrid layout.
    fn new(layout: Arc<HessianLayout>, objective: &Objective<'_>) -> Kept {
        Kept {
            rest: layout
                .pattern()
                .multigrid_sizes()
                .map(|_| objective.mesh().rest_flat()),
            layout,
        }
    }
}

/// Hessian layouts keyed by what they were built for (connectivity, fixed
/// vertices, linear solver; for a multigrid layout also the rest
/// positions): an objective that matches one reuses it instead of ordering
/// and analysing its pattern again. Safe to share between threads.
#[derive(Debug, Default)]
pub struct LayoutCache(Mutex<Vec<Kept>>);

impl LayoutCache {
    /// Number of layouts kept.
    pub fn len(&self) -> usize {
        self.lock().len()
    }

    /// Whether no layout is kept.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn lock(&self) -> MutexGuard<'_, Vec<Kept>> {
        // A panic elsewhere cannot leave the list half-written.
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The kept layout that serves `objective`, if any: it
    /// [fits](HessianLayout::fits) the objective's mesh and fixed vertices,
    /// was built for the same linear solver (Cholesky or multigrid), and a
    /// multigrid layout on the same rest positions.
    fn find(list: &[Kept], objective: &Objective<'_>) -> Option<Arc<HessianLayout>> {
        let multigrid = objective.linear_solver() == LinearSolver::Multigrid;
        list.iter()
            .find(|k| {
                k.layout.pattern().multigrid_sizes().is_some() == multigrid
                    && k.layout.fits(objective.mesh(), objective.fixed())
                    && k.rest
                        .as_ref()
                        .is_none_or(|r| *r == objective.mesh().rest_flat())
            })
            .map(|k| Arc::clone(&k.layout))
    }

    /// `objective` with the kept layout that serves it, or unchanged (it
    /// builds its own on first use; [`LayoutCache::keep`] it afterwards).
    /// For solves that may need no Hessian at all (gradient descent).
    ///
    /// # Errors
    /// None in practice: the layout found fits ([`Objective::with_layout`]).
    pub fn reuse<'a>(&self, objective: Objective<'a>) -> Result<Objective<'a>, ParamError> {
        match Self::find(&self.lock(), &objective) {
            Some(layout) => objective.with_layout(layout),
            None => Ok(objective),
        }
    }

    /// Keeps the layout `objective` built or was given, unless one serving
    /// it is kept already; nothing when it has none (no Hessian was
    /// needed).
    pub fn keep(&self, objective: &Objective<'_>) {
        let Some(layout) = objective.layout_if_built() else {
            return;
        };
        let mut list = self.lock();
        if Self::find(&list, objective).is_none() {
            list.push(Kept::new(layout, objective));
        }
    }

    /// `objective` with the kept layout that serves it, or with its own
    /// layout, built now and kept. The lock is held while the layout is
    /// built, so that solves run in parallel (the steps of a series) do not
    /// each build the same layout.
    ///
    /// # Errors
    /// Those of building the layout ([`Objective::layout`]).
    pub fn attach<'a>(&self, mut objective: Objective<'a>) -> Result<Objective<'a>, ParamError> {
        let mut list = self.lock();
        match Self::find(&list, &objective) {
            Some(layout) => objective.with_layout(layout),
            None => {
                let layout = objective.layout()?;
                list.push(Kept::new(layout, &objective));
                Ok(objective)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ParamMesh;
    use crate::energy::SymmetricDirichlet;
    use crate::solver::{Executor, ProjectedNewton, Solver, Stopping};
    use unfold_mesh::shapes::{PlacentaParams, placenta_slab, side};

    /// A small placenta slab's rest data and its fetal and maternal
    /// vertices (held in the solves).
    fn slab(cells_radial: usize) -> (ParamMesh, Vec<bool>) {
        let shape = placenta_slab(&PlacentaParams {
            cells_radial,
            cells_through: 2,
            ..PlacentaParams::default()
        })
        .unwrap();
        let held = shape
            .side
            .iter()
            .map(|&s| s == side::FETAL || s == side::MATERNAL)
            .collect();
        (ParamMesh::from_tets(&shape.mesh).unwrap(), held)
    }

    /// Newton from the slab stretched by `stretch` along z, its held sides
    /// kept there: the positions, bit for bit, and the iterations.
    fn solve(objective: &mut Objective<'_>, pm: &ParamMesh, stretch: f64) -> (Vec<u64>, usize) {
        let mut x = pm.rest_flat();
        for z in x.iter_mut().skip(2).step_by(3) {
            *z *= stretch;
        }
        let report = Executor::new(&ProjectedNewton::default())
            .stopping(Stopping {
                grad_tol: 1e-9,
                ..ProjectedNewton::default().default_stopping()
            })
            .run(objective, &mut x, &mut [])
            .unwrap();
        assert!(report.converged && report.iterations >= 2, "{report:?}");
        (x.iter().map(|v| v.to_bits()).collect(), report.iterations)
    }

    #[test]
    fn a_cached_layout_solves_bit_for_bit_like_a_fresh_one() {
        let (pm, held) = slab(5);
        let cache = LayoutCache::default();
        let new = || Objective::new(&pm, &SymmetricDirichlet, 1.0, None, &held).unwrap();
        for stretch in [1.2, 1.3] {
            let fresh = solve(&mut new(), &pm, stretch);
            // The first frame of a series builds and keeps the layout, the
            // next ones take it.
            let mut cached = cache.attach(new()).unwrap();
            assert_eq!(cache.len(), 1);
            assert_eq!(solve(&mut cached, &pm, stretch), fresh);
            let mut reused = cache.reuse(new()).unwrap();
            assert!(reused.layout_if_built().is_some());
            assert_eq!(solve(&mut reused, &pm, stretch), fresh);
        }
        assert_eq!(cache.len(), 1);
    }

    #[test]
    fn a_layout_for_another_pattern_solver_or_grid_is_not_reused() {
        let (pm, held) = slab(4);
        let cache = LayoutCache::default();
        let first = cache
            .attach(Objective::new(&pm, &SymmetricDirichlet, 1.0, None, &held).unwrap())
            .unwrap()
            .layout_if_built()
            .unwrap();
        let same = |o: Objective<'_>| o.layout_if_built().is_some_and(|l| Arc::ptr_eq(&l, &first));
        // Another fixed set, another connectivity: layouts of their own.
        let o = cache
            .attach(Objective::new(&pm, &SymmetricDirichlet, 1.0, None, &[]).unwrap())
            .unwrap();
        assert!(!same(o));
        assert_eq!(cache.len(), 2);
        let (other, other_held) = slab(5);
        let o = cache
            .reuse(Objective::new(&other, &SymmetricDirichlet, 1.0, None, &other_held).unwrap())
            .unwrap();
        assert!(o.layout_if_built().is_none(), "nothing fits: no layout yet");
        // The same mesh solved by multigrid: not the Cholesky layout.
        let mut mg = Objective::new(&pm, &SymmetricDirichlet, 1.0, None, &held).unwrap();
        mg.set_linear_solver(LinearSolver::Multigrid);
        let mg = cache.attach(mg).unwrap();
        assert!(
            mg.layout_if_built()
                .unwrap()
                .pattern()
                .multigrid_sizes()
                .is_some()
        );
        assert_eq!(cache.len(), 3);
        // A multigrid layout is laid over the rest positions: a mesh with
        // the same connectivity elsewhere gets its own.
        let mut moved = pm.clone();
        for p in &mut moved.rest {
            p.x *= 2.0;
        }
        let mut mg2 = Objective::new(&moved, &SymmetricDirichlet, 1.0, None, &held).unwrap();
        mg2.set_linear_solver(LinearSolver::Multigrid);
        cache.attach(mg2).unwrap();
        assert_eq!(cache.len(), 4);
        // The Cholesky layout serves the moved mesh (positions do not
        // matter to it).
        let o = cache
            .reuse(Objective::new(&moved, &SymmetricDirichlet, 1.0, None, &held).unwrap())
            .unwrap();
        assert!(same(o));
    }

    #[test]
    fn keep_takes_only_a_built_layout() {
        let (pm, held) = slab(4);
        let cache = LayoutCache::default();
        let mut o = cache
            .reuse(Objective::new(&pm, &SymmetricDirichlet, 1.0, None, &held).unwrap())
            .unwrap();
        // Values and gradients only (gradient descent): nothing to keep.
        let x = pm.rest_flat();
        let mut g = vec![0.0; x.len()];
        o.value_gradient(&x, &[], &mut g);
        cache.keep(&o);
        assert!(cache.is_empty());
        o.hessian(&x, &[], &mut Vec::new()).unwrap();
        cache.keep(&o);
        cache.keep(&o);
        assert_eq!(cache.len(), 1);
        let built = o.layout_if_built().unwrap();
        let next = cache
            .reuse(Objective::new(&pm, &SymmetricDirichlet, 1.0, None, &held).unwrap())
            .unwrap();
        assert!(Arc::ptr_eq(&next.layout_if_built().unwrap(), &built));
    }
}
