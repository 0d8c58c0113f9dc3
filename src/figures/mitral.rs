//! Figures of the mitral valve pipeline (ALGORITHMS 4.4 and 4.5): one
//! figure per map the pipeline writes, `map_<array>.png`.
//!
//! Every figure has two panels of [`FigureOptions`] size side by side (so it
//! is exactly `2 panel_width x panel_height`):
//!
//! - left, the 2D map (`valve2d`): an orthographic top view with `u` to the
//!   right and `v` up, in mm (the annulus along the top, the leaflets
//!   below), unlit colours; the annulus as a thick dark line
//!   ([`ANNULUS_COLOR`]), the rest of the leaflets' boundary in grey, a
//!   dashed vertical line at `u = 0` (the anterolateral commissure, where
//!   the ring is cut), the commissures named above the annulus (AL, PM,
//!   AL), the leaflets named below the map, a scale bar in mm and the
//!   valve's measurements;
//! - right, the 3D valve (`valve3d`) in perspective, seen from the atrium
//!   with the anterior leaflet up and the anterolateral commissure on the
//!   left (as in the surgeon's view), tilted by 20 degrees towards the
//!   anterior side so the posterior leaflet and the coaptation zone along
//!   its free edge face the viewer; smooth shading, the same colours, the
//!   annulus highlighted where visible, the commissures and leaflets named;
//!   and the legend: a colour bar (array name, unit, ticks, mean and range)
//!   or, for label maps, one swatch per label with its count where known.
//!
//! Label maps (leaflet, u intervals, checkerboard, Carpentier segments,
//! coaptation) use categorical colours and are drawn crisply: every
//! triangle is split into the three regions nearest its corners, each in
//! its corner's label colour, so no colour between two labels appears.
//! Continuous per-vertex maps are interpolated, per-triangle maps constant
//! per triangle. Colours follow ALGORITHMS 4.4 / 4.5: energies white at 2
//! and red at the source's thresholds (the area energy blue where the
//! triangle shrank, red where it grew), tenting white at <= -3 mm, yellow at
//! 0 and red at >= +3 mm, coaptation green (zone) / yellow (near) / white,
//! the anterior leaflet blue and the posterior red, the distance to the
//! other leaflet on viridis.

use std::collections::HashMap;

use unfold_mesh::{Field, FieldValues, TriMesh};
use unfold_organs::mitral::maps::{A1, COAPTATION_NONE};
use unfold_organs::mitral::{ANTERIOR, Outcome, POSTERIOR};
use unfold_render::nalgebra::{Point3, Vector3};
use unfold_render::{
    Anchor, Camera, ColorScale, Coloring, Colormap, Image, Lens, NAN_COLOR, Renderer, Rgb, Rgba,
    Shading, format_value, text_width,
};

use super::{Figure, FigureError, FigureOptions};

/// Colour of the annulus highlight in both panels (a thick dark line).
pub const ANNULUS_COLOR: Rgba = Rgba::new(30, 30, 30, 255);

/// Colour of the rest of the leaflets' boundary (free edges, commissure
/// sides).
pub const OUTLINE_COLOR: Rgba = Rgba::new(128, 128, 128, 255);

/// Coaptation colours by label ([`COAPTATION_NONE`], `COAPTATION_NEAR`,
/// `COAPTATION_WITHIN`): white, yellow, green (ALGORITHMS 4.5).
pub const COAPTATION_COLORS: [Rgb; 3] = [
    Rgb::new(255, 255, 255),
    Rgb::new(250, 200, 20),
    Rgb::new(30, 160, 70),
];

/// Carpentier segment colours, A1, A2, A3 (anterior, cool colours) then
/// P1, P2, P3 (posterior, warm colours).
pub const CARPENTIER_COLORS: [Rgb; 6] = [
    Rgb::new(78, 121, 167),
    Rgb::new(118, 183, 178),
    Rgb::new(89, 161, 79),
    Rgb::new(225, 87, 89),
    Rgb::new(242, 142, 43),
    Rgb::new(237, 201, 72),
];

/// Leaflet colours: anterior blue, posterior red (ALGORITHMS 4.5).
pub const LEAFLET_COLORS: [Rgb; 2] = [Rgb::new(40, 100, 200), Rgb::new(210, 40, 40)];

/// Checkerboard colours (labels 0 and 1).
pub const CHECKER_COLORS: [Rgb; 2] = [Rgb::new(235, 235, 235), Rgb::new(80, 80, 80)];

/// Smallest accepted panel, pixels (the legends and labels need room).
pub const MIN_PANEL: (u32, u32) = (300, 240);

const INK: Rgba = Rgba::BLACK;
const PAPER: Rgba = Rgba::WHITE;
/// Top band of each panel left for the figure title.
const TITLE_BAND: i32 = 24;
/// Row of the panel subtitles.
const SUBTITLE_Y: i32 = 28;
/// Rows of the labels above the 2D annulus.
const LABEL_Y: [i32; 2] = [42, 52];
/// Top of the 2D map area.
const MAP_TOP: i32 = 66;
/// Left and right margin of the 2D map area.
const MAP_SIDE: i32 = 22;
/// Room kept below the 2D map (leaflet names, scale bar, measurements).
const BELOW_MAP: i32 = 86;
/// Top of the 3D view area.
const VIEW_TOP: i32 = 40;
/// Tilt of the 3D view from the atrial normal towards the anterior side,
/// degrees.
const VIEW_TILT_DEG: f64 = 20.0;

