//! [`CYLINDER_PNG`]: the anatomy in the (half) cylinder, coloured by depth,
//! seen obliquely, with the outline of the cylinder and the orientation
//! words.

use std::collections::HashMap;
use std::f64::consts::{PI, TAU};

use unfold_mesh::{CellMesh, CellType, MeshError};
use unfold_organs::ventricle::disk::RV_CENTRE;
use unfold_organs::ventricle::{Chamber, Outcome};
use unfold_render::nalgebra::{Point3, Vector3};
use unfold_render::{
    Anchor, Camera, ColorScale, Coloring, Image, Projection, Renderer, Rgba, Shading,
};

use super::drawing::{colorbar_column, text, title_band};
use super::{COLORBAR_COLUMN, CYLINDER_PNG, DEPTH_COLORMAP, TITLE_BAND, figure_size};
use crate::figures::{Figure, FigureError, FigureOptions, INK, PAPER};

/// What of the anatomy is drawn: triangles (surface cells, boundary faces
/// of volume cells), segments (line cells) and lone points.
#[derive(Debug, Default, PartialEq)]
pub(super) struct Drawable {
    pub(super) triangles: Vec<[u32; 3]>,
    pub(super) segments: Vec<[u32; 2]>,
    pub(super) points: Vec<u32>,
}

/// The faces of a volume cell (VTK point order).
fn cell_faces(t: CellType, vs: &[u32]) -> Vec<Vec<u32>> {
    let f = |idx: &[&[usize]]| -> Vec<Vec<u32>> {
        idx.iter()
            .map(|face| face.iter().map(|&i| vs[i]).collect())
            .collect()
    };
    match t {
        CellType::Tetra => f(&[&[0, 2, 1], &[0, 1, 3], &[1, 2, 3], &[0, 3, 2]]),
        CellType::Hexahedron => f(&[
            &[0, 3, 2, 1],
            &[4, 5, 6, 7],
            &[0, 1, 5, 4],
            &[1, 2, 6, 5],
            &[2, 3, 7, 6],
            &[3, 0, 4, 7],
        ]),
        CellType::Wedge => f(&[
            &[0, 1, 2],
            &[3, 5, 4],
            &[0, 3, 4, 1],
            &[1, 4, 5, 2],
            &[2, 5, 3, 0],
        ]),
        CellType::Pyramid => f(&[
            &[0, 3, 2, 1],
            &[0, 1, 4],
            &[1, 2, 4],
            &[2, 3, 4],
            &[3, 0, 4],
        ]),
        _ => Vec::new(),
    }
}

/// The drawable parts of `mesh` (checked first): surface cells
/// fan-triangulated, the faces of volume cells that belong to one cell
/// only (the boundary), line cells as segments, and the points in none of
/// those as points. Deterministic: everything in cell order.
pub(super) fn drawable(mesh: &CellMesh) -> Result<Drawable, MeshError> {
    mesh.check()?;
    let mut d = Drawable::default();
    let mut used = vec![false; mesh.positions.len()];
    let fan = |poly: &[u32], out: &mut Vec<[u32; 3]>| {
        for k in 1..poly.len().saturating_sub(1) {
            out.push([poly[0], poly[k], poly[k + 1]]);
        }
    };
    let mut faces: Vec<Vec<u32>> = Vec::new();
    let mut count: HashMap<Vec<u32>, usize> = HashMap::new();
    for (t, vs) in mesh.cells() {
        match t.dimension() {
            3 => {
                for face in cell_faces(t, vs) {
                    let mut key = face.clone();
                    key.sort_unstable();
                    *count.entry(key).or_insert(0) += 1;
                    faces.push(face);
                }
            }
            2 => fan(vs, &mut d.triangles),
            1 => {
                for s in vs.windows(2) {
                    d.segments.push([s[0], s[1]]);
                }
            }
            _ => {}
        }
    }
    for face in faces {
        let mut key = face.clone();
        key.sort_unstable();
        if count.get(&key) == Some(&1) {
            fan(&face, &mut d.triangles);
        }
    }
    for t in &d.triangles {
        for &v in t {
            used[v as usize] = true;
        }
    }
    for s in &d.segments {
        for &v in s {
            used[v as usize] = true;
        }
    }
    // Volume cells' interior points are not drawn.
    for (t, vs) in mesh.cells() {
        if t.dimension() == 3 {
            for &v in vs {
                used[v as usize] = true;
            }
        }
    }
    d.points = (0..mesh.positions.len() as u32)
        .filter(|&v| !used[v as usize])
        .collect();
    Ok(d)
}

