//! The report page's linked viewer of a placenta subject: the flat image
//! (template space) beside the scan (scanner space), a click on either
//! marking the corresponding point on the other.
//!
//! The map is the run's own, piecewise linear over the tets: a template
//! point `p` in tet `T` of `flattened.vtu` with barycentric coordinates
//! `b` (`p = sum_i b_i y_i`, `y_i` the tet's template corners) goes to the
//! scanner point `x = sum_i b_i x_i`, `x_i` the same tet's corners in
//! `original.vtu` (scanner space); the inverse the other way, locating `x`
//! in the tets of `original.vtu` (docs/ARCHITECTURE.md, "Placenta"). The
//! page needs no server and reads no other file: both directions are
//! precomputed here into tables that go into the page's data
//! ([`viewer_html`]):
//! - [`flat_slice`]: one slice of the flat image (the template grid's `k`
//!   nearest the middle of the flattened mesh's z range) and, per pixel,
//!   the scanner point of its centre (NaN outside the mesh);
//! - [`scan_stack`]: the scan cropped to the mesh's box, downsampled by the
//!   smallest integer step that keeps the subject's data under
//!   [`MAX_BYTES`], and, per voxel inside the mesh, the template point of
//!   its centre (stored for those voxels only, with a mask).
//!
//! A ventricle gets the same between its disk and its surface
//! ([`surface_view`]): per pixel of the disk (`xi`, `zeta` of
//! `anatomy.vtu`) the surface point through the triangle containing it,
//! and that point's pixel in an orthographic rendering of the surface
//! (drawn here with `unfold_render`) where it faces the viewer (its depth
//! within two pixels of the rendering's depth there), so a click on the
//! disk marks the rendering or says the point is on the far side.
//!
//! Values are quantized to bytes (the range of the values shown), the
//! coordinates to little-endian `i16` in units of `scale` mm (the largest
//! magnitude over 32000: 0.01 mm for a box within 320 mm of the origin;
//! `-32768` for NaN), each array base64-encoded in a JSON `<script>` block; the page's script ([`VIEWER_JS`]) interpolates
//! the tables bilinearly within a slice where the four neighbours are
//! inside, else takes the nearest.

use super::report_page::escape;
use super::reports::SubjectReport;
use crate::app::placenta::inputs::flat_name;
use crate::io::{read_image, read_mesh};
use crate::mesh::nalgebra::{Matrix3, Matrix4, Point3, Vector3};
use crate::mesh::spatial::{PlanarTriLocator, TetLocator};
use crate::mesh::{TetMesh, TriMesh, Volume};
use std::fmt::Write as _;
use std::path::Path;

/// The cap on one subject's viewer data in the page, bytes of encoded
/// JSON: a scan whose tables would be larger is downsampled (the page
/// says by how much).
pub const MAX_BYTES: usize = 1_000_000;

/// The cap on the whole page: a subject whose viewer could pass it gets a
/// line saying so instead (a cohort of a hundred placentas keeps a page a
/// browser opens; each subject's files are in its folder).
pub const MAX_PAGE_BYTES: usize = 30_000_000;

/// The viewer's script (plain JavaScript, no library).
pub const VIEWER_JS: &str = include_str!("linked_viewer.js");

/// The viewer's style rules.
pub const VIEWER_CSS: &str = ".lv{display:flex;gap:1em;flex-wrap:wrap;align-items:flex-start}\
.lv canvas{border:1px solid #ddd;cursor:crosshair;image-rendering:pixelated}\
.lv-readout{font-family:monospace;font-size:0.85em}";

/// Why a subject has no linked viewer (the page says so in its place).
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    /// A mesh or image of the subject could not be read.
    #[error("{0}")]
    Read(String),
    /// `flattened.vtu` and `original.vtu` are not the same tets.
    #[error(
        "flattened.vtu ({flat_points} points, {flat_tets} tets) and original.vtu \
         ({points} points, {tets} tets) are not the same mesh"
    )]
    Mismatch {
        /// Points of the flattened mesh.
        flat_points: usize,
        /// Tets of the flattened mesh.
        flat_tets: usize,
        /// Points of the scanner-space mesh.
        points: usize,
        /// Tets of the scanner-space mesh.
        tets: usize,
    },
    /// The flat image or the scan has no voxels, or no slice meets the mesh.
    #[error("{what} is empty")]
    Empty {
        /// Which image.
        what: &'static str,
    },
    /// The surface could not be rendered.
    #[error("cannot render the surface: {0}")]
    Render(String),
    /// Even the coarsest downsampling of the scan is over the cap.
    #[error("the scan's viewer data ({bytes} bytes at step {step}) is over the cap of {cap} bytes")]
    TooLarge {
        /// Encoded bytes at the coarsest step tried.
        bytes: usize,
        /// That step.
        step: usize,
        /// [`MAX_BYTES`].
        cap: usize,
    },
}

/// One slice of the flat image and, per pixel, the scanner point of its
/// centre.
#[derive(Debug, Clone)]
pub struct FlatSlice {
    /// Pixels along i and j.
    pub dims: [usize; 2],
    /// The slice's index along the grid's k.
    pub k: usize,
    /// The template grid's voxel-to-world affine (template mm).
    pub affine: Matrix4<f64>,
    /// The flat image's values, `i + nx j`.
    pub values: Vec<f32>,
    /// The scanner point (mm) of each pixel's centre, 3 per pixel, NaN
    /// outside the flattened mesh.
    pub scanner: Vec<f32>,
}