/// All figures of one mitral outcome: `map_<array>.png` for the
/// distortion maps of ALGORITHMS 4.4 (`area_energy`, `angle_energy`,
/// `length_energy`) and the clinical maps of 4.5 (`leaflet`, `u_gradient`,
/// `u_interval`, `checker`, `carpentier`, `coaptation`,
/// `coaptation_distance_mm`, `tenting_mm`), in that order. Each is
/// `2 panel_width x panel_height`: the 2D map beside the 3D view (see the
/// module documentation).
///
/// # Errors
/// [`FigureError::Input`] when a panel is smaller than [`MIN_PANEL`], the
/// 2D and 3D meshes do not match the leaflets, an array is missing or has
/// the wrong length, or the annulus has fewer than two vertices per
/// leaflet; [`FigureError::Render`] when the renderer refuses something
/// (non-finite positions, sizes above its limit).
pub fn figures(outcome: &Outcome, opts: &FigureOptions) -> Result<Vec<Figure>, FigureError> {
    let geo = Geometry::new(outcome, opts)?;
    let specs = map_specs(outcome, &geo)?;
    specs
        .into_iter()
        .map(|spec| {
            let name = format!("map_{}.png", spec.array);
            let image = compose(&geo, &spec, &name)?;
            Ok(Figure { name, image })
        })
        .collect()
}

/// How one map is coloured and explained.
struct MapSpec {
    /// The array name (point or cell data of `valve2d` / `valve3d`).
    array: &'static str,
    /// The figure title.
    title: String,
    /// One colour per vertex or per triangle.
    colors: Vec<Rgb>,
    /// How `colors` is attached to the mesh.
    layout: Layout,
    /// The legend beside the 3D view.
    legend: Legend,
    /// Whether to write the Carpentier segment names on the map.
    segment_names: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Layout {
    /// Per-vertex labels: crisp regions around each vertex.
    VertexLabels,
    /// Per-vertex continuous colours, interpolated.
    Vertex,
    /// Per-triangle colours.
    Cell,
}

/// A legend: a colour bar or label swatches.
enum Legend {
    /// A vertical colour bar from `t = 0` (bottom) to `t = 1` (top).
    Bar {
        /// Title lines (array name, unit).
        title: Vec<String>,
        /// The colour at `t` in [0, 1].
        color: Box<dyn Fn(f64) -> Rgb>,
        /// Tick positions `t` and their labels.
        ticks: Vec<(f64, String)>,
        /// Lines below the bar (mean, range, ...).
        notes: Vec<String>,
    },
    /// One swatch per label.
    Swatches {
        /// Title lines.
        title: Vec<String>,
        /// Colour and text of each label.
        entries: Vec<(Rgb, String)>,
        /// Lines below the swatches.
        notes: Vec<String>,
    },
}

/// Everything the figures share: meshes, cameras, the 2D layout, anchors.
struct Geometry<'a> {
    outcome: &'a Outcome,
    pw: u32,
    ph: u32,
    /// Triangles of both meshes.
    triangles: &'a [[u32; 3]],
    /// 3D positions.
    p3: &'a [Point3<f64>],
    /// 2D positions `(u, v, 0)`.
    p2: &'a [Point3<f64>],
    /// Per leaflet, its annulus vertices in the merged meshes.
    annulus: [Vec<u32>; 2],
    /// Boundary edges that are not on the annulus.
    free_edges: Vec<[u32; 2]>,
    /// The subdivision for label maps.
    sub: Subdivision,
    /// The 2D map: pixels per mm, centre `(u, v)`, area in the panel.
    map: MapFrame,
    cam2d: Camera,
    cam3d: Camera,
    /// Size of the 3D view.
    view: (u32, u32),
    /// Width of the legend column at the right of the 3D panel.
    legend_w: u32,
}

/// Where the 2D map sits in the left panel.
#[derive(Debug, Clone, Copy)]
struct MapFrame {
    /// Pixels per mm.
    scale: f64,
    /// `(u, v)` at the centre of the map area.
    centre: [f64; 2],
    /// Top-left corner of the map area in the panel.
    origin: [i32; 2],
    /// Size of the map area.
    size: [u32; 2],
}

impl MapFrame {
    /// Panel pixel coordinates of `(u, v)`.
    fn panel_xy(&self, u: f64, v: f64) -> [f64; 2] {
        [
            f64::from(self.origin[0])
                + 0.5 * f64::from(self.size[0])
                + self.scale * (u - self.centre[0]),
            f64::from(self.origin[1]) + 0.5 * f64::from(self.size[1])
                - self.scale * (v - self.centre[1]),
        ]
    }

    /// Row one past the bottom of the map area.
    fn bottom(&self) -> i32 {
        self.origin[1] + self.size[1] as i32
    }
}

