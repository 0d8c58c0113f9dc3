//! The mitral valve pipeline as a value (ALGORITHMS 4): built from its
//! pieces, run on one valve or a time series.

use super::initializer::LeafletLayout;
use super::relax::{self, default_solver};
use super::{
    ANTERIOR, AnnulusError, AnnulusMode, CoaptationCounts, Config, DistortionReport, LayoutError,
    Leaflet, LeafletSide, Outcome, POSTERIOR, Pieces, PlaneReport, RelaxMode, Report, Timings,
    ValveInput, annulus, contract, layout, maps, merged,
};
use crate::OrganError;
use std::time::Instant;
use unfold_mesh::geometry::flipped_triangles;
use unfold_mesh::nalgebra::Point3;
use unfold_param::energy::SymmetricDirichlet;
use unfold_param::{
    Constraints, DistortionEnergy, Initializer, LineSearch, ParamError, ParamMesh, Pin, Solver,
};

/// The mitral pipeline: its pieces and settings. [`Pipeline::new`] is the
/// published method (ALGORITHMS 4): the leaflet layout of
/// [`LeafletLayout`] (longitudes when the leaflets have them, else Tutte),
/// relaxed by minimizing the symmetric Dirichlet energy with projected
/// Newton ([`relax::default_solver`]) and its Armijo line search. Each
/// piece can be replaced:
///
/// ```text
/// Pipeline::new()
///     .energy(Amips)                                   // any DistortionEnergy
///     .initializer(LeafletLayout { mode: InitMode::Tutte })  // any Initializer
///     .line_search(Backtracking::paper())              // any LineSearch
///     .solver(GradientDescent)                         // any Solver
///     .config(Config { cut_posteromedial: true, ..Config::default() })
///     .run(&valve)?
/// ```
///
/// The energy, solver and line search act when `config.relax` is
/// [`RelaxMode::Sd`] (the default: flip-free minimization); the spring
/// baseline uses none of them.
#[derive(Debug)]
pub struct Pipeline {
    energy: Box<dyn DistortionEnergy>,
    initializer: Box<dyn Initializer>,
    line_search: Option<Box<dyn LineSearch>>,
    solver: Box<dyn Solver>,
    config: Config,
}

impl Default for Pipeline {
    fn default() -> Self {
        Pipeline {
            energy: Box::new(SymmetricDirichlet),
            initializer: Box::new(LeafletLayout::default()),
            line_search: None,
            solver: Box::new(default_solver()),
            config: Config::default(),
        }
    }
}

/// How far a pinned annulus vertex may be from its target, relative to the
/// larger of 1 and the target's norm.
const PIN_TOLERANCE: f64 = 1e-9;

impl Pipeline {
    /// The published pipeline (see the type's documentation).
    pub fn new() -> Self {
        Self::default()
    }

    /// The relaxation's distortion energy `D`.
    pub fn energy(mut self, energy: impl DistortionEnergy + 'static) -> Self {
        self.energy = Box::new(energy);
        self
    }

    /// Each leaflet's initial layout (see [`super::initializer`] for what it
    /// is handed).
    pub fn initializer(mut self, initializer: impl Initializer + 'static) -> Self {
        self.initializer = Box::new(initializer);
        self
    }

    /// The line search (default: the solver's own).
    pub fn line_search(mut self, line_search: impl LineSearch + 'static) -> Self {
        self.line_search = Some(Box::new(line_search));
        self
    }

    /// The relaxation's solver.
    pub fn solver(mut self, solver: impl Solver + 'static) -> Self {
        self.solver = Box::new(solver);
        self
    }

    /// The numeric settings and modes.
    pub fn config(mut self, config: Config) -> Self {
        self.config = config;
        self
    }

    /// The settings in use.
    pub fn settings(&self) -> &Config {
        &self.config
    }

    /// Runs the whole pipeline on one valve (see the module docs).
    ///
    /// # Errors
    /// [`OrganError::Config`] for bad settings; [`OrganError::Mitral`] when
    /// the inputs do not fit a step ([`super::ContractError`]: leaflets not
    /// touching the ring, wrong number of commissures, non-disk leaflets,
    /// ...; [`LayoutError::NoLongitudes`] for longitudes on a leaflet
    /// without them; [`LayoutError::PinMoved`] for an initializer that
    /// moved the annulus; ...); [`OrganError::Mesh`] / [`OrganError::Param`]
    /// when a mesh check or a solve fails.
    pub fn run(&self, input: &ValveInput<'_>) -> Result<Outcome, OrganError> {
        self.run_cached(input, None)
    }