/// The scan cropped and downsampled, and per voxel inside the mesh the
/// template point of its centre.
#[derive(Debug, Clone)]
pub struct ScanStack {
    /// Voxels along i, j, k.
    pub dims: [usize; 3],
    /// The downsampling step (1: the scan's own voxels).
    pub step: usize,
    /// Voxel-to-world affine of the stack (scanner mm).
    pub affine: Matrix4<f64>,
    /// The scan's values, `i + nx (j + ny k)`.
    pub values: Vec<f32>,
    /// Whether each voxel's centre is inside the mesh.
    pub inside: Vec<bool>,
    /// The template point (mm) of each inside voxel's centre, 3 per inside
    /// voxel, in voxel order.
    pub template: Vec<f32>,
}

/// The point `sum_i b_i corners_i` of the tet `tet` of `to`.
fn barycentric_map(to: &TetMesh, tet: usize, b: &[f64; 4]) -> Point3<f64> {
    let c = to.tet_points(tet);
    Point3::from(c[0].coords * b[0] + c[1].coords * b[1] + c[2].coords * b[2] + c[3].coords * b[3])
}

/// The flat image's slice nearest the middle of `flattened`'s z range, and
/// each pixel centre's scanner point through the tets of `flattened` and
/// `original` (module documentation).
///
/// # Errors
/// [`ViewerError::Empty`] for an image without voxels.
pub fn flat_slice(
    flat: &Volume<f32>,
    flattened: &TetMesh,
    original: &TetMesh,
) -> Result<FlatSlice, ViewerError> {
    let [nx, ny, nz, _] = flat.dims();
    if nx * ny * nz == 0 || flattened.positions.is_empty() {
        return Err(ViewerError::Empty {
            what: "the flat image",
        });
    }
    let (lo, hi) = flattened
        .positions
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.z), hi.max(p.z))
        });
    let mid = Point3::new(0.0, 0.0, 0.5 * (lo + hi));
    // the k whose plane is nearest the middle: along the grid's k axis
    let k = (0..nz)
        .min_by(|&a, &b| {
            let za = flat.voxel_to_world(&Point3::new(0.0, 0.0, a as f64)).z;
            let zb = flat.voxel_to_world(&Point3::new(0.0, 0.0, b as f64)).z;
            (za - mid.z).abs().total_cmp(&(zb - mid.z).abs())
        })
        .unwrap_or(0);
    let locator = TetLocator::new(flattened);
    let mut values = Vec::with_capacity(nx * ny);
    let mut scanner = Vec::with_capacity(3 * nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            values.push(flat.get(i, j, k, 0).unwrap_or(f32::NAN));
            let p = flat.voxel_to_world(&Point3::new(i as f64, j as f64, k as f64));
            match locator.locate(&p) {
                Some((t, b)) => {
                    let x = barycentric_map(original, t, &b);
                    scanner.extend([x.x as f32, x.y as f32, x.z as f32]);
                }
                None => scanner.extend([f32::NAN; 3]),
            }
        }
    }
    Ok(FlatSlice {
        dims: [nx, ny],
        k,
        affine: *flat.affine(),
        values,
        scanner,
    })
}

/// The voxel box of `scan` around `mesh` (two voxels of margin), clamped
/// to the scan: `(lo, hi)` inclusive, or `None` when they do not meet.
fn crop_box(scan: &Volume<f32>, mesh: &TetMesh) -> Option<([usize; 3], [usize; 3])> {
    let dims = scan.dims();
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in &mesh.positions {
        let v = scan.world_to_voxel(p);
        for a in 0..3 {
            lo[a] = lo[a].min(v[a]);
            hi[a] = hi[a].max(v[a]);
        }
    }
    let mut out = ([0; 3], [0; 3]);
    for a in 0..3 {
        let n = dims[a] as f64;
        let l = (lo[a].floor() - 2.0).max(0.0);
        let h = (hi[a].ceil() + 2.0).min(n - 1.0);
        if l.is_nan() || h.is_nan() || l > h {
            return None;
        }
        out.0[a] = l as usize;
        out.1[a] = h as usize;
    }
    Some(out)
}

/// Encoded bytes of a stack of `voxels` voxels of which `inside` are in the
/// mesh: a byte of value and a byte of mask per voxel, 6 bytes per inside
/// voxel, base64 (4 characters per 3 bytes), plus the JSON around.
fn stack_bytes(voxels: usize, inside: usize) -> usize {
    (2 * voxels + 6 * inside).div_ceil(3) * 4 + 512
}

/// Encoded bytes of a flat slice of `pixels` pixels (a byte of value and
/// 6 bytes of scanner point each, base64, plus the JSON around).
fn slice_bytes(pixels: usize) -> usize {
    (7 * pixels).div_ceil(3) * 4 + 512
}