impl<'a> Geometry<'a> {
    fn new(outcome: &'a Outcome, opts: &FigureOptions) -> Result<Self, FigureError> {
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
    fn uv(&self, i: u32) -> [f64; 2] {
        let p = self.p2[i as usize];
        [p.x, p.y]
    }
}

fn sorted(e: [u32; 2]) -> [u32; 2] {
    if e[0] <= e[1] { e } else { [e[1], e[0]] }
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

/// Each triangle split into the three regions nearest its corners (two
/// triangles each, through the edge midpoints and the centroid), for crisp
/// per-vertex labels.
struct Subdivision {
    /// Per new vertex: the barycentric combination of old vertices (1, 2 or
    /// 3 of them, equal weights).
    points: Vec<Vec<u32>>,
    /// The new triangles.
    triangles: Vec<[u32; 3]>,
    /// The old vertex whose label each new triangle takes.
    corner: Vec<u32>,
}

impl Subdivision {
    fn new(triangles: &[[u32; 3]], n: usize) -> Self {
        let mut points: Vec<Vec<u32>> = (0..n as u32).map(|i| vec![i]).collect();
        let mut mids: HashMap<[u32; 2], u32> = HashMap::new();
        let mut out = Vec::with_capacity(6 * triangles.len());
        let mut corner = Vec::with_capacity(6 * triangles.len());
        for t in triangles {
            let mut mid = |a: u32, b: u32, points: &mut Vec<Vec<u32>>| {
                *mids.entry(sorted([a, b])).or_insert_with(|| {
                    points.push(vec![a, b]);
                    (points.len() - 1) as u32
                })
            };
            let m01 = mid(t[0], t[1], &mut points);
            let m12 = mid(t[1], t[2], &mut points);
            let m20 = mid(t[2], t[0], &mut points);
            points.push(t.to_vec());
            let g = (points.len() - 1) as u32;
            for (v, next, prev) in [(t[0], m01, m20), (t[1], m12, m01), (t[2], m20, m12)] {
                out.push([v, next, g]);
                out.push([v, g, prev]);
                corner.push(v);
                corner.push(v);
            }
        }
        Subdivision {
            points,
            triangles: out,
            corner,
        }
    }

    /// The new vertices' positions.
    fn positions(&self, p: &[Point3<f64>]) -> Vec<Point3<f64>> {
        self.points
            .iter()
            .map(|ids| {
                let s = ids
                    .iter()
                    .fold(Vector3::zeros(), |s, &i| s + p[i as usize].coords);
                Point3::from(s / ids.len() as f64)
            })
            .collect()
    }
}

/// Per-element values of `array`: point data (one per vertex) or cell data
/// (one per triangle), `components` each.
fn array_values(
    mesh: &TriMesh,
    array: &str,
    cell: bool,
    components: usize,
    figure: &str,
) -> Result<Vec<f64>, FigureError> {
    let (fields, n, kind) = if cell {
        (&mesh.cell_data, mesh.triangles.len(), "cell")
    } else {
        (&mesh.point_data, mesh.positions.len(), "point")
    };
    let field: &Field = fields.get(array).ok_or_else(|| {
        FigureError::input(figure, format!("valve2d has no {kind} array {array}"))
    })?;
    if field.components() != components || field.tuples() != n {
        return Err(FigureError::input(
            figure,
            format!(
                "{kind} array {array} has {} tuples of {} components, expected {n} of {components}",
                field.tuples(),
                field.components()
            ),
        ));
    }
    Ok(match field.values() {
        FieldValues::F64(v) => v.clone(),
        other => other.to_f64(),
    })
}

/// Label colours: `entries[value - first]`, grey for other values.
fn label_colors(values: &[f64], first: i32, palette: &[Rgb]) -> Vec<Rgb> {
    values
        .iter()
        .map(|&v| {
            let k = v - f64::from(first);
            if k >= 0.0 && (k as usize) < palette.len() && k.fract() == 0.0 {
                palette[k as usize]
            } else {
                NAN_COLOR
            }
        })
        .collect()
}

/// Mean and range of the finite values, and the count of infinite ones.
fn stats(values: &[f64]) -> Vec<String> {
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    let mut out = Vec::new();
    if !finite.is_empty() {
        let mean = finite.iter().sum::<f64>() / finite.len() as f64;
        let lo = finite.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        out.push(format!("mean {}", format_value(mean)));
        out.push(format!("min {}", format_value(lo)));
        out.push(format!("max {}", format_value(hi)));
    }
    let inf = values.iter().filter(|v| v.is_infinite()).count();
    if inf > 0 {
        out.push(format!("{inf} infinite (flipped)"));
    }
    out
}

/// White at `t = 0` to the red end of the blue-red map at `t = 1`.
fn white_red(t: f64) -> Rgb {
    Colormap::BlueRed.eval(0.5 + 0.5 * t.clamp(0.0, 1.0))
}

/// The tenting colours: white, yellow at 0.5, red at 1.
fn tenting_color(t: f64) -> Rgb {
    let (white, yellow, red) = (
        Rgb::new(255, 255, 255),
        Rgb::new(250, 215, 30),
        Rgb::new(215, 30, 30),
    );
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    if t <= 0.5 {
        white.lerp(yellow, 2.0 * t)
    } else {
        yellow.lerp(red, 2.0 * t - 1.0)
    }
}

/// An energy map with minimum 2: white at <= 2, red at >= `red`.
fn energy_spec(
    geo: &Geometry<'_>,
    array: &'static str,
    cell: bool,
    title: &str,
    symbol: &str,
    red: f64,
) -> Result<MapSpec, FigureError> {
    let values = array_values(&geo.outcome.valve2d, array, cell, 1, array)?;
    let colors = values
        .iter()
        .map(|&e| {
            if e.is_nan() {
                NAN_COLOR
            } else {
                white_red((e - 2.0) / (red - 2.0))
            }
        })
        .collect();
    let mut notes = stats(&values);
    notes.insert(0, "(no unit)".into());
    Ok(MapSpec {
        array,
        title: title.into(),
        colors,
        layout: if cell { Layout::Cell } else { Layout::Vertex },
        legend: Legend::Bar {
            title: vec![array.into(), symbol.into()],
            color: Box::new(white_red),
            ticks: vec![
                (0.0, "<= 2".into()),
                (0.5, format_value(0.5 * (2.0 + red))),
                (1.0, format!(">= {}", format_value(red))),
            ],
            notes,
        },
        segment_names: false,
    })
}

/// The area energy, signed: blue where the 2D triangle is smaller than the
/// 3D one, red where larger; white at 2, full colour at >= 3.
fn area_spec(geo: &Geometry<'_>) -> Result<MapSpec, FigureError> {
    let array = "area_energy";
    let values = array_values(&geo.outcome.valve2d, array, true, 1, array)?;
    let area = |p: &[Point3<f64>], t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| p[i as usize]);
        (b - a).cross(&(c - a)).norm()
    };
    let colors = values
        .iter()
        .zip(geo.triangles)
        .map(|(&e, t)| {
            if e.is_nan() {
                return NAN_COLOR;
            }
            let m = ((e - 2.0) / (3.0 - 2.0)).clamp(0.0, 1.0);
            let shrunk = area(geo.p2, t) < area(geo.p3, t);
            Colormap::BlueRed.eval(if shrunk { 0.5 - 0.5 * m } else { 0.5 + 0.5 * m })
        })
        .collect();
    let mut notes = stats(&values);
    notes.insert(0, "(no unit)".into());
    Ok(MapSpec {
        array,
        title: "Area distortion A2/A3 + A3/A2 (area_energy)".into(),
        colors,
        layout: Layout::Cell,
        legend: Legend::Bar {
            title: vec![
                array.into(),
                "A2, A3: 2D, 3D triangle area".into(),
                "blue: shrunk in 2D".into(),
                "red: enlarged".into(),
            ],
            color: Box::new(|t| Colormap::BlueRed.eval(t)),
            ticks: vec![
                (0.0, ">= 3".into()),
                (0.5, "2".into()),
                (1.0, ">= 3".into()),
            ],
            notes,
        },
        segment_names: false,
    })
}

