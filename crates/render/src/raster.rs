//! Z-buffered triangle rasterization, shading, wireframes and 3D polylines.

use nalgebra::{Point3, Vector3};

use crate::color::to_u8;
use crate::draw::walk_line;
use crate::{Camera, Image, Projected, RenderError, Rgb, Rgba};

/// Sub-pixel resolution of the rasterizer: vertices are snapped to
/// `1 / SUBPIXEL` of a pixel before the (exact, integer) edge tests.
pub const SUBPIXEL: i64 = 256;

/// Triangles with a projected vertex farther than this many pixels from the
/// origin are skipped (counted in [`DrawStats::culled`]): it keeps the
/// integer edge functions far from overflow.
pub const GUARD_BAND: f64 = (1u64 << 20) as f64;

/// How triangles are lit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Shading {
    /// No lighting: the colours are written as given (exactly, for uniform
    /// and per-triangle colours). For flat 2D maps.
    Unlit,
    /// Lambert with the face normal: `k = ambient + diffuse |n_f . l|`,
    /// constant over a triangle.
    Flat,
    /// Lambert with the interpolated, renormalized vertex normals (the
    /// area-weighted sums of the face normals around each vertex):
    /// `k = ambient + diffuse |n . l|` per pixel.
    #[default]
    Smooth,
}

/// The colours of a mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Coloring<'a> {
    /// One colour for every triangle.
    Uniform(Rgb),
    /// One colour per vertex, interpolated barycentrically (perspective-
    /// correct under a perspective camera).
    PerVertex(&'a [Rgb]),
    /// One colour per triangle (cell data), constant over the triangle.
    PerTriangle(&'a [Rgb]),
}

/// The light: a headlight, i.e. a directional light along the camera's view
/// direction `l = f`, with two-sided Lambert shading
/// `c = clamp(round(c_base (ambient + diffuse |n . l|)))` (the absolute value
/// lights both sides of open surfaces alike).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lighting {
    /// The ambient term (the factor for surfaces seen edge-on).
    pub ambient: f64,
    /// The diffuse term (added for surfaces facing the camera).
    pub diffuse: f64,
}

impl Default for Lighting {
    /// `ambient = 0.3`, `diffuse = 0.7`: a face seen head-on keeps its
    /// colour exactly, one seen edge-on is at 30 %.
    fn default() -> Self {
        Self {
            ambient: 0.3,
            diffuse: 0.7,
        }
    }
}

/// What one [`Renderer::draw_mesh`] call did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DrawStats {
    /// Triangles rasterized (possibly covering no pixel centre).
    pub drawn: usize,
    /// Triangles skipped: degenerate on screen, with a vertex at or behind
    /// the perspective near plane, or outside the [`GUARD_BAND`].
    pub culled: usize,
    /// Pixels written (passing the depth test; a pixel overwritten by a
    /// nearer triangle counts twice).
    pub pixels: usize,
}