    /// Runs the pipeline on every step of a time series (ALGORITHMS 4.6),
    /// in parallel, each step exactly as [`Pipeline::run`] would (the same
    /// result, bit for bit); the results come in the order of `inputs`.
    /// Steps whose leaflets have the connectivity and annulus of an earlier
    /// one share its Newton Hessian layout ([`relax::LayoutCache`]: the
    /// ordering and symbolic analysis are done once per distinct leaflet),
    /// as the steps of one recording often do.
    pub fn run_series(&self, inputs: &[ValveInput<'_>]) -> Vec<Result<Outcome, OrganError>> {
        use rayon::prelude::*;
        let cache = relax::LayoutCache::default();
        inputs
            .par_iter()
            .map(|input| self.run_cached(input, Some(&cache)))
            .collect()
    }

    /// Leaflet `k`'s initial layout: the initializer with the annulus
    /// pinned at its `(u, v)` targets, checked (length, pins); with the
    /// layout's name for the report.
    fn layout(
        &self,
        leaflet: &Leaflet,
        k: usize,
        amap: &annulus::AnnulusMap,
    ) -> Result<(Vec<[f64; 2]>, &'static str), OrganError> {
        let targets = layout::annulus_uv(leaflet, amap);
        let n = leaflet.mesh.positions.len();
        let pm = ParamMesh::from_triangles(&leaflet.mesh)?;
        let pins: Vec<Pin> = leaflet
            .annulus
            .iter()
            .zip(&targets)
            .map(|(&v, &q)| Pin::planar(v, q))
            .collect();
        let labels = vec![k as u8; n];
        let start = self
            .initializer
            .initialize(
                &pm,
                &Constraints {
                    pins: &pins,
                    labels: &labels,
                    weights: &[],
                },
            )
            .map_err(OrganError::from_param)?;
        if start.x.len() != 2 * n {
            return Err(ParamError::Length {
                what: "initial layout",
                expected: 2 * n,
                found: start.x.len(),
            }
            .into());
        }
        let uv: Vec<[f64; 2]> = start.x.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
        for pin in &pins {
            let (q, t) = (uv[pin.vertex as usize], pin.position);
            let distance = (q[0] - t[0]).hypot(q[1] - t[1]);
            if distance.is_nan() || distance > PIN_TOLERANCE * t[0].hypot(t[1]).max(1.0) {
                return Err(LayoutError::PinMoved {
                    leaflet: LeafletSide::of(k),
                    vertex: pin.vertex,
                    distance,
                }
                .into());
            }
        }
        Ok((
            uv,
            start.detail("layout").unwrap_or(self.initializer.name()),
        ))
    }

    fn run_cached(
        &self,
        input: &ValveInput<'_>,
        cache: Option<&relax::LayoutCache>,
    ) -> Result<Outcome, OrganError> {
        let config = &self.config;
        let start = Instant::now();
        config.validate()?;
        let mut timings = Timings::default();
        let t = Instant::now();
        let (repaired, repair) =
            super::leaflet_repair::repair_leaflets(input.anterior, input.posterior)?;
        let input = &ValveInput {
            anterior: &repaired[ANTERIOR],
            posterior: &repaired[POSTERIOR],
            annulus: input.annulus,
        };
        let valve = contract::prepare(input, config.tolerance_mm)?;
        timings.contract = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let amap = annulus::parameterize(&valve, config.annulus_mode)?;
        // Tenting, the saddle-horn height and the areas above / below are
        // measured from the least-squares plane of the annulus whatever the
        // layout mode: the landmark plane (through the two low commissures and
        // the posterior barycentre) tilts towards the posterior, and would show
        // a healthy anterior leaflet as prolapsing.
        let plane = annulus::plane(&valve, AnnulusMode::LeastSquares)?
            .ok_or(AnnulusError::NoLeastSquaresPlane)?;

        // Each leaflet's layout below the annulus, in parallel.
        let layout_one = |k: usize| self.layout(&valve.leaflets[k], k, &amap);
        let (la, lp) = rayon::join(|| layout_one(ANTERIOR), || layout_one(POSTERIOR));
        let ((uv_a, init_a), (uv_p, init_p)) = (la?, lp?);
        let mut uv: [Vec<[f64; 2]>; 2] = [uv_a, uv_p];
        let init = [init_a, init_p];
        timings.layout = t.elapsed().as_secs_f64();
        let t = Instant::now();

        // The leaflets relax independently (each with its annulus pinned): in
        // parallel, each with the energies of its initial layout, then its
        // coaptation distances (3D only, parallel over the vertices: the
        // leaflet that relaxes first starts them, the other joins in).
        type Relaxed = (relax::RelaxReport, [Vec<f64>; 3], Vec<f64>);
        let relax_one = |k: usize, uv: &mut Vec<[f64; 2]>| -> Result<Relaxed, OrganError> {
            let leaflet = &valve.leaflets[k];
            let initial = maps::leaflet_energies(&leaflet.mesh, k, uv)?;
            let mut fixed = vec![false; leaflet.mesh.positions.len()];
            for &v in &leaflet.annulus {
                fixed[v as usize] = true;
            }
            let report = match config.relax {
                RelaxMode::Spring => relax::spring(&leaflet.mesh, uv, &fixed, &config.spring),
                RelaxMode::Sd => relax::minimize(
                    &leaflet.mesh,
                    uv,
                    &fixed,
                    &config.sd,
                    &relax::Minimizer {
                        energy: self.energy.as_ref(),
                        solver: self.solver.as_ref(),
                        line_search: self.line_search.as_deref(),
                    },
                    cache,
                ),
            }?;
            Ok((report, initial, maps::coaptation_distances(&valve, k)))
        };
        let [uv_a, uv_p] = &mut uv;
        let (ra, rp) = rayon::join(|| relax_one(ANTERIOR, uv_a), || relax_one(POSTERIOR, uv_p));
        let ((report_a, initial_a, dist_a), (report_p, initial_p, dist_p)) = (ra?, rp?);
        let relax_reports = [report_a, report_p];
        let initial = maps::summarize(
            [&initial_a, &initial_p]
                .into_iter()
                .map(|[a, m, l]| [&a[..], m, l]),
        );
        timings.relax = t.elapsed().as_secs_f64();
        let t = Instant::now();
        if config.cut_posteromedial {
            for q in &mut uv[POSTERIOR] {
                q[0] += config.cut_gap_mm;
            }
        }
        let leaflet_maps = maps::leaflet_maps_with(
            &valve,
            [&uv[ANTERIOR], &uv[POSTERIOR]],
            &plane,
            &config.maps,
            [dist_a, dist_p],
        )?;
        let final_distortion = maps::summary(&leaflet_maps);
        let (m, (valve3d, valve2d)) = rayon::join(
            || maps::measurements(&valve, &plane),
            || {
                rayon::join(
                    || merged(&valve, &uv, &leaflet_maps, false),
                    || merged(&valve, &uv, &leaflet_maps, true),
                )
            },
        );
        let (valve3d, valve2d) = (valve3d?, valve2d?);

        let flipped = [ANTERIOR, POSTERIOR]
            .iter()
            .map(|&k| flipped_triangles(&uv[k], &valve.leaflets[k].mesh.triangles))
            .sum();
        let folded: usize = [ANTERIOR, POSTERIOR]
            .iter()
            .map(|&k| {
                unfold_mesh::geometry::folded_edges(&uv[k], &valve.leaflets[k].mesh.triangles).len()
            })
            .sum();
        let overlapping: usize = [ANTERIOR, POSTERIOR]
            .iter()
            .map(|&k| {
                unfold_mesh::geometry::boundary_edge_crossings(
                    &uv[k],
                    &valve.leaflets[k].mesh.triangles,
                )
                .edges_involved
            })
            .sum();
        let mut carpentier = [0usize; 6];
        let (mut within, mut near) = (0, 0);
        for lm in &leaflet_maps {
            for &c in &lm.carpentier {
                if (1..=6).contains(&c) {
                    carpentier[(c - 1) as usize] += 1;
                }
            }
            within += lm.coaptation.iter().filter(|&&c| c == 2).count();
            near += lm.coaptation.iter().filter(|&&c| c == 1).count();
        }
        timings.maps = t.elapsed().as_secs_f64();
        let pt = |p: &Point3<f64>| [p.x, p.y, p.z];
        let mut report = Report {
            repair,
            annulus_length_mm: m.annulus_length_mm,
            u_extent_mm: amap.u_extent(),
            leaflet_area_mm2: m.leaflet_area_mm2,
            saddle_horn_height_mm: m.saddle_horn_height_mm,
            area_above_plane_mm2: m.area_above_plane_mm2,
            area_below_plane_mm2: m.area_below_plane_mm2,
            distortion: DistortionReport {
                initial,
                r#final: final_distortion,
            },
            flipped_triangles: flipped,
            folded_edges: folded,
            overlapping_boundary_edges: overlapping,
            relax: match config.relax {
                RelaxMode::Spring => "spring".into(),
                RelaxMode::Sd => "sd".into(),
            },
            init: init.map(std::borrow::Cow::Borrowed),
            pieces: Pieces {
                energy: self.energy.name().into(),
                initializer: self.initializer.name().into(),
                line_search: match &self.line_search {
                    Some(l) => l.name().into(),
                    None => self.solver.default_line_search().name().into(),
                },
                solver: self.solver.name().into(),
            },
            annulus_mode: config.annulus_mode,
            relax_reports,
            coaptation_vertices: CoaptationCounts {
                within,
                near,
                threshold_mm: config.maps.coaptation_mm,
            },
            carpentier_vertices: carpentier,
            commissures_mm: [pt(&valve.ring[0]), pt(&valve.ring[valve.posteromedial])],
            layout_plane: amap.plane.map(|p| PlaneReport {
                point: pt(&p.point),
                normal: [p.normal.x, p.normal.y, p.normal.z],
            }),
            annulus_plane: PlaneReport {
                point: pt(&plane.point),
                normal: [plane.normal.x, plane.normal.y, plane.normal.z],
            },
            cut_posteromedial: config.cut_posteromedial,
            seconds: 0.0,
            timings,
            gates: Default::default(),
        };
        report.gates = super::gates::check(&report, config.relax)?;
        report.seconds = start.elapsed().as_secs_f64();
        Ok(Outcome {
            valve,
            annulus: amap,
            uv,
            valve3d,
            valve2d,
            maps: leaflet_maps,
            report,
        })
    }
}