fn map_specs(outcome: &Outcome, geo: &Geometry<'_>) -> Result<Vec<MapSpec>, FigureError> {
    let m2 = &outcome.valve2d;
    let mut specs = vec![
        area_spec(geo)?,
        energy_spec(
            geo,
            "angle_energy",
            true,
            "Angle distortion, MIPS (angle_energy)",
            "E_M, min 2",
            5.0,
        )?,
        energy_spec(
            geo,
            "length_energy",
            false,
            "Length distortion per vertex (length_energy)",
            "E_l, min 2",
            2.2,
        )?,
    ];

    // Leaflet identity.
    let leaflet = array_values(m2, "leaflet", false, 1, "leaflet")?;
    specs.push(MapSpec {
        array: "leaflet",
        title: "Leaflet identity (leaflet)".into(),
        colors: label_colors(&leaflet, 0, &LEAFLET_COLORS),
        layout: Layout::VertexLabels,
        legend: Legend::Swatches {
            title: vec!["leaflet".into(), "(label)".into()],
            entries: vec![
                (LEAFLET_COLORS[0], "0 anterior".into()),
                (LEAFLET_COLORS[1], "1 posterior".into()),
            ],
            notes: Vec::new(),
        },
        segment_names: false,
    });

    // u gradient: stored colours; the bar runs along u.
    let grad = array_values(m2, "u_gradient", false, 3, "u_gradient")?;
    let colors = grad
        .chunks_exact(3)
        .map(|c| {
            let f = |x: f64| (255.0 * x).round().clamp(0.0, 255.0) as u8;
            if c.iter().all(|x| x.is_finite()) {
                Rgb::new(f(c[0]), f(c[1]), f(c[2]))
            } else {
                NAN_COLOR
            }
        })
        .collect();
    let u_of = |i: u32| geo.uv(i)[0];
    let u0 = u_of(geo.annulus[ANTERIOR][0]);
    let upm_a = u_of(*geo.annulus[ANTERIOR].last().unwrap_or(&0));
    let upm_p = u_of(geo.annulus[POSTERIOR][0]);
    let ul = u_of(*geo.annulus[POSTERIOR].last().unwrap_or(&0));
    let extent = (ul - u0).max(1e-9);
    let t_pm = ((upm_a - u0) / extent).clamp(1e-6, 1.0 - 1e-6);
    let t_pm_p = ((upm_p - u0) / extent).clamp(t_pm, 1.0 - 1e-6);
    specs.push(MapSpec {
        array: "u_gradient",
        title: "Position along the annulus (u_gradient)".into(),
        colors,
        layout: Layout::Vertex,
        legend: Legend::Bar {
            title: vec!["u_gradient".into(), "(u, mm)".into()],
            color: Box::new(move |t| {
                let c = if t <= t_pm {
                    let s = t / t_pm;
                    [1.0 - s, s, 0.0]
                } else if t < t_pm_p {
                    [0.0, 1.0, 0.0]
                } else {
                    let s = ((t - t_pm_p) / (1.0 - t_pm_p)).clamp(0.0, 1.0);
                    [0.0, 1.0 - s, s]
                };
                let f = |x: f64| (255.0 * x).round() as u8;
                Rgb::new(f(c[0]), f(c[1]), f(c[2]))
            }),
            ticks: vec![
                (0.0, format!("{} AL", format_value(u0))),
                (t_pm, format!("{} PM", format_value(upm_a))),
                (1.0, format!("{} AL", format_value(ul))),
            ],
            notes: vec!["anterior: red-green".into(), "posterior: green-blue".into()],
        },
        segment_names: false,
    });

    // Eight equal u intervals.
    let intervals = array_values(m2, "u_interval", false, 1, "u_interval")?;
    let palette: Vec<Rgb> = (0..8).map(|k| Colormap::Tableau10.label(k)).collect();
    let width = extent / 8.0;
    specs.push(MapSpec {
        array: "u_interval",
        title: "Eight equal intervals of u (u_interval)".into(),
        colors: label_colors(&intervals, 0, &palette),
        layout: Layout::VertexLabels,
        legend: Legend::Swatches {
            title: vec!["u_interval".into(), "(u in mm)".into()],
            entries: palette
                .iter()
                .enumerate()
                .map(|(k, &c)| {
                    let a = u0 + width * k as f64;
                    (
                        c,
                        format!("{k}: {}-{}", format_value(a), format_value(a + width)),
                    )
                })
                .collect(),
            notes: Vec::new(),
        },
        segment_names: false,
    });

    // Checkerboard.
    let checker = array_values(m2, "checker", false, 1, "checker")?;
    specs.push(MapSpec {
        array: "checker",
        title: "Checkerboard of (u, v) squares (checker)".into(),
        colors: label_colors(&checker, 0, &CHECKER_COLORS),
        layout: Layout::VertexLabels,
        legend: Legend::Swatches {
            title: vec!["checker".into(), "(label)".into()],
            entries: vec![
                (CHECKER_COLORS[0], "0".into()),
                (CHECKER_COLORS[1], "1".into()),
            ],
            notes: vec![
                "squares of equal side in (u, v): undistorted where they stay square in 3D".into(),
            ],
        },
        segment_names: false,
    });

    // Carpentier segments.
    let carpentier = array_values(m2, "carpentier", false, 1, "carpentier")?;
    let names = ["A1", "A2", "A3", "P1", "P2", "P3"];
    let counts = outcome.report.carpentier_vertices;
    specs.push(MapSpec {
        array: "carpentier",
        title: "Carpentier segments (carpentier)".into(),
        colors: label_colors(&carpentier, A1, &CARPENTIER_COLORS),
        layout: Layout::VertexLabels,
        legend: Legend::Swatches {
            title: vec!["carpentier".into(), "(segment = value: vertices)".into()],
            entries: (0..6)
                .map(|k| {
                    (
                        CARPENTIER_COLORS[k],
                        format!("{} = {}: {}", names[k], k as i32 + A1, counts[k]),
                    )
                })
                .collect(),
            notes: Vec::new(),
        },
        segment_names: true,
    });

    // Coaptation zone.
    let coaptation = array_values(m2, "coaptation", false, 1, "coaptation")?;
    let cc = outcome.report.coaptation_vertices;
    let t = format_value(cc.threshold_mm);
    let t2 = format_value(2.0 * cc.threshold_mm);
    specs.push(MapSpec {
        array: "coaptation",
        title: format!("Coaptation zone, threshold {t} mm (coaptation)"),
        colors: label_colors(&coaptation, COAPTATION_NONE, &COAPTATION_COLORS),
        layout: Layout::VertexLabels,
        legend: Legend::Swatches {
            title: vec![
                "coaptation".into(),
                "d: distance to the other leaflet".into(),
            ],
            entries: vec![
                (COAPTATION_COLORS[2], format!("d < {t} mm")),
                (COAPTATION_COLORS[1], format!("{t} <= d < {t2} mm")),
                (COAPTATION_COLORS[0], format!("d >= {t2} mm")),
            ],
            notes: vec![
                format!("zone: {} vertices", cc.within),
                format!("near: {} vertices", cc.near),
                "(the leaflets always touch at the commissures)".into(),
            ],
        },
        segment_names: false,
    });

    // Distance to the other leaflet.
    let array = "coaptation_distance_mm";
    let dist = array_values(m2, array, false, 1, array)?;
    let scale = ColorScale::from_values(Colormap::Viridis, &dist);
    let scale = ColorScale::new(Colormap::Viridis, scale.lo.min(0.0), scale.hi.max(1e-9));
    let mut notes = stats(&dist);
    notes.insert(0, "(mm)".into());
    specs.push(MapSpec {
        array,
        title: "Distance to the other leaflet (coaptation_distance_mm)".into(),
        colors: scale.colors(&dist),
        layout: Layout::Vertex,
        legend: Legend::Bar {
            title: vec![array.into()],
            color: Box::new(|t| Colormap::Viridis.eval(t)),
            ticks: vec![
                (0.0, format_value(scale.lo)),
                (0.5, format_value(0.5 * (scale.lo + scale.hi))),
                (1.0, format_value(scale.hi)),
            ],
            notes,
        },
        segment_names: false,
    });

    // Tenting / prolapse.
    let array = "tenting_mm";
    let tent = array_values(m2, array, false, 1, array)?;
    let mut notes = stats(&tent);
    notes.insert(0, "(mm, + atrial)".into());
    specs.push(MapSpec {
        array,
        title: "Tenting: height above the annulus plane (tenting_mm)".into(),
        colors: tent
            .iter()
            .map(|&h| {
                if h.is_nan() {
                    NAN_COLOR
                } else {
                    tenting_color((h + 3.0) / 6.0)
                }
            })
            .collect(),
        layout: Layout::Vertex,
        legend: Legend::Bar {
            title: vec!["tenting_mm".into()],
            color: Box::new(tenting_color),
            ticks: vec![
                (0.0, "<= -3".into()),
                (0.5, "0".into()),
                (1.0, ">= 3".into()),
            ],
            notes,
        },
        segment_names: false,
    });
    Ok(specs)
}