/// Calls `f(x, y, l)` for every pixel whose centre the triangle `v` (in
/// fixed-point pixel coordinates, [`SUBPIXEL`] units) covers, with `l` the
/// screen-space barycentric coordinates of the centre (for `v[0], v[1],
/// v[2]` in the given order).
///
/// The edge functions `E_ab(p) = (b_x - a_x)(p_y - a_y) - (b_y - a_y)(p_x -
/// a_x)` are exact integers; the triangle is reordered so that its area
/// `E_01(v_2) > 0`, and a centre is inside when `E >= 0` for its three
/// edges. A centre exactly on an edge belongs to the triangle that holds
/// the perturbed point `p + (e, e^2)` (`e -> 0+`): since
/// `E(p + (e, e^2)) = E(p) + dx e^2 - dy e`, the edge `a -> b` keeps such
/// centres when `dy < 0`, or `dy = 0` and `dx > 0`. This is a top-left-style
/// rule: triangles sharing an edge or a vertex cover each pixel exactly
/// once. Degenerate triangles cover nothing; pixels
/// outside `width x height` are skipped.
pub(crate) fn raster_triangle(
    v: [[i64; 2]; 3],
    width: u32,
    height: u32,
    mut f: impl FnMut(usize, usize, [f64; 3]),
) {
    let edge = |a: [i64; 2], b: [i64; 2], p: [i64; 2]| {
        (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
    };
    let area = edge(v[0], v[1], v[2]);
    if area == 0 {
        return;
    }
    // Orient counter-clockwise (positive area); `order` maps back.
    let (v, order) = if area > 0 {
        (v, [0, 1, 2])
    } else {
        ([v[0], v[2], v[1]], [0, 2, 1])
    };
    let area = area.abs();
    let half = SUBPIXEL / 2;
    let min_x = v.iter().map(|p| p[0]).min().unwrap_or(0);
    let max_x = v.iter().map(|p| p[0]).max().unwrap_or(0);
    let min_y = v.iter().map(|p| p[1]).min().unwrap_or(0);
    let max_y = v.iter().map(|p| p[1]).max().unwrap_or(0);
    // Pixels whose centre `i SUBPIXEL + half` lies in [min, max].
    let i0 = (min_x - half + SUBPIXEL - 1).div_euclid(SUBPIXEL).max(0);
    let i1 = (max_x - half)
        .div_euclid(SUBPIXEL)
        .min(i64::from(width) - 1);
    let j0 = (min_y - half + SUBPIXEL - 1).div_euclid(SUBPIXEL).max(0);
    let j1 = (max_y - half)
        .div_euclid(SUBPIXEL)
        .min(i64::from(height) - 1);
    if i0 > i1 || j0 > j1 {
        return;
    }
    // Edge k is opposite vertex k: (v1, v2), (v2, v0), (v0, v1).
    let ends = [(v[1], v[2]), (v[2], v[0]), (v[0], v[1])];
    let bias = ends.map(|(a, b)| {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        if dy < 0 || (dy == 0 && dx > 0) { 0 } else { -1 }
    });
    let step_x = ends.map(|(a, b)| -(b[1] - a[1]) * SUBPIXEL);
    let step_y = ends.map(|(a, b)| (b[0] - a[0]) * SUBPIXEL);
    let p0 = [i0 * SUBPIXEL + half, j0 * SUBPIXEL + half];
    let mut row = [0usize, 1, 2].map(|k| edge(ends[k].0, ends[k].1, p0));
    let inv = 1.0 / area as f64;
    for j in j0..=j1 {
        let mut e = row;
        for i in i0..=i1 {
            if e[0] + bias[0] >= 0 && e[1] + bias[1] >= 0 && e[2] + bias[2] >= 0 {
                let l = [e[0] as f64 * inv, e[1] as f64 * inv, e[2] as f64 * inv];
                let mut out = [0.0; 3];
                for k in 0..3 {
                    out[order[k]] = l[k];
                }
                f(i as usize, j as usize, out);
            }
            for k in 0..3 {
                e[k] += step_x[k];
            }
        }
        for k in 0..3 {
            row[k] += step_y[k];
        }
    }
}

/// A projected vertex ready for rasterization.
#[derive(Debug, Clone, Copy)]
struct ScreenVertex {
    fixed: [i64; 2],
    depth: f64,
    /// `1 / w`: 1 for orthographic cameras, `1 / depth` for perspective.
    inv_w: f64,
}

/// Renders meshes and lines into an image through a camera, with a z-buffer.
///
/// Everything is sequential and deterministic: the same calls give the same
/// pixels. Where triangles are exactly equally near, the first one drawn
/// stays (the depth test is `depth < z`).
#[derive(Debug, Clone)]
pub struct Renderer {
    image: Image,
    zbuf: Vec<f64>,
    camera: Camera,
    lighting: Lighting,
    depth_bias: Option<f64>,
}

impl Renderer {
    /// A `width x height` renderer with the image cleared to `background`
    /// and the z-buffer empty (+infinity). Errors for an invalid size.
    pub fn new(
        width: u32,
        height: u32,
        background: Rgba,
        camera: Camera,
    ) -> Result<Self, RenderError> {
        let image = Image::new(width, height, background)?;
        Ok(Self {
            zbuf: vec![f64::INFINITY; width as usize * height as usize],
            image,
            camera,
            lighting: Lighting::default(),
            depth_bias: None,
        })
    }

    /// The camera.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The lighting used by [`Shading::Flat`] and [`Shading::Smooth`].
    pub fn lighting(&self) -> Lighting {
        self.lighting
    }

    /// Sets the lighting.
    pub fn set_lighting(&mut self, lighting: Lighting) {
        self.lighting = lighting;
    }

    /// The depth offset that lines get in their depth test against surfaces
    /// (a line pixel is drawn when `depth <= z + bias`).
    pub fn depth_bias(&self) -> f64 {
        self.depth_bias
            .unwrap_or_else(|| 0.005 * (self.camera.target() - self.camera.eye()).norm())
    }

    /// Sets the line depth offset; `None` restores the default,
    /// `0.005 |target - eye|` (1 % of the bounding-sphere radius for a framed
    /// orthographic camera). Non-finite or negative values are taken as 0.
    pub fn set_depth_bias(&mut self, bias: Option<f64>) {
        self.depth_bias = bias.map(|b| if b.is_finite() && b > 0.0 { b } else { 0.0 });
    }

    /// The image drawn so far.
    pub fn image(&self) -> &Image {
        &self.image
    }

    /// The image, to draw 2D overlays (titles, colour bars) on it.
    pub fn image_mut(&mut self) -> &mut Image {
        &mut self.image
    }

    /// The image, consuming the renderer.
    pub fn into_image(self) -> Image {
        self.image
    }

    /// The depth stored at pixel `(x, y)`; `None` outside the image or where
    /// nothing was drawn.
    pub fn depth_at(&self, x: i64, y: i64) -> Option<f64> {
        if x < 0
            || y < 0
            || x >= i64::from(self.image.width())
            || y >= i64::from(self.image.height())
        {
            return None;
        }
        let z = self.zbuf[y as usize * self.image.width() as usize + x as usize];
        z.is_finite().then_some(z)
    }

    /// Projects `p` into this renderer's image ([`Camera::project`]).
    pub fn project(&self, p: &Point3<f64>) -> Option<Projected> {
        self.camera
            .project(p, self.image.width(), self.image.height())
    }

    /// Rasterizes the triangles with depth test, colours and shading.
    ///
    /// Coverage follows the fill rule of the rasterizer (pixel centres,
    /// shared edges drawn exactly once). At a pixel with screen barycentrics
    /// `l_i`, the perspective-correct weights are
    /// `b_i = (l_i / w_i) / sum_j (l_j / w_j)` (`w = 1` orthographic,
    /// `w = depth` perspective); depth, per-vertex colours and vertex normals
    /// are interpolated with `b_i`. Both windings are drawn (no back-face
    /// culling).
    ///
    /// Errors, before anything is drawn: a non-finite vertex among those the
    /// triangles use, an index out of range, a colour slice of the wrong
    /// length.
    pub fn draw_mesh(
        &mut self,
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
        coloring: Coloring<'_>,
        shading: Shading,
    ) -> Result<DrawStats, RenderError> {
        validate(positions, triangles)?;
        match coloring {
            Coloring::PerVertex(c) if c.len() != positions.len() => {
                return Err(RenderError::LengthMismatch {
                    what: "per-vertex colours",
                    expected: positions.len(),
                    got: c.len(),
                });
            }
            Coloring::PerTriangle(c) if c.len() != triangles.len() => {
                return Err(RenderError::LengthMismatch {
                    what: "per-triangle colours",
                    expected: triangles.len(),
                    got: c.len(),
                });
            }
            _ => {}
        }
        let screen = self.project_all(positions, triangles);
        let normals = match shading {
            Shading::Smooth => vertex_normals(positions, triangles),
            _ => Vec::new(),
        };
        let light = self.camera.forward();
        let Lighting { ambient, diffuse } = self.lighting;
        let perspective = self.camera.is_perspective();
        let (w, h) = (self.image.width(), self.image.height());
        let mut stats = DrawStats::default();
        for (t, tri) in triangles.iter().enumerate() {
            let idx = tri.map(|i| i as usize);
            let sv = match (screen[idx[0]], screen[idx[1]], screen[idx[2]]) {
                (Some(a), Some(b), Some(c)) => [a, b, c],
                _ => {
                    stats.culled += 1;
                    continue;
                }
            };
            let fixed = sv.map(|s| s.fixed);
            let area = (fixed[1][0] - fixed[0][0]) * (fixed[2][1] - fixed[0][1])
                - (fixed[1][1] - fixed[0][1]) * (fixed[2][0] - fixed[0][0]);
            if area == 0 {
                stats.culled += 1;
                continue;
            }
            stats.drawn += 1;
            let p = idx.map(|i| positions[i]);
            let face_n = (p[1] - p[0]).cross(&(p[2] - p[0]));
            let face_k = lambert(&face_n, &light, ambient, diffuse);
            // Base colour: constant, or the three vertex colours.
            let flat_color: Option<[f64; 3]> = match coloring {
                Coloring::Uniform(c) => Some(rgb_f(c)),
                Coloring::PerTriangle(c) => Some(rgb_f(c[t])),
                Coloring::PerVertex(_) => None,
            };
            let vcol: [[f64; 3]; 3] = match coloring {
                Coloring::PerVertex(c) => idx.map(|i| rgb_f(c[i])),
                _ => [[0.0; 3]; 3],
            };
            let vn: [Vector3<f64>; 3] = if shading == Shading::Smooth {
                idx.map(|i| normals[i])
            } else {
                [Vector3::zeros(); 3]
            };
            let inv_w = sv.map(|s| s.inv_w);
            let depth = sv.map(|s| s.depth);
            let zbuf = &mut self.zbuf;
            let image = &mut self.image;
            let width = w as usize;
            raster_triangle(fixed, w, h, |x, y, l| {
                let b = if perspective {
                    let q = [l[0] * inv_w[0], l[1] * inv_w[1], l[2] * inv_w[2]];
                    let s = q[0] + q[1] + q[2];
                    [q[0] / s, q[1] / s, q[2] / s]
                } else {
                    l
                };
                let z = b[0] * depth[0] + b[1] * depth[1] + b[2] * depth[2];
                let o = y * width + x;
                if z.is_nan() || z >= zbuf[o] {
                    return;
                }
                zbuf[o] = z;
                let base = flat_color.unwrap_or_else(|| {
                    [0, 1, 2].map(|ch| b[0] * vcol[0][ch] + b[1] * vcol[1][ch] + b[2] * vcol[2][ch])
                });
                let k = match shading {
                    Shading::Unlit => 1.0,
                    Shading::Flat => face_k,
                    Shading::Smooth => {
                        let n = vn[0] * b[0] + vn[1] * b[1] + vn[2] * b[2];
                        if n.norm_squared() > 0.0 {
                            lambert(&n, &light, ambient, diffuse)
                        } else {
                            face_k
                        }
                    }
                };
                let c = if k == 1.0 {
                    Rgba::new(to_u8(base[0]), to_u8(base[1]), to_u8(base[2]), 255)
                } else {
                    Rgba::new(
                        to_u8(base[0] * k),
                        to_u8(base[1] * k),
                        to_u8(base[2] * k),
                        255,
                    )
                };
                image.put(x as i64, y as i64, c);
                stats.pixels += 1;
            });
        }
        Ok(stats)
    }

    /// Draws every triangle edge as a 1-pixel line in `color`, depth-tested
    /// against the z-buffer with the [`Renderer::depth_bias`] (edges behind a
    /// nearer surface are hidden, edges on the surface drawn over it). Along
    /// a line, depth is interpolated linearly in `1 / depth` for perspective
    /// cameras (exact) and linearly otherwise. Each edge is drawn from its
    /// smaller to its larger vertex index, so an edge shared by two triangles
    /// gives the same pixels twice. Edges with an end behind the perspective
    /// near plane are skipped. The z-buffer is not changed.
    ///
    /// Returns the number of pixels written; errors as
    /// [`Renderer::draw_mesh`].
    pub fn draw_wireframe(
        &mut self,
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
        color: Rgba,
    ) -> Result<usize, RenderError> {
        validate(positions, triangles)?;
        let mut n = 0;
        for tri in triangles {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let (a, b) = if a <= b { (a, b) } else { (b, a) };
                n += self.line_3d(&positions[a as usize], &positions[b as usize], color);
            }
        }
        Ok(n)
    }

    /// Draws the 3D polyline through `points` (closed back to the first
    /// point if `closed`) as 1-pixel lines, depth-tested like
    /// [`Renderer::draw_wireframe`]. Returns the number of pixels written;
    /// errors with [`RenderError::NonFinite`] for a non-finite point.
    pub fn draw_polyline_3d(
        &mut self,
        points: &[Point3<f64>],
        closed: bool,
        color: Rgba,
    ) -> Result<usize, RenderError> {
        for (i, p) in points.iter().enumerate() {
            if !p.coords.iter().all(|x| x.is_finite()) {
                return Err(RenderError::NonFinite {
                    what: "point",
                    index: i,
                });
            }
        }
        let mut n = 0;
        if points.len() == 1 {
            n += self.line_3d(&points[0], &points[0], color);
        }
        for w in points.windows(2) {
            n += self.line_3d(&w[0], &w[1], color);
        }
        if closed && points.len() > 2 {
            n += self.line_3d(&points[points.len() - 1], &points[0], color);
        }
        Ok(n)
    }

    /// One depth-tested line; returns the pixels written.
    fn line_3d(&mut self, a: &Point3<f64>, b: &Point3<f64>, color: Rgba) -> usize {
        let (Some(pa), Some(pb)) = (self.project(a), self.project(b)) else {
            return 0;
        };
        let perspective = self.camera.is_perspective();
        let bias = self.depth_bias();
        let (w, h) = (self.image.width(), self.image.height());
        let width = w as usize;
        let zbuf = &self.zbuf;
        let image = &mut self.image;
        let mut n = 0;
        walk_line([pa.x, pa.y], [pb.x, pb.y], w, h, |x, y, t| {
            if x < 0 || y < 0 || x >= i64::from(w) || y >= i64::from(h) {
                return;
            }
            let z = if perspective {
                1.0 / ((1.0 - t) / pa.depth + t / pb.depth)
            } else {
                (1.0 - t) * pa.depth + t * pb.depth
            };
            if z <= zbuf[y as usize * width + x as usize] + bias {
                image.put(x, y, color);
                n += 1;
            }
        });
        n
    }

    /// Projects the vertices the triangles use; `None` for vertices behind
    /// the near plane or outside the guard band.
    fn project_all(
        &self,
        positions: &[Point3<f64>],
        triangles: &[[u32; 3]],
    ) -> Vec<Option<ScreenVertex>> {
        let mut used = vec![false; positions.len()];
        for t in triangles {
            for &i in t {
                used[i as usize] = true;
            }
        }
        let perspective = self.camera.is_perspective();
        positions
            .iter()
            .zip(&used)
            .map(|(p, &u)| {
                if !u {
                    return None;
                }
                let q = self.project(p)?;
                if !(q.x.abs() <= GUARD_BAND && q.y.abs() <= GUARD_BAND) {
                    return None;
                }
                let s = SUBPIXEL as f64;
                Some(ScreenVertex {
                    fixed: [(q.x * s).round() as i64, (q.y * s).round() as i64],
                    depth: q.depth,
                    inv_w: if perspective { 1.0 / q.depth } else { 1.0 },
                })
            })
            .collect()
    }
}