/// The scan cropped to `original`'s box and sampled every `step` voxels,
/// the smallest `step` keeping [`slice_bytes`] of `flat_pixels` plus
/// [`stack_bytes`] within `cap`, with each inside voxel centre's template
/// point through the tets of `original` and `flattened` (module
/// documentation).
///
/// # Errors
/// [`ViewerError::Empty`] when the mesh misses the scan,
/// [`ViewerError::TooLarge`] when no step fits.
pub fn scan_stack(
    scan: &Volume<f32>,
    original: &TetMesh,
    flattened: &TetMesh,
    flat_pixels: usize,
    cap: usize,
) -> Result<ScanStack, ViewerError> {
    let (lo, hi) = crop_box(scan, original).ok_or(ViewerError::Empty { what: "the scan" })?;
    let locator = TetLocator::new(original);
    let mut step = 1;
    loop {
        let dims: [usize; 3] = std::array::from_fn(|a| (hi[a] - lo[a]) / step + 1);
        let mut shift = Matrix4::new_scaling(step as f64);
        shift[(3, 3)] = 1.0;
        for a in 0..3 {
            shift[(a, 3)] = lo[a] as f64;
        }
        let affine = scan.affine() * shift;
        let n = dims.iter().product::<usize>();
        let lower_bound = slice_bytes(flat_pixels) + stack_bytes(n, 0);
        if lower_bound <= cap {
            let mut values = Vec::with_capacity(n);
            let mut inside = Vec::with_capacity(n);
            let mut template = Vec::new();
            for k in 0..dims[2] {
                for j in 0..dims[1] {
                    for i in 0..dims[0] {
                        let (si, sj, sk) = (lo[0] + step * i, lo[1] + step * j, lo[2] + step * k);
                        values.push(scan.get(si, sj, sk, 0).unwrap_or(f32::NAN));
                        let x = affine.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                        match locator.locate(&x) {
                            Some((t, b)) => {
                                let p = barycentric_map(flattened, t, &b);
                                template.extend([p.x as f32, p.y as f32, p.z as f32]);
                                inside.push(true);
                            }
                            None => inside.push(false),
                        }
                    }
                }
            }
            let bytes = slice_bytes(flat_pixels) + stack_bytes(n, template.len() / 3);
            if bytes <= cap {
                return Ok(ScanStack {
                    dims,
                    step,
                    affine,
                    values,
                    inside,
                    template,
                });
            }
        }
        if dims.iter().all(|&d| d == 1) {
            return Err(ViewerError::TooLarge {
                bytes: lower_bound,
                step,
                cap,
            });
        }
        step += 1;
    }
}

impl ScanStack {
    /// The template point of the voxel nearest continuous voxel
    /// coordinates `v` of the stack, if it is inside the mesh (what the
    /// page shows where bilinear interpolation has no four inside
    /// neighbours).
    pub fn template_nearest(&self, v: &Point3<f64>) -> Option<Point3<f64>> {
        let mut idx = [0usize; 3];
        for a in 0..3 {
            let r = v[a].round();
            if !(0.0..self.dims[a] as f64).contains(&r) {
                return None;
            }
            idx[a] = r as usize;
        }
        let flat = idx[0] + self.dims[0] * (idx[1] + self.dims[1] * idx[2]);
        if !self.inside[flat] {
            return None;
        }
        let rank = self.inside[..flat].iter().filter(|&&b| b).count();
        let t = &self.template[3 * rank..3 * rank + 3];
        Some(Point3::new(t[0].into(), t[1].into(), t[2].into()))
    }
}

/// `values` as bytes over their finite range (`0` for NaN and for a
/// constant image) and that range.
fn quantize(values: &[f32]) -> (Vec<u8>, [f64; 2]) {
    let (lo, hi) = values
        .iter()
        .filter(|v| v.is_finite())
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let bytes = values
        .iter()
        .map(|&v| {
            if v.is_finite() && hi > lo {
                (((v - lo) / (hi - lo)) * 255.0).round() as u8
            } else {
                0
            }
        })
        .collect();
    (bytes, [f64::from(lo), f64::from(hi)])
}

/// Coordinates as base64 of little-endian `i16`s in units of the returned
/// scale (mm): the largest finite magnitude over 32000, `-32768` for NaN.
fn b64_coords(values: &[f32]) -> (String, f64) {
    let max = values
        .iter()
        .filter(|v| v.is_finite())
        .fold(0f64, |m, &v| m.max(f64::from(v).abs()));
    let scale = if max > 0.0 { max / 32000.0 } else { 1.0 };
    let bytes: Vec<u8> = values
        .iter()
        .flat_map(|&v| {
            let q = if v.is_finite() {
                (f64::from(v) / scale).round() as i16
            } else {
                i16::MIN
            };
            q.to_le_bytes()
        })
        .collect();
    (b64(&bytes), scale)
}