/// Draws the mesh coloured by `spec` into `r` (positions `p`).
fn draw_colored(
    r: &mut Renderer,
    geo: &Geometry<'_>,
    p: &[Point3<f64>],
    spec: &MapSpec,
    shading: Shading,
    figure: &str,
) -> Result<(), FigureError> {
    let err = FigureError::render(figure);
    let expected = match spec.layout {
        Layout::Cell => geo.triangles.len(),
        _ => p.len(),
    };
    if spec.colors.len() != expected {
        return Err(FigureError::input(
            figure,
            format!("{} colours for {expected} elements", spec.colors.len()),
        ));
    }
    match spec.layout {
        Layout::Cell => {
            r.draw_mesh(
                p,
                geo.triangles,
                Coloring::PerTriangle(&spec.colors),
                shading,
            )
            .map_err(err)?;
        }
        Layout::Vertex => {
            r.draw_mesh(p, geo.triangles, Coloring::PerVertex(&spec.colors), shading)
                .map_err(err)?;
        }
        Layout::VertexLabels => {
            let q = geo.sub.positions(p);
            let colors: Vec<Rgb> = geo
                .sub
                .corner
                .iter()
                .map(|&v| spec.colors[v as usize])
                .collect();
            r.draw_mesh(
                &q,
                &geo.sub.triangles,
                Coloring::PerTriangle(&colors),
                shading,
            )
            .map_err(err)?;
        }
    }
    Ok(())
}

/// Draws a line `w` pixels thick (offsets of the 1-pixel line).
fn thick_line(img: &mut Image, a: [f64; 2], b: [f64; 2], c: Rgba, w: i32) {
    let lo = -(w - 1) / 2;
    for dx in lo..lo + w {
        for dy in lo..lo + w {
            let (dx, dy) = (f64::from(dx), f64::from(dy));
            img.line([a[0] + dx, a[1] + dy], [b[0] + dx, b[1] + dy], c);
        }
    }
}

/// Draws a dashed vertical line at column `x` from row `y0` to `y1`.
fn dashed_vline(img: &mut Image, x: f64, y0: f64, y1: f64, c: Rgba) {
    let mut y = y0;
    while y < y1 {
        let e = (y + 5.0).min(y1);
        img.line([x, y], [x, e], c);
        y += 9.0;
    }
}

/// Text with a one-pixel halo in `halo` around it.
#[allow(clippy::too_many_arguments)]
fn halo_text(
    img: &mut Image,
    x: i32,
    y: i32,
    text: &str,
    scale: u32,
    c: Rgba,
    halo: Rgba,
    figure: &str,
) -> Result<(), FigureError> {
    for (dx, dy) in [
        (-1, 0),
        (1, 0),
        (0, -1),
        (0, 1),
        (-1, -1),
        (1, 1),
        (-1, 1),
        (1, -1),
    ] {
        img.draw_text(x + dx, y + dy, text, scale, halo, Anchor::Center)
            .map_err(FigureError::render(figure))?;
    }
    img.draw_text(x, y, text, scale, c, Anchor::Center)
        .map_err(FigureError::render(figure))?;
    Ok(())
}