/// The cylinder's outline at depth `z`: the unit circle (LV) or the half
/// circle about [`RV_CENTRE`] closed by the septal edge (RV).
fn outline(chamber: Chamber, z: f64) -> Vec<Point3<f64>> {
    let n = 128;
    match chamber {
        Chamber::Lv => (0..n)
            .map(|k| {
                let a = TAU * k as f64 / n as f64;
                Point3::new(a.cos(), a.sin(), z)
            })
            .collect(),
        Chamber::Rv => (0..=n / 2)
            .map(|k| {
                let a = -0.5 * PI + PI * k as f64 / (n / 2) as f64;
                Point3::new(RV_CENTRE[0] + a.cos(), RV_CENTRE[1] + a.sin(), z)
            })
            .collect(),
    }
}

/// [`CYLINDER_PNG`].
pub(super) fn cylinder(
    outcome: &Outcome,
    chamber: Chamber,
    opts: &FigureOptions,
) -> Result<Figure, FigureError> {
    const F: &str = CYLINDER_PNG;
    let (w, h) = figure_size(opts, 1, 1)?;
    let mesh = &outcome.normalized;
    if mesh.positions.is_empty() {
        return Err(FigureError::input(F, "the anatomy has no points"));
    }
    let d = drawable(mesh)
        .map_err(|e| FigureError::input(F, format!("the normalized anatomy: {e}")))?;
    let depth: Vec<f64> = mesh.positions.iter().map(|p| p.z).collect();
    let scale = ColorScale::from_values(DEPTH_COLORMAP, &depth);
    let colors = scale.colors(&depth);
    // The view, 30 degrees off the disk plane. LV: from the S side (the
    // camera on the depth < 0 side, looking along +zeta and +depth), depth
    // downwards, so that the disk appears as in the bull's-eye (anterior
    // up, septum left). RV: from above (the depth > 1 side), depth upwards,
    // the half disk as in its own axes (septal edge left, first corner up).
    let e = 30f64.to_radians();
    let (f, up) = match chamber {
        Chamber::Lv => (Vector3::new(0.0, e.cos(), e.sin()), -Vector3::z()),
        Chamber::Rv => (Vector3::new(0.0, e.cos(), -e.sin()), Vector3::z()),
    };
    let ring0 = outline(chamber, 0.0);
    let ring1 = outline(chamber, 1.0);
    let (aw, ah) = (
        (i64::from(w) - COLORBAR_COLUMN) as u32,
        (i64::from(h) - TITLE_BAND) as u32,
    );
    // Framed on the cylinder (the anatomy lies inside it): its width across
    // (2 or 1 units) with 64 pixels for labels on either side, its height
    // (2 sin e + cos e units) with 22 above and below.
    let (target, across) = match chamber {
        Chamber::Lv => (Point3::new(0.0, 0.0, 0.5), 2.0),
        Chamber::Rv => (Point3::new(RV_CENTRE[0] + 0.5, 0.0, 0.5), 1.0),
    };
    let px_per_unit = ((f64::from(aw) - 128.0) / across)
        .min((f64::from(ah) - 44.0) / (2.0 * e.sin() + e.cos()))
        .max(1.0);
    let cam = Camera::orthographic(
        target - 4.0 * f,
        target,
        up,
        0.5 * f64::from(ah) / px_per_unit,
    )
    .map_err(FigureError::render(F))?;
    let mut r = Renderer::new(aw, ah, PAPER, cam).map_err(FigureError::render(F))?;
    if !d.triangles.is_empty() {
        r.draw_mesh(
            &mesh.positions,
            &d.triangles,
            Coloring::PerVertex(&colors),
            Shading::Smooth,
        )
        .map_err(FigureError::render(F))?;
    }
    for s in &d.segments {
        let (a, b) = (s[0] as usize, s[1] as usize);
        let c = scale.color(0.5 * (depth[a] + depth[b])).opaque();
        r.draw_polyline_3d(&[mesh.positions[a], mesh.positions[b]], false, c)
            .map_err(FigureError::render(F))?;
    }
    if !d.points.is_empty() {
        // Squares facing the camera, 5 pixels wide, depth-tested.
        let px = match cam.projection() {
            Projection::Orthographic { half_height } => 2.0 * half_height / f64::from(ah),
            Projection::Perspective { .. } => 0.0,
        };
        let (ru, uu) = (cam.right() * 2.5 * px, cam.up() * 2.5 * px);
        let mut pos = Vec::with_capacity(4 * d.points.len());
        let mut tris = Vec::with_capacity(2 * d.points.len());
        let mut cols = Vec::with_capacity(2 * d.points.len());
        for &v in &d.points {
            let p = mesh.positions[v as usize];
            let b = pos.len() as u32;
            pos.extend([p - ru - uu, p + ru - uu, p + ru + uu, p - ru + uu]);
            tris.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
            cols.extend([colors[v as usize]; 2]);
        }
        r.draw_mesh(&pos, &tris, Coloring::PerTriangle(&cols), Shading::Unlit)
            .map_err(FigureError::render(F))?;
    }
    // The outline, depth-tested (hidden behind the anatomy): both rings and
    // the vertical edges of the wall's silhouette (and the RV's corners).
    let outline_ink = Rgba::new(60, 60, 60, 255);
    for ring in [&ring0, &ring1] {
        r.draw_polyline_3d(ring, true, outline_ink)
            .map_err(FigureError::render(F))?;
    }
    let verticals: Vec<[f64; 2]> = match chamber {
        Chamber::Lv => vec![[1.0, 0.0], [-1.0, 0.0]],
        Chamber::Rv => vec![
            [RV_CENTRE[0], 1.0],
            [RV_CENTRE[0], -1.0],
            [RV_CENTRE[0] + 1.0, 0.0],
        ],
    };
    for p in &verticals {
        r.draw_polyline_3d(
            &[Point3::new(p[0], p[1], 0.0), Point3::new(p[0], p[1], 1.0)],
            false,
            outline_ink,
        )
        .map_err(FigureError::render(F))?;
    }
    // Labels, placed from the projections (in figure pixels).
    let proj = |p: Point3<f64>| {
        r.project(&p)
            .map(|q| [q.x, q.y + TITLE_BAND as f64])
            .unwrap_or([f64::NAN; 2])
    };
    let mut labels: Vec<([f64; 2], String, Anchor)> = Vec::new();
    // Beside the vertical edges at mid height.
    let (left, right) = match chamber {
        Chamber::Lv => ("septal", "lateral"),
        Chamber::Rv => ("septal edge", "free wall"),
    };
    let (pl, pr) = match chamber {
        Chamber::Lv => (
            proj(Point3::new(1.0, 0.0, 0.5)),
            proj(Point3::new(-1.0, 0.0, 0.5)),
        ),
        Chamber::Rv => (
            proj(Point3::new(RV_CENTRE[0], 0.0, 0.5)),
            proj(Point3::new(RV_CENTRE[0] + 1.0, 0.0, 0.5)),
        ),
    };
    labels.push(([pl[0] - 6.0, pl[1] - 4.0], left.into(), Anchor::Right));
    labels.push(([pr[0] + 6.0, pr[1] - 4.0], right.into(), Anchor::Left));
    // Above the highest ring and below the lowest one.
    let (upper, lower) = if proj(ring0[0])[1] < proj(ring1[0])[1] {
        (0.0, 1.0)
    } else {
        (1.0, 0.0)
    };
    match chamber {
        Chamber::Lv => {
            let a = proj(Point3::new(0.0, 1.0, upper));
            labels.push(([a[0], a[1] - 13.0], "anterior".into(), Anchor::Center));
            let i = proj(Point3::new(0.0, -1.0, lower));
            labels.push(([i[0], i[1] + 5.0], "inferior".into(), Anchor::Center));
        }
        Chamber::Rv => {
            let a = proj(Point3::new(RV_CENTRE[0], 1.0, upper));
            labels.push(([a[0], a[1] - 13.0], "corner 1".into(), Anchor::Center));
            let i = proj(Point3::new(RV_CENTRE[0], -1.0, lower));
            labels.push(([i[0], i[1] + 5.0], "corner 2".into(), Anchor::Center));
        }
    }
    // The depth of each ring, right of it.
    for (ring, z, words) in [
        (&ring0, 0.0, ["depth 0", "(S)"]),
        (&ring1, 1.0, ["depth 1", "(H)"]),
    ] {
        let x = ring
            .iter()
            .map(|p| proj(*p)[0])
            .fold(f64::NEG_INFINITY, f64::max);
        let c = proj(Point3::new(target.x, 0.0, z));
        labels.push(([x + 6.0, c[1] - 9.0], words[0].into(), Anchor::Left));
        labels.push(([x + 6.0, c[1] + 2.0], words[1].into(), Anchor::Left));
    }
    let mut img = Image::new(w, h, PAPER).map_err(FigureError::render(F))?;
    img.blit(r.image(), 0, TITLE_BAND);
    let (heading, sub) = match chamber {
        Chamber::Lv => (
            "LV anatomy in the cylinder",
            "across: displayed disk, down: depth; seen from the S side: anterior up, septum left",
        ),
        Chamber::Rv => (
            "RV anatomy in the cylinder",
            "across: half disk, up: depth; seen from above: septal edge left, corner 1 up",
        ),
    };
    title_band(&mut img, F, heading, sub)?;
    for (p, word, anchor) in labels {
        if p[0].is_finite() && p[1].is_finite() {
            text(&mut img, F, p[0] as i64, p[1] as i64, &word, INK, anchor)?;
        }
    }
    let x0 = i64::from(w) - COLORBAR_COLUMN;
    colorbar_column(&mut img, F, x0, &scale, &["depth", "(0 = S, 1 = H)"])?;
    Ok(Figure::new(F, img))
}

