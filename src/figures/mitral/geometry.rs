//! What every mitral figure shares, checked once: the meshes, the annulus
//! and the free edges, where the 2D map sits in its panel, and the two
//! cameras (the 3D one from the atrium, tilted, anterior up).

use unfold_organs::mitral::{ANTERIOR, Outcome, POSTERIOR};
use unfold_render::nalgebra::{Point3, Vector3};
use unfold_render::{Camera, Lens};

use super::subdivision::{Subdivision, sorted};
use super::{BELOW_MAP, MAP_SIDE, MAP_TOP, MIN_PANEL, VIEW_TILT_DEG, VIEW_TOP};
use crate::figures::{FigureError, FigureOptions};

/// Everything the figures share: meshes, cameras, the 2D layout, anchors.
pub(super) struct Geometry<'a> {
    pub(super) outcome: &'a Outcome,
    pub(super) pw: u32,
    pub(super) ph: u32,
    /// Triangles of both meshes.
    pub(super) triangles: &'a [[u32; 3]],
    /// 3D positions.
    pub(super) p3: &'a [Point3<f64>],
    /// 2D positions `(u, v, 0)`.
    pub(super) p2: &'a [Point3<f64>],
    /// Per leaflet, its annulus vertices in the merged meshes.
    pub(super) annulus: [Vec<u32>; 2],
    /// Boundary edges that are not on the annulus.
    pub(super) free_edges: Vec<[u32; 2]>,
    /// The subdivision for label maps.
    pub(super) sub: Subdivision,
    /// The 2D map: pixels per mm, centre `(u, v)`, area in the panel.
    pub(super) map: MapFrame,
    pub(super) cam2d: Camera,
    pub(super) cam3d: Camera,
    /// Size of the 3D view.
    pub(super) view: (u32, u32),
    /// Width of the legend column at the right of the 3D panel.
    pub(super) legend_w: u32,
}

/// Where the 2D map sits in the left panel.
#[derive(Debug, Clone, Copy)]
pub(super) struct MapFrame {
    /// Pixels per mm.
    pub(super) scale: f64,
    /// `(u, v)` at the centre of the map area.
    pub(super) centre: [f64; 2],
    /// Top-left corner of the map area in the panel.
    pub(super) origin: [i32; 2],
    /// Size of the map area.
    pub(super) size: [u32; 2],
}

impl MapFrame {
    /// Panel pixel coordinates of `(u, v)`.
    pub(super) fn panel_xy(&self, u: f64, v: f64) -> [f64; 2] {
        [
            f64::from(self.origin[0])
                + 0.5 * f64::from(self.size[0])
                + self.scale * (u - self.centre[0]),
            f64::from(self.origin[1]) + 0.5 * f64::from(self.size[1])
                - self.scale * (v - self.centre[1]),
        ]
    }

    /// Row one past the bottom of the map area.
    pub(super) fn bottom(&self) -> i32 {
        self.origin[1] + self.size[1] as i32
    }
}