/// `ambient + diffuse |n . l| / |n|` (`l` a unit vector); `ambient` alone for
/// a zero normal.
fn lambert(n: &Vector3<f64>, l: &Vector3<f64>, ambient: f64, diffuse: f64) -> f64 {
    let len = n.norm();
    if len > 0.0 {
        ambient + diffuse * (n.dot(l) / len).abs()
    } else {
        ambient
    }
}

fn rgb_f(c: Rgb) -> [f64; 3] {
    [f64::from(c.r), f64::from(c.g), f64::from(c.b)]
}

/// Checks the indices and that every vertex a triangle uses is finite.
fn validate(positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> Result<(), RenderError> {
    for (t, tri) in triangles.iter().enumerate() {
        for &i in tri {
            let Some(p) = positions.get(i as usize) else {
                return Err(RenderError::IndexOutOfRange {
                    triangle: t,
                    index: i,
                    vertex_count: positions.len(),
                });
            };
            if !p.coords.iter().all(|x| x.is_finite()) {
                return Err(RenderError::NonFinite {
                    what: "vertex",
                    index: i as usize,
                });
            }
        }
    }
    Ok(())
}

/// Area-weighted vertex normals: `n_v = sum over triangles at v of
/// (p1 - p0) x (p2 - p0)` (unnormalized; twice the area times the unit
/// normal).
fn vertex_normals(positions: &[Point3<f64>], triangles: &[[u32; 3]]) -> Vec<Vector3<f64>> {
    let mut n = vec![Vector3::zeros(); positions.len()];
    for t in triangles {
        let p = t.map(|i| positions[i as usize]);
        let f = (p[1] - p[0]).cross(&(p[2] - p[0]));
        for &i in t {
            n[i as usize] += f;
        }
    }
    n
}