#[cfg(test)]
mod tests {
    use super::*;
    use unfold_render::nalgebra::Point3;

    #[test]
    fn volume_cells_are_drawn_by_their_boundary_faces() {
        // Two tets sharing the face (1, 2, 3), a line and a lone point.
        let mut m = CellMesh::from_points(vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(0.0, 0.0, 1.0),
            Point3::new(1.0, 1.0, 1.0),
            Point3::new(3.0, 0.0, 0.0),
            Point3::new(3.0, 1.0, 0.0),
            Point3::new(5.0, 5.0, 5.0),
        ]);
        m.push_cell(CellType::Tetra, &[0, 1, 2, 3]);
        m.push_cell(CellType::Tetra, &[1, 2, 3, 4]);
        m.push_cell(CellType::Line, &[5, 6]);
        m.push_cell(CellType::Vertex, &[7]);
        let d = drawable(&m).unwrap();
        assert_eq!(d.triangles.len(), 6);
        let mut shared = [1u32, 2, 3];
        shared.sort_unstable();
        assert!(d.triangles.iter().all(|t| {
            let mut s = *t;
            s.sort_unstable();
            s != shared
        }));
        assert_eq!(d.segments, vec![[5, 6]]);
        assert_eq!(d.points, vec![7]);
        // A hexahedron: 6 quads, 12 triangles.
        let mut h = CellMesh::from_points(
            (0..8)
                .map(|i| Point3::new((i & 1) as f64, ((i >> 1) & 1) as f64, (i >> 2) as f64))
                .collect(),
        );
        h.push_cell(CellType::Hexahedron, &[0, 1, 3, 2, 4, 5, 7, 6]);
        assert_eq!(drawable(&h).unwrap().triangles.len(), 12);
        // Bad indices are an error, not a panic.
        let mut bad = CellMesh::from_points(vec![Point3::origin()]);
        bad.push_cell(CellType::Triangle, &[0, 1, 2]);
        assert!(drawable(&bad).is_err());
    }
}