impl<'a> Geometry<'a> {
    pub(super) fn new(outcome: &'a Outcome, opts: &FigureOptions) -> Result<Self, FigureError> {
        const FIG: &str = "mitral figures";
        let (pw, ph) = (opts.panel_width, opts.panel_height);
        if pw < MIN_PANEL.0 || ph < MIN_PANEL.1 {
            return Err(FigureError::input(
                FIG,
                format!(
                    "panels of {pw} x {ph} pixels are too small (at least {} x {})",
                    MIN_PANEL.0, MIN_PANEL.1
                ),
            ));
        }
        let (m2, m3) = (&outcome.valve2d, &outcome.valve3d);
        if m2.positions.len() != m3.positions.len() || m2.triangles != m3.triangles {
            return Err(FigureError::input(
                FIG,
                "valve2d and valve3d do not have the same vertices and triangles",
            ));
        }
        let n = m3.positions.len();
        let offset = outcome.valve.leaflets[ANTERIOR].mesh.positions.len();
        if offset + outcome.valve.leaflets[POSTERIOR].mesh.positions.len() != n {
            return Err(FigureError::input(
                FIG,
                "the merged meshes do not have the leaflets' vertices",
            ));
        }
        let mut annulus = [Vec::new(), Vec::new()];
        for k in [ANTERIOR, POSTERIOR] {
            let shift = if k == ANTERIOR { 0 } else { offset as u32 };
            let ring: Vec<u32> = outcome.valve.leaflets[k]
                .annulus
                .iter()
                .map(|&v| v + shift)
                .collect();
            if ring.len() < 2 || ring.iter().any(|&v| v as usize >= n) {
                return Err(FigureError::input(
                    FIG,
                    format!("leaflet {k} has no annulus of at least two valid vertices"),
                ));
            }
            annulus[k] = ring;
        }
        if let Some(t) = m3
            .triangles
            .iter()
            .position(|t| t.iter().any(|&v| v as usize >= n))
        {
            return Err(FigureError::input(
                FIG,
                format!("triangle {t} refers to a vertex out of range"),
            ));
        }
        for (what, mesh) in [("valve2d", m2), ("valve3d", m3)] {
            if let Some(i) = mesh
                .positions
                .iter()
                .position(|p| !p.coords.iter().all(|c| c.is_finite()))
            {
                return Err(FigureError::input(
                    FIG,
                    format!("{what} vertex {i} is not finite"),
                ));
            }
        }
        if m3.triangles.is_empty() {
            return Err(FigureError::input(FIG, "the valve has no triangles"));
        }

        // Boundary edges (used by one triangle), minus the annulus edges.
        let mut edges: Vec<[u32; 2]> = m3
            .triangles
            .iter()
            .flat_map(|t| (0..3).map(move |k| sorted([t[k], t[(k + 1) % 3]])))
            .collect();
        edges.sort_unstable();
        let mut ring_edges: Vec<[u32; 2]> = annulus
            .iter()
            .flat_map(|r| r.windows(2).map(|w| sorted([w[0], w[1]])))
            .collect();
        ring_edges.sort_unstable();
        let mut free_edges = Vec::new();
        let mut i = 0;
        while i < edges.len() {
            let mut j = i + 1;
            while j < edges.len() && edges[j] == edges[i] {
                j += 1;
            }
            if j - i == 1 && ring_edges.binary_search(&edges[i]).is_err() {
                free_edges.push(edges[i]);
            }
            i = j;
        }

        // The 2D map: as large as the panel allows, at the top.
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &m2.positions {
            for c in 0..2 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let du = (hi[0] - lo[0]).max(1e-6);
        let dv = (hi[1] - lo[1]).max(1e-6);
        let pad = 4.0;
        let avail_w = f64::from(pw) - 2.0 * f64::from(MAP_SIDE) - 2.0 * pad;
        let avail_h = f64::from(ph) - f64::from(MAP_TOP + BELOW_MAP) - 2.0 * pad;
        let scale = (avail_w / du).min(avail_h / dv);
        let size = [
            pw - 2 * MAP_SIDE as u32,
            ((dv * scale + 2.0 * pad).ceil() as u32).max(1),
        ];
        let centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
        let map = MapFrame {
            scale,
            centre,
            origin: [MAP_SIDE, MAP_TOP],
            size,
        };
        let c2 = Point3::new(centre[0], centre[1], 0.0);
        let cam2d = Camera::orthographic(
            c2 + Vector3::z() * du.max(dv),
            c2,
            Vector3::y(),
            0.5 * f64::from(size[1]) / scale,
        )
        .map_err(FigureError::render(FIG))?;

        // The 3D view: from the atrium, tilted, anterior up.
        let legend_w = (pw * 7 / 20).clamp(110, 180);
        let view = (pw - legend_w, ph - VIEW_TOP as u32);
        let (dir, up) = view_direction(outcome);
        let cam3d = Camera::frame(
            &m3.positions,
            dir,
            up,
            Lens::Perspective {
                fovy: 30f64.to_radians(),
            },
            view.0,
            view.1,
            0.15,
        )
        .map_err(FigureError::render(FIG))?;

        Ok(Geometry {
            outcome,
            pw,
            ph,
            triangles: &m3.triangles,
            p3: &m3.positions,
            p2: &m2.positions,
            annulus,
            free_edges,
            sub: Subdivision::new(&m3.triangles, n),
            map,
            cam2d,
            cam3d,
            view,
            legend_w,
        })
    }

    /// `(u, v)` of vertex `i`.
    pub(super) fn uv(&self, i: u32) -> [f64; 2] {
        let p = self.p2[i as usize];
        [p.x, p.y]
    }
}

/// The view direction and image-up vector of the 3D panel: from the atrium
/// (`-atrium`), tilted by [`VIEW_TILT_DEG`] so the eye moves towards the
/// anterior side, with the anterior side up (the anterolateral commissure
/// then lies on the left, as the ring runs clockwise seen from the atrium).
fn view_direction(outcome: &Outcome) -> (Vector3<f64>, Vector3<f64>) {
    let valve = &outcome.valve;
    let n = {
        let a = valve.atrium;
        let l = a.norm();
        if l > 0.0 && l.is_finite() {
            a / l
        } else {
            Vector3::z()
        }
    };
    let count = valve.ring.len().max(1) as f64;
    let c = valve
        .ring
        .iter()
        .fold(Vector3::zeros(), |s, p| s + p.coords)
        / count;
    // The middle of the anterior arc (ring[0..=posteromedial]).
    let mid = valve
        .ring
        .get(valve.posteromedial / 2)
        .map_or(c, |p| p.coords);
    let d = mid - c;
    let mut a = d - n * n.dot(&d);
    if a.norm().is_nan() || a.norm() <= 1e-9 {
        // Any direction orthogonal to n.
        let e = if n.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        a = e - n * n.dot(&e);
    }
    let a = a.normalize();
    // Negative: the eye moves to the anterior side, so the view shows the
    // posterior leaflet's face and the coaptation zone along its free edge.
    let tilt = (-VIEW_TILT_DEG).to_radians();
    (-n * tilt.cos() + a * tilt.sin(), a)
}