/// A "nice" scale bar length in mm for `scale` pixels per mm and a map
/// `width` pixels wide: 10 mm when that is 25 px to half the width, else
/// the longest of 1, 2, 5, 10, 20, 50, 100 mm within a quarter of it.
fn scale_bar_mm(scale: f64, width: f64) -> f64 {
    if (25.0..=0.5 * width).contains(&(10.0 * scale)) {
        return 10.0;
    }
    [1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0]
        .into_iter()
        .rev()
        .find(|&l| l * scale <= 0.25 * width)
        .unwrap_or(1.0)
}

/// The left panel: the 2D map.
fn panel_2d(geo: &Geometry<'_>, spec: &MapSpec, figure: &str) -> Result<Image, FigureError> {
    let err = || FigureError::render(figure);
    let mut img = Image::new(geo.pw, geo.ph, PAPER).map_err(err())?;
    let map = geo.map;
    let mut r = Renderer::new(map.size[0], map.size[1], PAPER, geo.cam2d).map_err(err())?;
    draw_colored(&mut r, geo, geo.p2, spec, Shading::Unlit, figure)?;
    img.blit(
        r.image(),
        i64::from(map.origin[0]),
        i64::from(map.origin[1]),
    );
    let px = |i: u32| {
        let q = geo.uv(i);
        map.panel_xy(q[0], q[1])
    };
    // Outline, then the annulus over it.
    for e in &geo.free_edges {
        img.line(px(e[0]), px(e[1]), OUTLINE_COLOR);
    }
    for ring in &geo.annulus {
        for w in ring.windows(2) {
            thick_line(&mut img, px(w[0]), px(w[1]), ANNULUS_COLOR, 3);
        }
    }

    // The subtitle, the commissures and u = 0.
    subtitle(
        &mut img,
        geo.pw,
        &["2D map (u along the annulus, mm)", "2D map (mm)"],
        figure,
    )?;
    let al = px(geo.annulus[ANTERIOR][0]);
    let pm = px(*geo.annulus[ANTERIOR].last().unwrap_or(&0));
    let pm_p = px(geo.annulus[POSTERIOR][0]);
    let al_end = px(*geo.annulus[POSTERIOR].last().unwrap_or(&0));
    let bottom = f64::from(map.bottom());
    let tick_top = f64::from(LABEL_Y[1] + 10);
    dashed_vline(&mut img, al[0], tick_top, bottom, INK);
    img.draw_text(al[0] as i32, LABEL_Y[0], "u = 0", 1, INK, Anchor::Center)
        .map_err(err())?;
    let pm_x = 0.5 * (pm[0] + pm_p[0]);
    for (x, name) in [(al[0], "AL"), (pm_x, "PM"), (al_end[0], "AL")] {
        img.draw_text(x as i32, LABEL_Y[1], name, 1, INK, Anchor::Center)
            .map_err(err())?;
    }
    for (x, y) in [(pm[0], pm[1]), (pm_p[0], pm_p[1]), (al_end[0], al_end[1])] {
        img.line([x, tick_top], [x, y - 3.0], INK);
    }

    // Segment names at their centroids.
    if spec.segment_names {
        let carpentier = array_values(&geo.outcome.valve2d, "carpentier", false, 1, figure)?;
        for (k, name) in ["A1", "A2", "A3", "P1", "P2", "P3"].iter().enumerate() {
            let label = f64::from(A1) + k as f64;
            let (mut s, mut n) = ([0.0; 2], 0.0);
            for (i, &c) in carpentier.iter().enumerate() {
                if c == label {
                    let q = geo.uv(i as u32);
                    s[0] += q[0];
                    s[1] += q[1];
                    n += 1.0;
                }
            }
            if n > 0.0 {
                let c = map.panel_xy(s[0] / n, s[1] / n);
                halo_text(
                    &mut img,
                    c[0] as i32,
                    c[1] as i32 - 8,
                    name,
                    2,
                    INK,
                    PAPER,
                    figure,
                )?;
            }
        }
    }

    // Leaflet names below the map.
    let y = map.bottom() + 4;
    for (x, name) in [
        (0.5 * (al[0] + pm[0]), "anterior leaflet"),
        (0.5 * (pm_p[0] + al_end[0]), "posterior leaflet"),
    ] {
        img.draw_text(x as i32, y, name, 1, INK, Anchor::Center)
            .map_err(err())?;
    }

    // Scale bar.
    let len = scale_bar_mm(map.scale, f64::from(map.size[0]));
    let (x0, yb) = (f64::from(MAP_SIDE), f64::from(y + 26));
    let x1 = x0 + len * map.scale;
    thick_line(&mut img, [x0, yb], [x1, yb], INK, 2);
    img.line([x0, yb - 4.0], [x0, yb + 4.0], INK);
    img.line([x1, yb - 4.0], [x1, yb + 4.0], INK);
    img.draw_text(
        (x1 + 8.0) as i32,
        yb as i32 - 4,
        &format!("{} mm", format_value(len)),
        1,
        INK,
        Anchor::Left,
    )
    .map_err(err())?;

    // Measurements.
    let rep = &geo.outcome.report;
    let lines = [
        format!(
            "annulus {} mm, saddle horn {} mm",
            format_value(rep.annulus_length_mm),
            format_value(rep.saddle_horn_height_mm)
        ),
        format!(
            "leaflet area: anterior {}, posterior {} mm^2",
            format_value(rep.leaflet_area_mm2.anterior),
            format_value(rep.leaflet_area_mm2.posterior)
        ),
        format!(
            "area above / below annulus plane: {} / {} mm^2",
            format_value(rep.area_above_plane_mm2),
            format_value(rep.area_below_plane_mm2)
        ),
    ];
    let mut ty = yb as i32 + 14;
    let room = (geo.pw as usize).saturating_sub(2 * MAP_SIDE as usize) / 8;
    for line in lines.iter().flat_map(|l| wrap(l, room)) {
        if ty + 8 > geo.ph as i32 - 2 {
            break;
        }
        img.draw_text(MAP_SIDE, ty, &line, 1, INK, Anchor::Left)
            .map_err(err())?;
        ty += 11;
    }
    Ok(img)
}

