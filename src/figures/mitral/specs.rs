//! How each map is coloured and explained ([`MapSpec`]): the arrays read
//! from the 2D mesh, their colours (ALGORITHMS 4.4, 4.5) and legends.

use unfold_mesh::{Field, FieldValues, TriMesh};
use unfold_organs::mitral::maps::{A1, COAPTATION_NONE};
use unfold_organs::mitral::{ANTERIOR, Outcome, POSTERIOR};
use unfold_render::nalgebra::Point3;
use unfold_render::{ColorScale, Colormap, NAN_COLOR, Rgb, format_value};

use super::geometry::Geometry;
use super::{CARPENTIER_COLORS, CHECKER_COLORS, COAPTATION_COLORS, LEAFLET_COLORS};
use crate::figures::FigureError;

/// How one map is coloured and explained.
pub(super) struct MapSpec {
    /// The array name (point or cell data of `valve2d` / `valve3d`).
    pub(super) array: &'static str,
    /// The figure title.
    pub(super) title: String,
    /// One colour per vertex or per triangle.
    pub(super) colors: Vec<Rgb>,
    /// How `colors` is attached to the mesh.
    pub(super) layout: Layout,
    /// The legend beside the 3D view.
    pub(super) legend: Legend,
    /// Whether to write the Carpentier segment names on the map.
    pub(super) segment_names: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Layout {
    /// Per-vertex labels: crisp regions around each vertex.
    VertexLabels,
    /// Per-vertex continuous colours, interpolated.
    Vertex,
    /// Per-triangle colours.
    Cell,
}

/// A legend: a colour bar or label swatches.
pub(super) enum Legend {
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

/// Per-element values of `array`: point data (one per vertex) or cell data
/// (one per triangle), `components` each.
pub(super) fn array_values(
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
        title: "Area distortion A'/A + A/A' (area_energy)".into(),
        colors,
        layout: Layout::Cell,
        legend: Legend::Bar {
            title: vec![
                array.into(),
                "A', A: 2D, 3D triangle area".into(),
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

pub(super) fn map_specs(
    outcome: &Outcome,
    geo: &Geometry<'_>,
) -> Result<Vec<MapSpec>, FigureError> {
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