/// Base64 of bytes (RFC 4648, section 4, `=` padding), what the page's
/// `atob` reads.
fn b64(bytes: &[u8]) -> String {
    use base64::Engine as _;
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

/// A 4x4 matrix row-major.
fn rows(m: &Matrix4<f64>) -> Vec<f64> {
    (0..4)
        .flat_map(|r| (0..4).map(move |c| m[(r, c)]))
        .collect()
}

/// The viewer's data as JSON (`<` written `\u003c`, so it can sit in a
/// `<script>` block).
pub fn viewer_json(name: &str, slice: &FlatSlice, stack: &ScanStack) -> String {
    let (flat_values, flat_range) = quantize(&slice.values);
    let (scan_values, scan_range) = quantize(&stack.values);
    let inverse = |m: &Matrix4<f64>| rows(&m.try_inverse().unwrap_or_else(Matrix4::zeros));
    let mask: Vec<u8> = stack.inside.iter().map(|&b| u8::from(b)).collect();
    let (scanner, scanner_scale) = b64_coords(&slice.scanner);
    let (template, template_scale) = b64_coords(&stack.template);
    let value = serde_json::json!({
        "image": name,
        "flat": {
            "dims": slice.dims, "k": slice.k,
            "affine": rows(&slice.affine), "inverse": inverse(&slice.affine),
            "range": flat_range, "values": b64(&flat_values),
            "scanner": scanner, "scanner_scale": scanner_scale,
        },
        "scan": {
            "dims": stack.dims, "step": stack.step,
            "affine": rows(&stack.affine), "inverse": inverse(&stack.affine),
            "range": scan_range, "values": b64(&scan_values),
            "inside": b64(&mask), "template": template, "template_scale": template_scale,
        },
    });
    value.to_string().replace('<', "\\u003c")
}

/// A placenta subject's data from its folder: `flattened.vtu`,
/// `original.vtu`, the flat image `<name>_flat.nii.gz` and the scan it came
/// from (`scan`).
///
/// # Errors
/// [`ViewerError`]'s.
pub fn placenta_data(
    dir: &Path,
    flat_image: &Path,
    scan: &Path,
) -> Result<(FlatSlice, ScanStack), ViewerError> {
    let read_tets = |name: &str| {
        read_mesh(dir.join(name))
            .map_err(|e| ViewerError::Read(e.to_string()))?
            .to_tet_mesh()
            .map_err(|e| ViewerError::Read(format!("{name}: {e}")))
    };
    let flattened = read_tets("flattened.vtu")?;
    let original = read_tets("original.vtu")?;
    if flattened.tets != original.tets || flattened.positions.len() != original.positions.len() {
        return Err(ViewerError::Mismatch {
            flat_points: flattened.positions.len(),
            flat_tets: flattened.tets.len(),
            points: original.positions.len(),
            tets: original.tets.len(),
        });
    }
    let read = |p: &Path| read_image(p).map_err(|e| ViewerError::Read(e.to_string()));
    let flat = read(flat_image)?;
    let scan = read(scan)?;
    let slice = flat_slice(&flat.volume, &flattened, &original)?;
    let stack = scan_stack(
        &scan.volume,
        &original,
        &flattened,
        slice.dims[0] * slice.dims[1],
        MAX_BYTES,
    )?;
    Ok((slice, stack))
}

/// The linked viewer of subject `id` (its folder `OUT/<id>`): for a
/// placenta whose report names an image, its first image's flat image in
/// the folder and the scan the report says it came from; for a ventricle,
/// its disk and surface ([`ventricle_data`]). Nothing for other organs and
/// for a placenta without images.
pub fn subject_viewer(html: &mut String, out: &Path, id: &str, report: Option<&SubjectReport>) {
    if matches!(
        report,
        Some(SubjectReport::Placenta(_) | SubjectReport::Ventricle(_))
    ) && html.len() + MAX_BYTES > MAX_PAGE_BYTES
    {
        let _ = writeln!(
            html,
            "<h3>Linked viewer</h3>\n<p class=\"warn\">No linked viewer: the page holds {} MB \
             already, its cap is {} MB.</p>",
            html.len() / 1_000_000,
            MAX_PAGE_BYTES / 1_000_000
        );
        return;
    }
    let r = match report {
        Some(SubjectReport::Placenta(r)) => r,
        Some(SubjectReport::Ventricle(_)) => {
            surface_html(html, &escape(id), ventricle_data(&out.join(id)));
            return;
        }
        _ => return,
    };
    let Some(image) = r.report.images.first() else {
        return;
    };
    let dir = out.join(id);
    let flat = dir.join(flat_name(&image.name));
    let data = match &image.input {
        Some(scan) => placenta_data(&dir, &flat, Path::new(scan)),
        None => Err(ViewerError::Read(
            "report.json does not name the scan the flat image came from".into(),
        )),
    };
    viewer_html(html, &escape(id), &image.name, data);
}

/// The viewer's style and script, once at the end of a page that has a
/// viewer (an element of class `lv`).
pub fn page_assets(html: &mut String) {
    if html.contains("<div class=\"lv\"") || html.contains("<div class=\"lvv\"") {
        let _ = writeln!(
            html,
            "<style>{VIEWER_CSS}</style><script>{VIEWER_JS}</script>"
        );
    }
}

/// The viewer's HTML for a subject: the data block and the element the
/// script fills, or the reason it is missing.
pub fn viewer_html(
    html: &mut String,
    id_attr: &str,
    name: &str,
    data: Result<(FlatSlice, ScanStack), ViewerError>,
) {
    html.push_str("<h3>Linked viewer</h3>\n");
    match data {
        Ok((slice, stack)) => {
            let _ = write!(
                html,
                "<p>Click the flat image ({}, template slice k = {}) or the scan: the \
                 other marks the same point (the run's map through the tets, precomputed). \
                 The scan is shown {}.</p>\n<div class=\"lv\" data-subject=\"{id_attr}\">\
                 <script type=\"application/json\" class=\"lv-data\">{}</script></div>\n",
                escape(name),
                slice.k,
                if stack.step == 1 {
                    "at its own voxels".to_string()
                } else {
                    format!(
                        "downsampled: one voxel in {} along each axis, to keep its data \
                         under {} MB",
                        stack.step,
                        MAX_BYTES / 1_000_000
                    )
                },
                viewer_json(name, &slice, &stack),
            );
        }
        Err(e) => {
            let _ = writeln!(
                html,
                "<p class=\"warn\">No linked viewer: {}</p>",
                escape(&e.to_string())
            );
        }
    }
}

/// Pixels per side of the ventricle's disk image (over `[-1, 1]^2`).
pub const DISK_PIXELS: usize = 100;

/// Pixels per side of the ventricle's surface rendering.
pub const RENDER_PIXELS: u32 = 200;

/// A ventricle's disk and an orthographic rendering of its surface, linked:
/// per disk pixel the surface point and, where it faces the viewer, its
/// pixel in the rendering.
#[derive(Debug, Clone)]
pub struct SurfaceView {
    /// The disk image, `i + n j` (`j` down, `zeta` up): `40 + 12 s` for a
    /// pixel in AHA segment `s` (0 without a segment), 0 outside the disk.
    pub disk: Vec<u8>,
    /// The surface point (scanner mm) of each disk pixel's centre, 3 per
    /// pixel, NaN outside the disk.
    pub surface: Vec<f32>,
    /// Where that point is in the rendering (pixel coordinates, the centre
    /// of pixel `(i, j)` at `(i + 0.5, j + 0.5)`), 2 per pixel, NaN where
    /// another part of the surface hides it (the far side) or outside.
    pub render_px: Vec<f32>,
    /// The rendering's grey levels, `RENDER_PIXELS` square, row-major.
    pub render: Vec<u8>,
}

/// The disk `(xi, zeta)` of `mesh`'s point data `xi` and `zeta`.
fn disk_coordinates(mesh: &TriMesh) -> Result<Vec<[f64; 2]>, ViewerError> {
    let field = |name: &str| {
        mesh.point_data
            .get(name)
            .ok_or_else(|| ViewerError::Read(format!("anatomy.vtu has no point array '{name}'")))
    };
    let (xi, zeta) = (field("xi")?, field("zeta")?);
    (0..mesh.positions.len())
        .map(|i| match (xi.get(i, 0), zeta.get(i, 0)) {
            (Some(x), Some(z)) if x.is_finite() && z.is_finite() => Ok([x, z]),
            _ => Err(ViewerError::Read(format!(
                "anatomy.vtu: point {i} has no finite disk coordinates"
            ))),
        })
        .collect()
}

/// The disk image of `mesh` (its disk coordinates `disk`, one per vertex)
/// and the rendering of `mesh` seen along `view_dir` with `up` up: a disk
/// pixel's centre `(xi, zeta)` lies in a triangle of the disk with
/// barycentric coordinates `b`; its surface point is `sum_i b_i x_i` over
/// the same triangle's corners in `mesh`; it is visible where its depth is
/// within two pixels of the rendering's depth at its pixel.
///
/// # Errors
/// [`ViewerError::Render`] for a mesh the renderer refuses (no finite
/// points, `up` along `view_dir`).
pub fn surface_view(
    mesh: &TriMesh,
    disk: &[[f64; 2]],
    view_dir: Vector3<f64>,
    up: Vector3<f64>,
) -> Result<SurfaceView, ViewerError> {
    use crate::figures::render::{
        Camera, Coloring, Lens, Projection, Renderer, Rgb, Rgba, Shading,
    };
    let failed = |e: crate::figures::render::RenderError| ViewerError::Render(e.to_string());
    let size = RENDER_PIXELS;
    let camera = Camera::frame(
        &mesh.positions,
        view_dir,
        up,
        Lens::Orthographic,
        size,
        size,
        0.05,
    )
    .map_err(failed)?;
    let mut renderer = Renderer::new(size, size, Rgba::BLACK, camera).map_err(failed)?;
    renderer
        .draw_mesh(
            &mesh.positions,
            &mesh.triangles,
            Coloring::Uniform(Rgb::new(220, 220, 220)),
            Shading::Smooth,
        )
        .map_err(failed)?;
    let pixel_mm = match camera.projection() {
        Projection::Orthographic { half_height } => 2.0 * half_height / f64::from(size),
        Projection::Perspective { .. } => 0.0,
    };
    let aha = mesh.point_data.get("aha");
    let locator = PlanarTriLocator::new(disk, &mesh.triangles);
    let n = DISK_PIXELS;
    let mut view = SurfaceView {
        disk: Vec::with_capacity(n * n),
        surface: Vec::with_capacity(3 * n * n),
        render_px: Vec::with_capacity(2 * n * n),
        render: renderer
            .image()
            .as_bytes()
            .chunks(4)
            .map(|p| p[0])
            .collect(),
    };
    for j in 0..n {
        for i in 0..n {
            let h = 2.0 / n as f64;
            let uv = [-1.0 + (i as f64 + 0.5) * h, 1.0 - (j as f64 + 0.5) * h];
            let Some((t, b)) = locator.locate(uv) else {
                view.disk.push(0);
                view.surface.extend([f32::NAN; 3]);
                view.render_px.extend([f32::NAN; 2]);
                continue;
            };
            let tri = mesh.triangles[t];
            let x = (0..3).fold(Point3::origin(), |x, c| {
                x + mesh.positions[tri[c] as usize].coords * b[c]
            });
            let nearest = (0..3).max_by(|&a, &c| b[a].total_cmp(&b[c])).unwrap_or(0);
            let segment = aha
                .and_then(|f| f.get(tri[nearest] as usize, 0))
                .filter(|s| (1.0..=17.0).contains(s))
                .unwrap_or(0.0);
            view.disk.push(40 + 12 * segment as u8);
            view.surface.extend([x.x as f32, x.y as f32, x.z as f32]);
            let seen = renderer.project(&x).filter(|p| {
                renderer
                    .depth_at(p.x.floor() as i64, p.y.floor() as i64)
                    .is_some_and(|z| p.depth <= z + 2.0 * pixel_mm)
            });
            match seen {
                Some(p) => view.render_px.extend([p.x as f32, p.y as f32]),
                None => view.render_px.extend([f32::NAN; 2]),
            }
        }
    }
    Ok(view)
}

/// The direction of the largest spread of `points` (the long axis of a
/// ventricle) and a direction across it to look along.
fn side_view(points: &[Point3<f64>]) -> (Vector3<f64>, Vector3<f64>) {
    let n = points.len().max(1) as f64;
    let c = points.iter().fold(Vector3::zeros(), |c, p| c + p.coords) / n;
    let cov = points.iter().fold(Matrix3::zeros(), |m, p| {
        let d = p.coords - c;
        m + d * d.transpose()
    });
    let eig = cov.symmetric_eigen();
    let k = eig.eigenvalues.imax();
    let axis: Vector3<f64> = eig.eigenvectors.column(k).into();
    let least = (0..3)
        .min_by(|&a, &b| axis[a].abs().total_cmp(&axis[b].abs()))
        .unwrap_or(0);
    let across = axis.cross(&Vector3::ith(least, 1.0));
    (across, axis)
}

/// A ventricle subject's data from its folder: `anatomy.vtu` (scanner
/// space) with its disk coordinates.
///
/// # Errors
/// [`ViewerError`]'s.
pub fn ventricle_data(dir: &Path) -> Result<SurfaceView, ViewerError> {
    let mesh = read_mesh(dir.join("anatomy.vtu"))
        .map_err(|e| ViewerError::Read(e.to_string()))?
        .to_tri_mesh()
        .map_err(|e| ViewerError::Read(format!("anatomy.vtu: {e}")))?;
    let disk = disk_coordinates(&mesh)?;
    let (view_dir, up) = side_view(&mesh.positions);
    surface_view(&mesh, &disk, view_dir, up)
}

/// The ventricle viewer's data as JSON (`<` written `\u003c`).
pub fn surface_json(view: &SurfaceView) -> String {
    let (surface, surface_scale) = b64_coords(&view.surface);
    let (render_px, render_px_scale) = b64_coords(&view.render_px);
    let value = serde_json::json!({
        "disk": {
            "n": DISK_PIXELS, "values": b64(&view.disk),
            "surface": surface, "surface_scale": surface_scale,
            "render_px": render_px, "render_px_scale": render_px_scale,
        },
        "render": {"w": RENDER_PIXELS, "h": RENDER_PIXELS, "values": b64(&view.render)},
    });
    value.to_string().replace('<', "\\u003c")
}

/// The ventricle viewer's HTML, or the reason it is missing.
fn surface_html(html: &mut String, id_attr: &str, data: Result<SurfaceView, ViewerError>) {
    html.push_str("<h3>Linked viewer</h3>\n");
    match data {
        Ok(view) => {
            let _ = write!(
                html,
                "<p>Click the disk (the AHA segments): the rendering of the surface (scanner \
                 space, seen from the side) marks the same point, or says it is on the far \
                 side.</p>\n<div class=\"lvv\" data-subject=\"{id_attr}\">\
                 <script type=\"application/json\" class=\"lv-data\">{}</script></div>\n",
                surface_json(&view),
            );
        }
        Err(e) => {
            let _ = writeln!(
                html,
                "<p class=\"warn\">No linked viewer: {}</p>",
                escape(&e.to_string())
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::{PlacentaParams, Pose, placenta_slab};

    /// A small generated subject: a bent slab in a pose (scanner space),
    /// its "flattened" copy through a smooth map (a rotation about z, the
    /// thickness halved, a mild bend in x), a flat image on a 5 mm template
    /// grid over the flattened mesh and a 4 mm scan over the slab.
    fn subject() -> (TetMesh, TetMesh, Volume<f32>, Volume<f32>) {
        let original = placenta_slab(&PlacentaParams {
            length: 80.0,
            width: 60.0,
            thickness_centre: 16.0,
            thickness_rim: 8.0,
            cells_radial: 4,
            cells_through: 2,
            pose: Pose::new([10.0, -5.0, 30.0], [10.0, 5.0, 20.0]),
            ..PlacentaParams::default()
        })
        .unwrap()
        .mesh;
        let (s, c) = 0.3f64.sin_cos();
        let flattened = TetMesh::new(
            original
                .positions
                .iter()
                .map(|p| {
                    Point3::new(
                        c * p.x - s * p.y + 0.002 * p.y * p.y,
                        s * p.x + c * p.y,
                        0.5 * (p.z - 30.0),
                    )
                })
                .collect(),
            original.tets.clone(),
        );
        let grid = |mesh: &TetMesh, h: f64, value: &dyn Fn(&Point3<f64>) -> f32| {
            let (mut lo, mut hi) = (
                Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY),
                Point3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY),
            );
            for p in &mesh.positions {
                lo = lo.inf(p);
                hi = hi.sup(p);
            }
            let dims: [usize; 3] =
                std::array::from_fn(|a| ((hi[a] - lo[a]) / h).ceil() as usize + 3);
            let mut affine = Matrix4::new_scaling(h);
            affine[(3, 3)] = 1.0;
            for a in 0..3 {
                affine[(a, 3)] = lo[a] - h;
            }
            let mut data = Vec::new();
            for k in 0..dims[2] {
                for j in 0..dims[1] {
                    for i in 0..dims[0] {
                        data.push(value(
                            &affine.transform_point(&Point3::new(i as f64, j as f64, k as f64)),
                        ));
                    }
                }
            }
            Volume::new([dims[0], dims[1], dims[2], 1], affine, data).unwrap()
        };
        let flat = grid(&flattened, 5.0, &|p| (p.x + p.y) as f32);
        let scan = grid(&original, 4.0, &|p| (p.x - p.z) as f32);
        (original, flattened, flat, scan)
    }

    /// The tet of `from` containing `p` and its barycentric coordinates, by
    /// trying every tet (Cramer's rule on the 3x3 system), mapped to `to`.
    fn direct_map(from: &TetMesh, to: &TetMesh, p: &Point3<f64>) -> Option<Point3<f64>> {
        let mut best: Option<(f64, Point3<f64>)> = None;
        for (t, tet) in from.tets.iter().enumerate() {
            let c = from.tet_points(t);
            let m = crate::mesh::nalgebra::Matrix3::from_columns(&[
                c[1] - c[0],
                c[2] - c[0],
                c[3] - c[0],
            ]);
            let Some(inv) = m.try_inverse() else { continue };
            let l = inv * (p - c[0]);
            let b = [1.0 - l.sum(), l.x, l.y, l.z];
            let min = b.iter().copied().fold(f64::INFINITY, f64::min);
            if min >= -1e-9 && best.as_ref().is_none_or(|(m, _)| min > *m) {
                let q = tet.iter().zip(b).fold(Point3::origin(), |q, (&v, w)| {
                    q + to.positions[v as usize].coords * w
                });
                best = Some((min, q));
            }
        }
        best.map(|(_, q)| q)
    }

    fn at(table: &[f32], i: usize) -> Option<Point3<f64>> {
        let t = &table[3 * i..3 * i + 3];
        t[0].is_finite()
            .then(|| Point3::new(t[0].into(), t[1].into(), t[2].into()))
    }

    #[test]
    fn a_template_pixel_maps_to_the_direct_barycentric_scanner_point() {
        let (original, flattened, flat, _) = subject();
        let slice = flat_slice(&flat, &flattened, &original).unwrap();
        let [nx, ny] = slice.dims;
        let mut inside = 0;
        for j in 0..ny {
            for i in 0..nx {
                let p = flat.voxel_to_world(&Point3::new(i as f64, j as f64, slice.k as f64));
                let direct = direct_map(&flattened, &original, &p);
                let table = at(&slice.scanner, i + nx * j);
                assert_eq!(direct.is_some(), table.is_some(), "pixel {i},{j}");
                if let (Some(d), Some(t)) = (direct, table) {
                    assert!((d - t).norm() < 1e-3, "pixel {i},{j}: {d} vs {t}");
                    inside += 1;
                }
            }
        }
        assert!(inside > 20, "{inside} pixels inside");
        // the slice is the one through the middle of the flattened mesh
        let z = flat
            .voxel_to_world(&Point3::new(0.0, 0.0, slice.k as f64))
            .z;
        let (lo, hi) = flattened
            .positions
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), p| (l.min(p.z), h.max(p.z)));
        assert!(
            (z - 0.5 * (lo + hi)).abs() <= 2.5,
            "slice at z = {z}, mesh {lo}..{hi}"
        );
    }

    #[test]
    fn scanner_and_back_returns_within_half_a_voxel() {
        let (original, flattened, flat, scan) = subject();
        let slice = flat_slice(&flat, &flattened, &original).unwrap();
        let stack = scan_stack(&scan, &original, &flattened, 0, MAX_BYTES).unwrap();
        assert_eq!(stack.step, 1);
        let inverse = stack.affine.try_inverse().unwrap();
        // the largest stretch of the template map (the 0.002 y^2 bend over
        // |y| < 60): 1 + 0.24
        let half_diagonal = 0.5 * 3f64.sqrt() * 4.0 * 1.24;
        let mut checked = 0;
        for (i, chunk) in slice.scanner.chunks(3).enumerate() {
            let Some(x) = at(&slice.scanner, i).filter(|_| chunk[0].is_finite()) else {
                continue;
            };
            let (pi, pj) = (i % slice.dims[0], i / slice.dims[0]);
            let p = flat.voxel_to_world(&Point3::new(pi as f64, pj as f64, slice.k as f64));
            // the nearest voxel may be just outside the mesh at its surface
            if let Some(back) = stack.template_nearest(&inverse.transform_point(&x)) {
                let d = (back - p).norm();
                assert!(d <= half_diagonal, "pixel {pi},{pj}: {d} mm");
                checked += 1;
            }
        }
        assert!(checked > 20, "{checked} round trips");
        // every inside voxel's template point is the direct inverse map
        let mut rank = 0;
        for (n, &inside) in stack.inside.iter().enumerate() {
            let [nx, ny, _] = stack.dims;
            let v = Point3::new(
                (n % nx) as f64,
                ((n / nx) % ny) as f64,
                (n / (nx * ny)) as f64,
            );
            let x = stack.affine.transform_point(&v);
            let direct = direct_map(&original, &flattened, &x);
            assert_eq!(direct.is_some(), inside, "voxel {v}");
            if let Some(d) = direct {
                assert!((d - at(&stack.template, rank).unwrap()).norm() < 1e-3);
                rank += 1;
            }
        }
    }

    #[test]
    fn the_size_cap_holds_by_downsampling() {
        let (original, flattened, flat, scan) = subject();
        let slice = flat_slice(&flat, &flattened, &original).unwrap();
        let pixels = slice.dims[0] * slice.dims[1];
        let full = scan_stack(&scan, &original, &flattened, pixels, MAX_BYTES).unwrap();
        let full_len = viewer_json("t2", &slice, &full).len();
        assert!(full_len <= MAX_BYTES);
        let cap = full_len / 3;
        let small = scan_stack(&scan, &original, &flattened, pixels, cap).unwrap();
        assert!(small.step > 1);
        let len = viewer_json("t2", &slice, &small).len();
        assert!(len <= cap, "{len} bytes over the cap {cap}");
        // the coarser stack keeps the grid: its voxel (a, b, c) is the
        // scan's (lo + step a, ...)
        assert_eq!(
            small.affine[(0, 0)],
            full.affine[(0, 0)] * small.step as f64
        );
        // a cap below the flat slice alone cannot be met
        assert!(matches!(
            scan_stack(&scan, &original, &flattened, pixels, 1000),
            Err(ViewerError::TooLarge { .. })
        ));
    }

    /// A ventricle cup cut below its equator (a graph over the x-y plane,
    /// axis z, apex down) with the disk `(x, y) / r_max`, its AHA array all 1.
    fn cup() -> (TriMesh, Vec<[f64; 2]>) {
        use crate::mesh::shapes::{VentricleParams, ventricle_cup};
        let mut mesh = ventricle_cup(&VentricleParams {
            base_above_equator: -0.2,
            ..VentricleParams::default()
        })
        .unwrap()
        .surface;
        let r = mesh
            .positions
            .iter()
            .map(|p| p.x.hypot(p.y))
            .fold(0.0, f64::max);
        let disk: Vec<[f64; 2]> = mesh.positions.iter().map(|p| [p.x / r, p.y / r]).collect();
        mesh.point_data.insert(crate::mesh::Field::scalars(
            "aha",
            vec![1.0; mesh.positions.len()],
        ));
        (mesh, disk)
    }

    #[test]
    fn a_disk_pixel_maps_to_the_surface_and_shows_where_it_faces_the_viewer() {
        let (mesh, disk) = cup();
        let r = disk.iter().zip(&mesh.positions).find(|(d, _)| d[0] != 0.0);
        let scale = r.map_or(1.0, |(d, p)| p.x / d[0]);
        // seen along +y: the near wall is y < 0
        let view = surface_view(&mesh, &disk, Vector3::y(), Vector3::z()).unwrap();
        let n = DISK_PIXELS;
        let (mut near, mut far) = (0, 0);
        for j in 0..n {
            for i in 0..n {
                let k = i + n * j;
                let Some(x) = at(&view.surface, k) else {
                    assert_eq!(view.disk[k], 0);
                    continue;
                };
                assert_eq!(view.disk[k], 52, "segment 1's grey");
                // the disk is (x, y) / r: the pixel centre's (x, y) back
                let h = 2.0 / n as f64;
                let uv = [-1.0 + (i as f64 + 0.5) * h, 1.0 - (j as f64 + 0.5) * h];
                assert!((x.x - uv[0] * scale).abs() < 1e-3 && (x.y - uv[1] * scale).abs() < 1e-3);
                let shown = view.render_px[2 * k].is_finite();
                if x.y < -0.3 * scale {
                    assert!(shown, "near point {x} not shown");
                    let (px, py) = (view.render_px[2 * k], view.render_px[2 * k + 1]);
                    let size = RENDER_PIXELS as f32;
                    assert!((0.0..size).contains(&px) && (0.0..size).contains(&py));
                    let grey = view.render[py as usize * RENDER_PIXELS as usize + px as usize];
                    assert!(grey > 0, "the marker's pixel is the surface's");
                    near += 1;
                } else if x.y > 0.3 * scale {
                    assert!(!shown, "far point {x} shown");
                    far += 1;
                }
            }
        }
        assert!(near > 100 && far > 100, "{near} near, {far} far");
        assert!(surface_json(&view).len() < MAX_BYTES / 2);
    }

    #[test]
    fn a_surface_without_disk_coordinates_is_refused() {
        let (mut mesh, _) = cup();
        let err = disk_coordinates(&mesh).unwrap_err();
        assert!(err.to_string().contains("'xi'"), "{err}");
        let (xi, zeta) = (
            vec![0.0; mesh.positions.len()],
            vec![f64::NAN; mesh.positions.len()],
        );
        mesh.point_data
            .insert(crate::mesh::Field::scalars("xi", xi));
        mesh.point_data
            .insert(crate::mesh::Field::scalars("zeta", zeta));
        let err = disk_coordinates(&mesh).unwrap_err();
        assert!(
            err.to_string().contains("no finite disk coordinates"),
            "{err}"
        );
    }

    #[test]
    fn base64_matches_the_rfc_vectors() {
        for (bytes, text) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(b64(bytes.as_bytes()), text);
        }
        assert_eq!(b64(&[0xff, 0xfe, 0xfd]), "//79");
    }

    proptest::proptest! {
        #[test]
        fn coordinates_round_trip_within_half_a_unit(
            values in proptest::collection::vec(-400.0f32..400.0, 1..50),
            nan in 0usize..50,
        ) {
            let mut values = values;
            let nan = nan % values.len();
            values[nan] = f32::NAN;
            let (text, scale) = b64_coords(&values);
            let bytes: Vec<u8> = text
                .as_bytes()
                .chunks(4)
                .flat_map(|c| {
                    let six = |b: u8| {
                        u32::try_from(
                            b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/"
                                .iter()
                                .position(|&a| a == b)
                                .unwrap_or(0),
                        )
                        .unwrap_or(0)
                    };
                    let w = c.iter().fold(0u32, |w, &b| w << 6 | six(b));
                    let pad = c.iter().filter(|&&b| b == b'=').count();
                    w.to_be_bytes()[1..4 - pad].to_vec()
                })
                .collect();
            for (i, v) in values.iter().enumerate() {
                let q = i16::from_le_bytes([bytes[2 * i], bytes[2 * i + 1]]);
                if v.is_nan() {
                    proptest::prop_assert_eq!(q, i16::MIN);
                } else {
                    proptest::prop_assert!((f64::from(q) * scale - f64::from(*v)).abs() <= 0.5 * scale + 1e-9);
                    proptest::prop_assert!(scale <= 400.0 / 32000.0 + 1e-12);
                }
            }
        }
    }

    #[test]
    fn a_subject_without_its_files_gets_the_reason_not_a_viewer() {
        let dir = tempfile::tempdir().unwrap();
        let data = placenta_data(dir.path(), &dir.path().join("t2_flat.nii.gz"), dir.path());
        let mut html = String::new();
        viewer_html(&mut html, "p1", "t2", data);
        assert!(html.contains("No linked viewer: "), "{html}");
        assert!(html.contains("flattened.vtu"), "{html}");
        page_assets(&mut html);
        assert!(!html.contains("<script"), "no viewer, no script");
    }

    #[test]
    fn mismatched_meshes_are_refused() {
        let (original, flattened, _, _) = subject();
        let dir = tempfile::tempdir().unwrap();
        let opts = crate::io::WriteOptions::default();
        let mut fewer = flattened.clone();
        fewer.tets.pop();
        crate::io::write_mesh(dir.path().join("flattened.vtu"), &(&fewer).into(), &opts).unwrap();
        crate::io::write_mesh(dir.path().join("original.vtu"), &(&original).into(), &opts).unwrap();
        let err = placenta_data(dir.path(), dir.path(), dir.path()).unwrap_err();
        assert!(matches!(err, ViewerError::Mismatch { .. }), "{err}");
    }
}