/// Writes the first of `texts` that fits in `width` pixels, centred over
/// them, on the subtitle row.
fn subtitle(img: &mut Image, width: u32, texts: &[&str], figure: &str) -> Result<(), FigureError> {
    let text = texts
        .iter()
        .find(|t| text_width(t, 1) + 4 <= width)
        .or(texts.last())
        .copied()
        .unwrap_or("");
    img.draw_text(width as i32 / 2, SUBTITLE_Y, text, 1, INK, Anchor::Center)
        .map_err(FigureError::render(figure))?;
    Ok(())
}

/// The right panel: the 3D view and the legend.
fn panel_3d(geo: &Geometry<'_>, spec: &MapSpec, figure: &str) -> Result<Image, FigureError> {
    let err = || FigureError::render(figure);
    let mut img = Image::new(geo.pw, geo.ph, PAPER).map_err(err())?;
    let (w, h) = geo.view;
    let mut r = Renderer::new(w, h, PAPER, geo.cam3d).map_err(err())?;
    draw_colored(&mut r, geo, geo.p3, spec, Shading::Smooth, figure)?;
    for e in &geo.free_edges {
        r.draw_polyline_3d(
            &[geo.p3[e[0] as usize], geo.p3[e[1] as usize]],
            false,
            OUTLINE_COLOR,
        )
        .map_err(err())?;
    }
    // The annulus, thick where visible (segment midpoints depth-tested).
    let bias = r.depth_bias();
    let mut segments = Vec::new();
    for ring in &geo.annulus {
        for w2 in ring.windows(2) {
            let (a, b) = (geo.p3[w2[0] as usize], geo.p3[w2[1] as usize]);
            let m = Point3::from((a.coords + b.coords) * 0.5);
            let (Some(pa), Some(pb), Some(pm)) = (r.project(&a), r.project(&b), r.project(&m))
            else {
                continue;
            };
            let visible = r
                .depth_at(pm.x.floor() as i64, pm.y.floor() as i64)
                .is_none_or(|z| pm.depth <= z + 4.0 * bias);
            if visible {
                segments.push(([pa.x, pa.y], [pb.x, pb.y]));
            }
        }
    }
    let view_img = r.image_mut();
    for (a, b) in segments {
        thick_line(view_img, a, b, ANNULUS_COLOR, 3);
    }

    // Segment names at the vertex nearest each segment's 2D centroid.
    let mut labels: Vec<([f64; 2], String, u32)> = Vec::new();
    if spec.segment_names {
        let carpentier = array_values(&geo.outcome.valve2d, "carpentier", false, 1, figure)?;
        for (k, name) in ["A1", "A2", "A3", "P1", "P2", "P3"].iter().enumerate() {
            let label = f64::from(A1) + k as f64;
            let ids: Vec<u32> = (0..carpentier.len() as u32)
                .filter(|&i| carpentier[i as usize] == label)
                .collect();
            if ids.is_empty() {
                continue;
            }
            let n = ids.len() as f64;
            let c = ids.iter().fold([0.0; 2], |s, &i| {
                let q = geo.uv(i);
                [s[0] + q[0] / n, s[1] + q[1] / n]
            });
            let best = ids.iter().copied().min_by(|&i, &j| {
                let d = |v: u32| {
                    let q = geo.uv(v);
                    (q[0] - c[0]).powi(2) + (q[1] - c[1]).powi(2)
                };
                d(i).total_cmp(&d(j))
            });
            if let Some(p) = best.and_then(|v| r.project(&geo.p3[v as usize])) {
                labels.push(([p.x, p.y], (*name).to_string(), 2));
            }
        }
    }
    // Commissures and leaflets, pushed outwards from the ring's centre.
    let centre = {
        let pts: Vec<[f64; 2]> = geo
            .annulus
            .iter()
            .flatten()
            .filter_map(|&v| r.project(&geo.p3[v as usize]))
            .map(|p| [p.x, p.y])
            .collect();
        let n = pts.len().max(1) as f64;
        pts.iter()
            .fold([0.0; 2], |s, p| [s[0] + p[0] / n, s[1] + p[1] / n])
    };
    let out = |v: u32, by: f64| -> Option<[f64; 2]> {
        let p = r.project(&geo.p3[v as usize])?;
        let d = [p.x - centre[0], p.y - centre[1]];
        let l = (d[0] * d[0] + d[1] * d[1]).sqrt().max(1e-9);
        Some([p.x + by * d[0] / l, p.y + by * d[1] / l])
    };
    let ant = &geo.annulus[ANTERIOR];
    let post = &geo.annulus[POSTERIOR];
    for (v, name) in [(ant[0], "AL"), (*ant.last().unwrap_or(&0), "PM")] {
        if let Some(p) = out(v, 16.0) {
            labels.push((p, name.to_string(), 1));
        }
    }
    // The leaflet names above and below the whole valve, over the middle
    // of their annulus arcs.
    let rows: Vec<f64> = geo
        .p3
        .iter()
        .filter_map(|p| r.project(p))
        .map(|p| p.y)
        .collect();
    let top = rows.iter().copied().fold(f64::INFINITY, f64::min);
    let low = rows.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    for (v, name, y) in [
        (ant[ant.len() / 2], "anterior", top - 8.0),
        (post[post.len() / 2], "posterior", low + 10.0),
    ] {
        if let (Some(p), true) = (r.project(&geo.p3[v as usize]), y.is_finite()) {
            labels.push(([p.x, y], name.to_string(), 1));
        }
    }
    let view_img = r.image_mut();
    for (p, name, scale) in &labels {
        let half = 4 * *scale as i32;
        halo_text(
            view_img,
            p[0] as i32,
            p[1] as i32 - half,
            name,
            *scale,
            INK,
            PAPER,
            figure,
        )?;
    }
    img.blit(r.image(), 0, i64::from(VIEW_TOP));
    subtitle(
        &mut img,
        w,
        &[
            "3D, from the atrium, anterior up",
            "3D, from the atrium",
            "3D",
        ],
        figure,
    )?;
    draw_legend(
        &mut img,
        &spec.legend,
        (w + 6) as i32,
        VIEW_TOP + 4,
        geo.legend_w - 10,
        geo.ph as i32 - VIEW_TOP - 10,
        figure,
    )?;
    Ok(img)
}

/// Splits `text` into lines of at most `max` characters: at spaces, and
/// inside longer words after an underscore or anywhere.
fn wrap(text: &str, max: usize) -> Vec<String> {
    let max = max.max(1);
    let mut pieces: Vec<String> = Vec::new();
    for word in text.split(' ').filter(|w| !w.is_empty()) {
        if word.chars().count() <= max {
            pieces.push(word.to_string());
            continue;
        }
        let mut cur = String::new();
        for part in word.split_inclusive('_') {
            if cur.chars().count() + part.chars().count() > max && !cur.is_empty() {
                pieces.push(std::mem::take(&mut cur));
            }
            cur.push_str(part);
            while cur.chars().count() > max {
                let head: String = cur.chars().take(max).collect();
                cur = cur.chars().skip(max).collect();
                pieces.push(head);
            }
        }
        if !cur.is_empty() {
            pieces.push(cur);
        }
    }
    let mut lines: Vec<String> = Vec::new();
    for p in pieces {
        match lines.last_mut() {
            Some(l) if l.chars().count() + 1 + p.chars().count() <= max => {
                l.push(' ');
                l.push_str(&p);
            }
            _ => lines.push(p),
        }
    }
    lines
}

/// Draws `legend` in the box at `(x, y)` of `width x height` pixels (text
/// wrapped to the width; what does not fit below is left out).
fn draw_legend(
    img: &mut Image,
    legend: &Legend,
    x: i32,
    y: i32,
    width: u32,
    height: i32,
    figure: &str,
) -> Result<(), FigureError> {
    let err = || FigureError::render(figure);
    let bottom = y + height;
    // Writes wrapped lines from row `ty` at column `tx`; returns the next row.
    let lines = |img: &mut Image, tx: i32, ty: i32, s: &str| -> Result<i32, FigureError> {
        let room = (x + width as i32 - tx).max(8) as usize / 8;
        let mut ty = ty;
        for line in wrap(s, room) {
            if ty + 8 > bottom {
                break;
            }
            img.draw_text(tx, ty, &line, 1, INK, Anchor::Left)
                .map_err(err())?;
            ty += 10;
        }
        Ok(ty)
    };
    let (title, notes) = match legend {
        Legend::Bar { title, notes, .. } | Legend::Swatches { title, notes, .. } => (title, notes),
    };
    let mut ty = y;
    for line in title {
        ty = lines(img, x, ty, line)?;
    }
    ty += 6;
    match legend {
        Legend::Bar { color, ticks, .. } => {
            let note_lines: usize = notes
                .iter()
                .map(|n| wrap(n, (width / 8) as usize).len())
                .sum();
            let note_h = 10 * note_lines as i32 + 8;
            let bar_h = (bottom - ty - note_h - 8).clamp(20, 200);
            let (y_top, y_bot) = (ty + 4, ty + 4 + bar_h);
            let bar_w = 18;
            img.stroke_rect(
                unfold_render::Rect::new(x, y_top - 1, bar_w as u32, (bar_h + 3) as u32),
                INK,
            );
            for yy in y_top..=y_bot {
                let t = f64::from(y_bot - yy) / f64::from(bar_h);
                let c = color(t).opaque();
                for xx in x + 1..x + bar_w - 1 {
                    img.put(i64::from(xx), i64::from(yy), c);
                }
            }
            for (t, label) in ticks {
                let yy = (f64::from(y_bot) - t * f64::from(bar_h)).round() as i32;
                img.line(
                    [f64::from(x + bar_w), f64::from(yy) + 0.5],
                    [f64::from(x + bar_w + 3), f64::from(yy) + 0.5],
                    INK,
                );
                let room = (width as i32 - bar_w - 8).max(8) as usize / 8;
                let s: String = label.chars().take(room).collect();
                img.draw_text(x + bar_w + 8, yy - 4, &s, 1, INK, Anchor::Left)
                    .map_err(err())?;
            }
            ty = y_bot + 14;
        }
        Legend::Swatches { entries, .. } => {
            for (c, label) in entries {
                if ty + 12 > bottom {
                    break;
                }
                let sw = unfold_render::Rect::new(x, ty, 12, 12);
                img.fill_rect(sw, c.opaque());
                img.stroke_rect(sw, INK);
                ty = lines(img, x + 18, ty + 2, label)?.max(ty + 17);
            }
            ty += 6;
        }
    }
    for line in notes {
        ty = lines(img, x, ty, line)?;
    }
    Ok(())
}

/// The whole figure: the title over both panels.
fn compose(geo: &Geometry<'_>, spec: &MapSpec, figure: &str) -> Result<Image, FigureError> {
    let err = || FigureError::render(figure);
    let left = panel_2d(geo, spec, figure)?;
    let right = panel_3d(geo, spec, figure)?;
    let mut fig = Image::new(2 * geo.pw, geo.ph, PAPER).map_err(err())?;
    fig.blit(&left, 0, 0);
    fig.blit(&right, i64::from(geo.pw), 0);
    let scale = if text_width(&spec.title, 2) + 8 <= fig.width() {
        2
    } else {
        1
    };
    let ty = (TITLE_BAND - 8 * scale as i32) / 2;
    fig.draw_text(
        geo.pw as i32,
        ty.max(0),
        &spec.title,
        scale,
        INK,
        Anchor::Center,
    )
    .map_err(err())?;
    Ok(fig)
}
