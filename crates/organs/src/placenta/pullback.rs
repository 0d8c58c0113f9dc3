//! The image pull-back (ALGORITHMS 2.7): resampling a scanner-frame image
//! into the template frame through the flattening map.
//!
//! The placenta pipeline maps a tet mesh with rest positions `Z` (scanner
//! frame, mm) to flattened positions `X` (template frame, mm); the map is
//! piecewise linear on the tets. To view an image in the template, every
//! voxel centre `p` of an axis-aligned [`TemplateGrid`] covering `X` is
//! pulled back to the scanner frame:
//!
//! 1. find the tet `k = [x0, x1, x2, x3]` of `X` containing `p` (a BVH over
//!    the tets, [`TetLocator`], never a linear scan);
//! 2. its barycentric coordinates `alpha = (a1, a2, a3, a4)` (one per corner,
//!    in order): with the edge matrix `Ds = [x1 - x0 | x2 - x0 | x3 - x0]`,
//!    `[a2 a3 a4]^T = Ds^-1 (p - x0)` and `a1 = 1 - a2 - a3 - a4`;
//! 3. the source point `z = sum_i alpha_i z_i` (the same combination of the
//!    tet's rest positions `z_i`);
//! 4. the image value at `z` by trilinear interpolation at the continuous
//!    voxel coordinates `v = A^-1 (z, 1)^T` (`A` the image's voxel-to-world
//!    affine): `sum_{corners c} w_c f(c)`, `w_c = prod_axis (1 - |v_a - c_a|)`.
//!
//! Voxels outside the mesh, or whose source point lies outside the image
//! (more than half a voxel beyond its outer voxel centres), get 0. Steps 1-3
//! depend on the meshes only, so they are done once ([`PullbackTable::new`])
//! and the table is applied to every image and every frame of a 4D series
//! ([`PullbackTable::apply`]).

use super::error::PullbackError;
use nalgebra::{Matrix4, Point3, Vector3};
use rayon::prelude::*;
use unfold_mesh::spatial::TetLocator;
use unfold_mesh::{TetMesh, Volume};

/// The largest template grid accepted: `512^3` voxels (512 MiB per f32
/// frame).
pub const MAX_VOXELS: usize = 512 * 512 * 512;

/// An axis-aligned grid in the template frame.
///
/// Voxel `(i, j, k)` has its centre at `origin + (i sx, j sy, k sz)` (mm);
/// linear indices run x fastest, `i + nx (j + ny k)`, as in
/// [`Volume`]. The voxel-to-world affine is [`TemplateGrid::affine`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TemplateGrid {
    /// World (template-frame) coordinates of the centre of voxel `(0, 0, 0)`,
    /// mm.
    pub origin: [f64; 3],
    /// Voxel size along x, y and z, mm (all finite and positive).
    pub spacing: [f64; 3],
    /// Number of voxels along x, y and z (all at least 1).
    pub dims: [usize; 3],
}

impl TemplateGrid {
    /// The grid covering `points` at `spacing` mm.
    ///
    /// The points' bounding box `[lo, hi]` is grown by half a voxel on every
    /// side; along each axis `n = ceil((hi - lo) / s) + 1` voxels cover it
    /// (`n s >= hi - lo + s`), and the grid is centred on the box, so every
    /// point lies at least half a voxel inside the grid's outer boundary
    /// ([`TemplateGrid::bounds`]).
    ///
    /// # Errors
    /// [`PullbackError::Spacing`] for a non-finite or non-positive spacing,
    /// [`PullbackError::NoPoints`] for no points,
    /// [`PullbackError::NotFinite`] for a non-finite point,
    /// [`PullbackError::BoxTooLarge`] for a box of infinite extent and
    /// [`PullbackError::GridTooLarge`] for a grid of more than
    /// [`MAX_VOXELS`] voxels (with a spacing that would fit).
    pub fn covering(points: &[Point3<f64>], spacing: [f64; 3]) -> Result<Self, PullbackError> {
        check_spacing(spacing)?;
        if points.is_empty() {
            return Err(PullbackError::NoPoints);
        }
        check_finite_points("point", points)?;
        let (lo, hi) = bounds_of(points);
        let ext: [f64; 3] = std::array::from_fn(|a| hi[a] - lo[a]);
        if ext.iter().any(|e| !e.is_finite()) {
            return Err(PullbackError::BoxTooLarge { lo, hi });
        }
        let counts = dims_for(ext, spacing);
        let total: f64 = counts.iter().product();
        if total.is_nan() || total > MAX_VOXELS as f64 {
            return Err(PullbackError::GridTooLarge {
                spacing,
                lo,
                hi,
                fitting: fitting_spacing(ext, spacing),
            });
        }
        let dims = counts.map(|c| c as usize);
        let origin = std::array::from_fn(|a| {
            0.5 * (lo[a] + hi[a]) - 0.5 * (dims[a] - 1) as f64 * spacing[a]
        });
        Ok(TemplateGrid {
            origin,
            spacing,
            dims,
        })
    }

    /// The grid of a fixed box `[min, max]` at `spacing` mm: voxel centres
    /// at `min + i s` for `i = 0 .. n - 1`, `n = floor((max - min) / s +
    /// 1e-9) + 1` along each axis, so the first centre is `min` and the last
    /// at or below `max` (up to rounding). The same box and spacing give the
    /// same grid whatever the mesh.
    ///
    /// # Errors
    /// [`PullbackError::Spacing`], [`PullbackError::GridBox`] for a bad box,
    /// [`PullbackError::GridSize`] for more than [`MAX_VOXELS`] voxels.
    pub fn fixed(min: [f64; 3], max: [f64; 3], spacing: [f64; 3]) -> Result<Self, PullbackError> {
        check_spacing(spacing)?;
        let ok = (0..3).all(|a| min[a].is_finite() && max[a].is_finite() && max[a] >= min[a]);
        if !ok {
            return Err(PullbackError::GridBox { min, max });
        }
        let counts: [f64; 3] =
            std::array::from_fn(|a| ((max[a] - min[a]) / spacing[a] + 1e-9).floor() + 1.0);
        let limit = MAX_VOXELS as f64;
        if counts.iter().any(|c| !c.is_finite() || *c > limit)
            || counts.iter().product::<f64>() > limit
        {
            return Err(PullbackError::GridSize {
                dims: counts.map(|c| c.min(limit) as usize),
                limit: MAX_VOXELS,
            });
        }
        Ok(TemplateGrid {
            origin: min,
            spacing,
            dims: counts.map(|c| c as usize),
        })
    }

    /// Checks a grid built by hand: finite origin, finite positive spacing,
    /// no zero dimension and at most [`MAX_VOXELS`] voxels.
    ///
    /// # Errors
    /// [`PullbackError::Spacing`], [`PullbackError::Origin`] or
    /// [`PullbackError::GridSize`] for the first that fails.
    pub fn validate(&self) -> Result<(), PullbackError> {
        check_spacing(self.spacing)?;
        if !self.origin.iter().all(|x| x.is_finite()) {
            return Err(PullbackError::Origin {
                origin: self.origin,
            });
        }
        if !fits(self.dims) {
            return Err(PullbackError::GridSize {
                dims: self.dims,
                limit: MAX_VOXELS,
            });
        }
        Ok(())
    }

    /// The voxel-to-world affine: `diag(sx, sy, sz)` with translation
    /// `origin`, i.e. `p = origin + diag(spacing) (i, j, k)^T`.
    pub fn affine(&self) -> Matrix4<f64> {
        let mut m = Matrix4::identity();
        for a in 0..3 {
            m[(a, a)] = self.spacing[a];
            m[(a, 3)] = self.origin[a];
        }
        m
    }

    /// Number of voxels, `nx ny nz` (saturating).
    pub fn num_voxels(&self) -> usize {
        self.dims
            .iter()
            .fold(1usize, |acc, &d| acc.saturating_mul(d))
    }

    /// The centre of voxel `(i, j, k)`: `origin + (i sx, j sy, k sz)`.
    #[inline]
    pub fn centre(&self, i: usize, j: usize, k: usize) -> Point3<f64> {
        Point3::new(
            self.origin[0] + i as f64 * self.spacing[0],
            self.origin[1] + j as f64 * self.spacing[1],
            self.origin[2] + k as f64 * self.spacing[2],
        )
    }

    /// The linear index of voxel `(i, j, k)`: `i + nx (j + ny k)`.
    #[inline]
    pub fn linear_index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// The voxel `(i, j, k)` of a linear index (inverse of
    /// [`TemplateGrid::linear_index`]).
    #[inline]
    pub fn voxel(&self, index: usize) -> [usize; 3] {
        let [nx, ny, _] = self.dims;
        [index % nx, (index / nx) % ny, index / (nx * ny)]
    }

    /// The grid's outer boundary (the union of its voxels as boxes):
    /// `origin - spacing / 2` to `origin + (dims - 1/2) spacing`.
    pub fn bounds(&self) -> (Point3<f64>, Point3<f64>) {
        (
            Point3::from(std::array::from_fn::<f64, 3, _>(|a| {
                self.origin[a] - 0.5 * self.spacing[a]
            })),
            Point3::from(std::array::from_fn::<f64, 3, _>(|a| {
                self.origin[a] + (self.dims[a] as f64 - 0.5) * self.spacing[a]
            })),
        )
    }
}

/// A grid of voxel centres that a [`PullbackTable`] samples: the
/// axis-aligned [`TemplateGrid`] for a pull-back into the template, a
/// scanner image's own grid ([`super::pushback::ScannerGrid`]) for the way
/// back. Linear indices run x fastest, `i + nx (j + ny k)`.
pub trait VoxelGrid: Copy + Send + Sync {
    /// Number of voxels along each axis.
    fn dims(&self) -> [usize; 3];
    /// World coordinates (mm) of the centre of voxel `(i, j, k)`.
    fn centre(&self, i: usize, j: usize, k: usize) -> Point3<f64>;
    /// The voxel-to-world affine of the output volume.
    fn affine(&self) -> Matrix4<f64>;
    /// Checks the grid (finite, no zero dimension, at most [`MAX_VOXELS`]).
    ///
    /// # Errors
    /// The [`PullbackError`] of the first check that fails.
    fn validate(&self) -> Result<(), PullbackError>;
    /// Number of voxels, `nx ny nz` (saturating).
    fn num_voxels(&self) -> usize {
        self.dims()
            .iter()
            .fold(1usize, |acc, &d| acc.saturating_mul(d))
    }
}

impl VoxelGrid for TemplateGrid {
    fn dims(&self) -> [usize; 3] {
        self.dims
    }

    fn centre(&self, i: usize, j: usize, k: usize) -> Point3<f64> {
        TemplateGrid::centre(self, i, j, k)
    }

    fn affine(&self) -> Matrix4<f64> {
        TemplateGrid::affine(self)
    }

    fn validate(&self) -> Result<(), PullbackError> {
        TemplateGrid::validate(self)
    }
}

/// The voxel -> source-point table: for every voxel of a grid (by default a
/// [`TemplateGrid`]) whose centre lies inside the flattened mesh, its linear
/// index (x fastest) and the source point in the original (scanner) frame.
/// Built once, applied to every image and every frame.
///
/// The roles of the two meshes are symmetric: built on a scanner grid with
/// the original mesh as `mapped` and the flattened positions as `source`,
/// the same table carries template-space images back to the scanner
/// ([`super::pushback`]).
#[derive(Debug, Clone)]
pub struct PullbackTable<G: VoxelGrid = TemplateGrid> {
    grid: G,
    /// Linear voxel indices, strictly increasing.
    voxels: Vec<u32>,
    /// Source points (scanner frame), one per entry of `voxels`.
    sources: Vec<Point3<f64>>,
    /// Bounding box of the rest positions (scanner frame), for messages.
    source_box: ([f64; 3], [f64; 3]),
}

impl<G: VoxelGrid> PullbackTable<G> {
    /// Builds the table.
    ///
    /// `mapped` are the flattened positions `X` (template frame), `tets` the
    /// connectivity, `source` the rest positions `Z` in the scanner frame
    /// (same length as `mapped`). For every voxel centre `p` of `grid`, the
    /// tet `[x0, x1, x2, x3]` of `X` containing `p` is found with a
    /// [`TetLocator`] (a BVH; points on shared faces and on the boundary, up
    /// to round-off, count as inside), its barycentric coordinates
    /// `alpha = (a1, a2, a3, a4)` are `[a2 a3 a4]^T = Ds^-1 (p - x0)`,
    /// `Ds = [x1 - x0 | x2 - x0 | x3 - x0]`, `a1 = 1 - a2 - a3 - a4`, and the
    /// source point is `z = sum_i alpha_i z_i` (`z_i` the rest positions of
    /// the same corners). Where the flattened mesh folds over itself
    /// (inverted tets), the tet in which `p` is deepest is used; degenerate
    /// (flat) tets of `X` are skipped.
    ///
    /// The voxel loop runs in parallel (rayon) over grid rows, which are
    /// concatenated in order, so the table is deterministic and sorted by
    /// voxel index.
    ///
    /// # Errors
    /// An invalid grid (as [`TemplateGrid::validate`]);
    /// [`PullbackError::LengthMismatch`], [`PullbackError::EmptyMesh`],
    /// [`PullbackError::NotFinite`], [`PullbackError::VertexOutOfRange`] or
    /// [`PullbackError::AllTetsFlat`] for a mesh that cannot be used.
    pub fn new(
        grid: G,
        mapped: &[Point3<f64>],
        tets: &[[u32; 4]],
        source: &[Point3<f64>],
    ) -> Result<Self, PullbackError> {
        grid.validate()?;
        if mapped.len() != source.len() {
            return Err(PullbackError::LengthMismatch {
                mapped: mapped.len(),
                sources: source.len(),
            });
        }
        if mapped.is_empty() || tets.is_empty() {
            return Err(PullbackError::EmptyMesh {
                vertices: mapped.len(),
                tets: tets.len(),
            });
        }
        check_finite_points("mapped position", mapped)?;
        check_finite_points("source position", source)?;
        let n = mapped.len();
        if let Some((t, tet)) = tets
            .iter()
            .enumerate()
            .find(|(_, tet)| tet.iter().any(|&v| v as usize >= n))
        {
            return Err(PullbackError::VertexOutOfRange {
                tet: t,
                corners: *tet,
                vertices: n,
            });
        }
        let locator = TetLocator::new(&TetMesh::new(mapped.to_vec(), tets.to_vec()));
        if locator.is_empty() {
            return Err(PullbackError::AllTetsFlat { tets: tets.len() });
        }

        let [nx, ny, nz] = grid.dims();
        let rows: Vec<(Vec<u32>, Vec<Point3<f64>>)> = (0..ny * nz)
            .into_par_iter()
            .map(|row| {
                let (j, k) = (row % ny, row / ny);
                let mut voxels = Vec::new();
                let mut sources = Vec::new();
                for i in 0..nx {
                    let p = grid.centre(i, j, k);
                    if let Some((t, alpha)) = locator.locate(&p) {
                        let tet = tets[t];
                        let z = (0..4).fold(Vector3::zeros(), |acc, c| {
                            acc + source[tet[c] as usize].coords * alpha[c]
                        });
                        // `validate` bounds the grid by MAX_VOXELS < 2^32.
                        voxels.push((i + nx * row) as u32);
                        sources.push(Point3::from(z));
                    }
                }
                (voxels, sources)
            })
            .collect();
        let total = rows.iter().map(|r| r.0.len()).sum();
        let mut voxels = Vec::with_capacity(total);
        let mut sources = Vec::with_capacity(total);
        for (v, s) in rows {
            voxels.extend(v);
            sources.extend(s);
        }
        Ok(PullbackTable {
            grid,
            voxels,
            sources,
            source_box: bounds_of(source),
        })
    }

    /// The grid the table was built on.
    pub fn grid(&self) -> &G {
        &self.grid
    }

    /// Number of voxels inside the mesh.
    pub fn len(&self) -> usize {
        self.voxels.len()
    }

    /// Whether no voxel centre lies inside the mesh.
    pub fn is_empty(&self) -> bool {
        self.voxels.is_empty()
    }

    /// Linear indices (x fastest, see [`TemplateGrid::linear_index`]) of the
    /// voxels inside the mesh, strictly increasing.
    pub fn voxel_indices(&self) -> &[u32] {
        &self.voxels
    }

    /// The source points `z = sum_i alpha_i z_i` (scanner frame, mm), one per
    /// entry of [`PullbackTable::voxel_indices`].
    pub fn sources(&self) -> &[Point3<f64>] {
        &self.sources
    }

    /// Pulls every frame of `image` back into the template grid.
    ///
    /// Output: dims `[nx, ny, nz, image frames]`, f32, affine
    /// [`TemplateGrid::affine`]. A voxel of the table gets the trilinear
    /// interpolation of the frame at the continuous voxel coordinates
    /// `A^-1 (z, 1)^T` of its source point ([`Volume::sample_voxel`], `A`
    /// the image's voxel-to-world affine, computed once for all frames);
    /// voxels outside the mesh and voxels whose source point is outside the
    /// image (more than half a voxel beyond its outer voxel centres) get 0.
    /// NaN image values propagate: a voxel whose interpolation stencil gives
    /// a NaN corner a non-zero weight is NaN.
    ///
    /// # Errors
    /// [`PullbackError::NoOverlap`] when no source point falls inside the
    /// image (with the image's and the mesh's world bounding boxes in mm),
    /// [`PullbackError::EmptyImage`] when the image has no voxels,
    /// [`PullbackError::EmptyTable`] when the table is empty (no voxel centre
    /// inside the mesh).
    pub fn apply(
        &self,
        image: &Volume<f32>,
    ) -> Result<(Volume<f32>, PullbackStats), PullbackError> {
        self.apply_with(image, Interpolation::Linear)
    }

    /// [`PullbackTable::apply`] with the given interpolation: trilinear, or
    /// the value of the voxel nearest to the source point
    /// ([`Volume::sample_voxel_nearest`]; the same domain, so the same
    /// voxels are sampled).
    ///
    /// # Errors
    /// As [`PullbackTable::apply`].
    pub fn apply_with(
        &self,
        image: &Volume<f32>,
        interpolation: Interpolation,
    ) -> Result<(Volume<f32>, PullbackStats), PullbackError> {
        if image.frame_len() == 0 || image.frames() == 0 {
            return Err(PullbackError::EmptyImage {
                frame_voxels: image.frame_len(),
                frames: image.frames(),
            });
        }
        if self.voxels.is_empty() {
            return Err(PullbackError::EmptyTable {
                grid_voxels: self.grid.num_voxels(),
            });
        }
        let coords: Vec<Point3<f64>> = self
            .sources
            .par_iter()
            .map(|z| image.world_to_voxel(z))
            .collect();
        let n = self.grid.num_voxels();
        let frames = image.frames();
        let mut data = vec![0.0f32; n * frames];
        let mut sampled = 0;
        for (t, out) in data.chunks_mut(n).enumerate() {
            let values: Vec<Option<f64>> = coords
                .par_iter()
                .map(|v| match interpolation {
                    Interpolation::Linear => image.sample_voxel(v, t),
                    Interpolation::Nearest => image.sample_voxel_nearest(v, t),
                })
                .collect();
            if t == 0 {
                sampled = values.iter().filter(|v| v.is_some()).count();
                if sampled == 0 {
                    let (image_lo, image_hi) = image_world_box(image);
                    let (mesh_lo, mesh_hi) = self.source_box;
                    return Err(PullbackError::NoOverlap {
                        image_lo,
                        image_hi,
                        mesh_lo,
                        mesh_hi,
                        voxels: self.voxels.len(),
                    });
                }
            }
            for (&idx, value) in self.voxels.iter().zip(values) {
                if let Some(x) = value {
                    out[idx as usize] = x as f32;
                }
            }
        }
        let [nx, ny, nz] = self.grid.dims();
        let volume = Volume::new([nx, ny, nz, frames], self.grid.affine(), data)
            .map_err(PullbackError::Output)?;
        let stats = PullbackStats {
            inside_mesh: self.voxels.len(),
            sampled,
            outside_image: self.voxels.len() - sampled,
        };
        Ok((volume, stats))
    }
}

/// How an image is sampled at a source point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Interpolation {
    /// Trilinear (the default; intensities).
    #[default]
    Linear,
    /// The nearest voxel's value (label maps: no blended labels).
    Nearest,
}

unfold_param::named!(Interpolation { Linear => "linear", Nearest => "nearest" });

/// Counts of a pull-back: `sampled + outside_image == inside_mesh`, and
/// `inside_mesh` plus the voxels outside the mesh is the grid's voxel count.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PullbackStats {
    /// Template voxels whose centre lies inside the flattened mesh.
    pub inside_mesh: usize,
    /// Of those, voxels whose source point lies inside the image (sampled).
    pub sampled: usize,
    /// Of those, voxels whose source point lies outside the image (set to 0).
    pub outside_image: usize,
}

/// Whether a grid of `dims` has between 1 and [`MAX_VOXELS`] voxels (the
/// product checked for overflow).
pub(super) fn fits(dims: [usize; 3]) -> bool {
    let n = dims
        .iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .unwrap_or(usize::MAX);
    n != 0 && n <= MAX_VOXELS
}

fn check_spacing(spacing: [f64; 3]) -> Result<(), PullbackError> {
    if spacing.iter().all(|s| s.is_finite() && *s > 0.0) {
        Ok(())
    } else {
        Err(PullbackError::Spacing { spacing })
    }
}

fn check_finite_points(what: &'static str, points: &[Point3<f64>]) -> Result<(), PullbackError> {
    match points
        .iter()
        .position(|p| !p.coords.iter().all(|x| x.is_finite()))
    {
        Some(index) => Err(PullbackError::NotFinite {
            what,
            index,
            point: [points[index].x, points[index].y, points[index].z],
        }),
        None => Ok(()),
    }
}

/// Component-wise bounds of (finite) points; `(+inf, -inf)` for none.
fn bounds_of(points: &[Point3<f64>]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}

/// Voxels per axis covering extents `ext` at `spacing`: `ceil(e / s) + 1`.
pub(super) fn dims_for(ext: [f64; 3], spacing: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|a| (ext[a] / spacing[a]).ceil() + 1.0)
}

/// The smallest common multiple `f spacing` (`f >= 1`, rounded up to
/// 1e-3 mm) whose covering grid has at most [`MAX_VOXELS`] voxels; the voxel
/// count does not grow with `f`, so `f` is found by bisection.
fn fitting_spacing(ext: [f64; 3], spacing: [f64; 3]) -> Option<[f64; 3]> {
    let fits = |s: [f64; 3]| {
        s.iter().all(|x| x.is_finite())
            && dims_for(ext, s).iter().product::<f64>() <= MAX_VOXELS as f64
    };
    let scaled = |f: f64| spacing.map(|s| s * f);
    let (mut lo, mut hi) = (1.0f64, 2.0f64);
    while !fits(scaled(hi)) {
        lo = hi;
        hi *= 2.0;
        if !hi.is_finite() {
            return None;
        }
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if fits(scaled(mid)) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let s = scaled(hi).map(|x| (x * 1000.0).ceil() / 1000.0);
    fits(s).then_some(s)
}

/// World bounding box `(min, max)` of an image's voxels (as boxes): the
/// affine image of the 8 corners of `[-1/2, n - 1/2]^3` in voxel
/// coordinates. Callers can check overlap with a mesh before any work.
pub fn image_world_box(image: &Volume<f32>) -> ([f64; 3], [f64; 3]) {
    let d = image.dims();
    let corners: Vec<Point3<f64>> = (0..8)
        .map(|c: usize| {
            let v = Point3::from(std::array::from_fn::<f64, 3, _>(|a| {
                if (c >> a) & 1 == 1 {
                    d[a] as f64 - 0.5
                } else {
                    -0.5
                }
            }));
            image.voxel_to_world(&v)
        })
        .collect();
    bounds_of(&corners)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Rotation3};
    use proptest::prelude::*;
    use unfold_mesh::geometry::tet_signed_volume;
    use unfold_mesh::shapes::{PlacentaParams, kuhn_grid, placenta_slab};

    /// An affine intensity with a large offset (values far from 0, so
    /// relative tolerances are meaningful).
    fn f_affine(p: &Point3<f64>) -> f64 {
        100.0 + 0.5 * p.x - 0.8 * p.y + 1.2 * p.z
    }

    /// An image on an oblique grid (rotated, anisotropic spacing) covering
    /// the box `[lo, hi]` with at least a voxel of margin, frame `t` holding
    /// `f(world position, t)`.
    fn oblique_image(
        lo: Point3<f64>,
        hi: Point3<f64>,
        frames: usize,
        f: impl Fn(&Point3<f64>, usize) -> f64,
    ) -> Volume<f32> {
        let r = Rotation3::from_euler_angles(0.3, -0.4, 0.7);
        let a = r.matrix() * Matrix3::from_diagonal(&Vector3::new(0.9, 1.3, 0.7));
        let inv = a.try_inverse().unwrap();
        let mut vmin = Vector3::repeat(f64::INFINITY);
        let mut vmax = Vector3::repeat(f64::NEG_INFINITY);
        for c in 0..8usize {
            let w = Vector3::from_fn(|i, _| if (c >> i) & 1 == 1 { hi[i] } else { lo[i] });
            let v = inv * w;
            vmin = vmin.inf(&v);
            vmax = vmax.sup(&v);
        }
        let vmin = vmin.map(|x| x.floor() - 2.0);
        let vmax = vmax.map(|x| x.ceil() + 2.0);
        let dims = [0, 1, 2].map(|i| (vmax[i] - vmin[i]) as usize + 1);
        let mut affine = Matrix4::identity();
        affine.fixed_view_mut::<3, 3>(0, 0).copy_from(&a);
        affine.fixed_view_mut::<3, 1>(0, 3).copy_from(&(a * vmin));
        let mut data = Vec::with_capacity(dims.iter().product::<usize>() * frames);
        for t in 0..frames {
            for k in 0..dims[2] {
                for j in 0..dims[1] {
                    for i in 0..dims[0] {
                        let p = affine.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                        data.push(f(&p, t) as f32);
                    }
                }
            }
        }
        Volume::new([dims[0], dims[1], dims[2], frames], affine, data).unwrap()
    }

    fn bbox(points: &[Point3<f64>]) -> (Point3<f64>, Point3<f64>) {
        let (lo, hi) = bounds_of(points);
        (Point3::from(lo), Point3::from(hi))
    }

    /// Barycentric coordinates by a direct solve (independent of the
    /// locator): `[a2 a3 a4] = Ds^-1 (p - x0)`, `a1 = 1 - a2 - a3 - a4`.
    fn barycentric(x: [Point3<f64>; 4], p: &Point3<f64>) -> [f64; 4] {
        let ds = Matrix3::from_columns(&[x[1] - x[0], x[2] - x[0], x[3] - x[0]]);
        let a = ds.lu().solve(&(p - x[0])).unwrap();
        [1.0 - a.sum(), a[0], a[1], a[2]]
    }

    fn corners(pos: &[Point3<f64>], tet: &[u32; 4]) -> [Point3<f64>; 4] {
        tet.map(|v| pos[v as usize])
    }

    fn correlation(a: &[f64], b: &[f64]) -> f64 {
        let n = a.len() as f64;
        let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
        let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
        for (x, y) in a.iter().zip(b) {
            sab += (x - ma) * (y - mb);
            saa += (x - ma) * (x - ma);
            sbb += (y - mb) * (y - mb);
        }
        sab / (saa * sbb).sqrt()
    }

    /// The mask of table voxels over the whole grid.
    fn mask(table: &PullbackTable) -> Vec<bool> {
        let mut m = vec![false; table.grid().num_voxels()];
        for &v in table.voxel_indices() {
            m[v as usize] = true;
        }
        m
    }

    #[test]
    fn identity_map_on_a_box_matches_direct_sampling() {
        let mesh = kuhn_grid([5, 4, 3], [4.0, 4.0, 3.5]);
        let (lo, hi) = bbox(&mesh.positions);
        let grid = TemplateGrid::covering(&mesh.positions, [1.3, 1.1, 0.9]).unwrap();
        let table = PullbackTable::new(grid, &mesh.positions, &mesh.tets, &mesh.positions).unwrap();
        let image = oblique_image(lo, hi, 1, |p, _| f_affine(p));
        let (out, stats) = table.apply(&image).unwrap();
        assert_eq!(out.dims(), [grid.dims[0], grid.dims[1], grid.dims[2], 1]);
        assert_eq!(*out.affine(), grid.affine());
        assert_eq!(stats.inside_mesh, table.len());
        assert_eq!(stats.sampled, table.len());
        assert_eq!(stats.outside_image, 0);
        let inside = mask(&table);
        let (mut n_in, mut n_out) = (0, 0);
        for (idx, &is_in) in inside.iter().enumerate() {
            let [i, j, k] = grid.voxel(idx);
            assert_eq!(grid.linear_index(i, j, k), idx);
            let p = grid.centre(i, j, k);
            // Signed distance to the box's boundary (positive inside).
            let d = (0..3)
                .map(|a| (p[a] - lo[a]).min(hi[a] - p[a]))
                .fold(f64::INFINITY, f64::min);
            let value = out.data()[idx] as f64;
            if d > 1e-6 {
                assert!(is_in, "voxel {idx} at {p} is inside the box");
            }
            if d < -1e-6 {
                assert!(!is_in, "voxel {idx} at {p} is outside the box");
            }
            if is_in {
                n_in += 1;
                let direct = image.sample_world(&p, 0).unwrap();
                let exact = f_affine(&p);
                assert!(
                    (value - direct).abs() <= 1e-4 * direct.abs(),
                    "{value} vs {direct}"
                );
                assert!(
                    (value - exact).abs() <= 1e-4 * exact.abs(),
                    "{value} vs {exact}"
                );
            } else {
                n_out += 1;
                assert_eq!(value, 0.0);
            }
        }
        assert!(n_in > 100 && n_out > 100, "{n_in} inside, {n_out} outside");
        assert_eq!(n_in + n_out, grid.num_voxels());
    }

    #[test]
    fn identity_map_on_a_placenta_matches_direct_sampling() {
        let params = PlacentaParams {
            length: 60.0,
            width: 45.0,
            thickness_centre: 12.0,
            thickness_rim: 5.0,
            bend_radius: 80.0,
            cells_radial: 6,
            cells_through: 2,
            ..PlacentaParams::default()
        };
        let mesh = placenta_slab(&params).unwrap().mesh;
        let (lo, hi) = bbox(&mesh.positions);
        let grid = TemplateGrid::covering(&mesh.positions, [1.5, 1.5, 1.5]).unwrap();
        let table = PullbackTable::new(grid, &mesh.positions, &mesh.tets, &mesh.positions).unwrap();
        let image = oblique_image(lo, hi, 1, |p, _| f_affine(p));
        let (out, stats) = table.apply(&image).unwrap();
        assert_eq!(stats.sampled, stats.inside_mesh);
        assert!(stats.inside_mesh > 1000);
        // The volume of the voxels inside approximates the mesh's volume.
        let vol: f64 = mesh
            .tets
            .iter()
            .map(|t| {
                let x = corners(&mesh.positions, t);
                tet_signed_volume(&x[0], &x[1], &x[2], &x[3])
            })
            .sum();
        let voxel_vol = stats.inside_mesh as f64 * 1.5f64.powi(3);
        assert!((voxel_vol / vol - 1.0).abs() < 0.1, "{voxel_vol} vs {vol}");
        let inside = mask(&table);
        for (idx, &is_in) in inside.iter().enumerate() {
            let value = out.data()[idx] as f64;
            if is_in {
                let [i, j, k] = grid.voxel(idx);
                let p = grid.centre(i, j, k);
                let direct = image.sample_world(&p, 0).unwrap();
                assert!((value - direct).abs() <= 1e-4 * direct.abs());
                assert!((value - f_affine(&p)).abs() <= 1e-4 * f_affine(&p).abs());
            } else {
                assert_eq!(value, 0.0);
            }
        }
    }

    /// Source box centred at `c`; `g(z)` with `q = z - c`:
    /// `x = (q1 + 0.3 q2, q2, q3 + 0.04 q2^2 + 0.02 q1^2)` (a shear and a
    /// bend, Jacobian determinant 1, so injective).
    const BEND_Y: f64 = 0.04;
    const BEND_X: f64 = 0.02;
    const SHEAR: f64 = 0.3;

    fn g(q: &Vector3<f64>) -> Point3<f64> {
        Point3::new(
            q.x + SHEAR * q.y,
            q.y,
            q.z + BEND_Y * q.y * q.y + BEND_X * q.x * q.x,
        )
    }

    fn g_inv(x: &Point3<f64>) -> Vector3<f64> {
        let q2 = x.y;
        let q1 = x.x - SHEAR * q2;
        Vector3::new(q1, q2, x.z - BEND_Y * q2 * q2 - BEND_X * q1 * q1)
    }

    #[test]
    fn nonlinear_map_pulls_back_through_the_barycentric_source_point() {
        let mut mesh = kuhn_grid([8, 6, 4], [2.5, 2.5, 2.5]);
        let shift = Vector3::new(30.0, -20.0, 50.0);
        for p in &mut mesh.positions {
            *p += shift;
        }
        let source = mesh.positions.clone();
        let c = shift + Vector3::new(10.0, 7.5, 5.0);
        let mapped: Vec<Point3<f64>> = source.iter().map(|z| g(&(z.coords - c))).collect();
        for t in &mesh.tets {
            let x = corners(&mapped, t);
            assert!(tet_signed_volume(&x[0], &x[1], &x[2], &x[3]) > 0.0);
        }
        let grid = TemplateGrid::covering(&mapped, [0.8, 0.9, 0.7]).unwrap();
        let table = PullbackTable::new(grid, &mapped, &mesh.tets, &source).unwrap();
        let (lo, hi) = bbox(&source);
        let image = oblique_image(lo, hi, 1, |p, _| f_affine(p));
        let (out, stats) = table.apply(&image).unwrap();
        assert_eq!(stats.sampled, stats.inside_mesh);
        let inside = mask(&table);
        let (mut got, mut smooth) = (Vec::new(), Vec::new());
        let mut n_in = 0;
        for (idx, &is_in) in inside.iter().enumerate() {
            let [i, j, k] = grid.voxel(idx);
            let p = grid.centre(i, j, k);
            // Brute force over all tets: the deepest one containing p.
            let best = mesh
                .tets
                .iter()
                .map(|t| (t, barycentric(corners(&mapped, t), &p)))
                .max_by(|a, b| {
                    let m = |x: &[f64; 4]| x.iter().copied().fold(f64::INFINITY, f64::min);
                    m(&a.1).total_cmp(&m(&b.1))
                })
                .unwrap();
            let depth = best.1.iter().copied().fold(f64::INFINITY, f64::min);
            let value = out.data()[idx] as f64;
            if depth > 1e-7 {
                assert!(is_in, "voxel {idx} at {p} is inside tet {:?}", best.0);
            }
            if depth < -1e-7 {
                assert!(!is_in, "voxel {idx} at {p} is outside the mesh");
            }
            if !is_in {
                assert_eq!(value, 0.0);
                continue;
            }
            n_in += 1;
            let z = (0..4).fold(Vector3::zeros(), |acc, c| {
                acc + source[best.0[c] as usize].coords * best.1[c]
            });
            let expected = f_affine(&Point3::from(z));
            assert!(
                (value - expected).abs() <= 1e-4 * expected.abs(),
                "voxel {idx}: {value} vs {expected}"
            );
            got.push(value);
            smooth.push(f_affine(&Point3::from(g_inv(&p) + c)));
        }
        assert!(n_in > 1000, "{n_in} voxels inside");
        let r = correlation(&got, &smooth);
        assert!(r > 0.99, "correlation {r}");
        // The piecewise-linear error is small but not zero: the map is
        // genuinely nonlinear.
        let max_err = got
            .iter()
            .zip(&smooth)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(max_err > 1e-3 && max_err < 1.0, "max error {max_err}");
    }

    #[test]
    fn four_d_series_reuses_the_table_per_frame() {
        let mesh = kuhn_grid([4, 3, 2], [3.0, 3.0, 3.0]);
        let rot = Rotation3::from_euler_angles(0.2, 0.5, -0.3);
        let source: Vec<Point3<f64>> = mesh
            .positions
            .iter()
            .map(|p| rot * p + Vector3::new(5.0, -3.0, 12.0))
            .collect();
        let grid = TemplateGrid::covering(&mesh.positions, [1.0, 1.2, 0.8]).unwrap();
        let table = PullbackTable::new(grid, &mesh.positions, &mesh.tets, &source).unwrap();
        let (lo, hi) = bbox(&source);
        let f = |p: &Point3<f64>, t: usize| f_affine(p) + 10.0 * t as f64;
        let series = oblique_image(lo, hi, 3, f);
        let (out, stats) = table.apply(&series).unwrap();
        assert_eq!(out.frames(), 3);
        assert_eq!(&out.dims()[..3], &grid.dims[..]);
        assert_eq!(*out.affine(), grid.affine());
        let n = grid.num_voxels();
        for t in 0..3 {
            let frame = oblique_image(lo, hi, 1, |p, _| f(p, t));
            assert_eq!(frame.affine(), series.affine());
            let (single, s) = table.apply(&frame).unwrap();
            assert_eq!(s, stats);
            assert_eq!(single.frames(), 1);
            assert_eq!(*single.affine(), *out.affine());
            assert_eq!(single.data(), &out.data()[t * n..(t + 1) * n]);
        }
        // Frames differ by 10 inside the mesh.
        for &v in table.voxel_indices() {
            let v = v as usize;
            let d = out.data()[v + n] - out.data()[v];
            assert!((d - 10.0).abs() < 1e-3, "{d}");
        }
    }

    #[test]
    fn image_far_away_does_not_overlap() {
        let mesh = kuhn_grid([3, 3, 2], [2.0, 2.0, 2.0]);
        let grid = TemplateGrid::covering(&mesh.positions, [1.0, 1.0, 1.0]).unwrap();
        let table = PullbackTable::new(grid, &mesh.positions, &mesh.tets, &mesh.positions).unwrap();
        let off = Vector3::new(500.0, 0.0, 0.0);
        let (lo, hi) = bbox(&mesh.positions);
        let image = oblique_image(lo + off, hi + off, 1, |p, _| f_affine(p));
        match table.apply(&image) {
            Err(e @ PullbackError::NoOverlap { voxels, .. }) => {
                assert_eq!(voxels, table.len());
                let msg = e.to_string();
                assert!(msg.contains("does not overlap"), "{msg}");
                assert!(msg.contains("mm"), "{msg}");
            }
            other => panic!("expected an image error, got {other:?}"),
        }
    }

    #[test]
    fn partial_overlap_zeroes_voxels_outside_the_image() {
        let mesh = kuhn_grid([6, 3, 2], [3.0, 3.0, 3.0]);
        let grid = TemplateGrid::covering(&mesh.positions, [1.0, 1.0, 1.0]).unwrap();
        let table = PullbackTable::new(grid, &mesh.positions, &mesh.tets, &mesh.positions).unwrap();
        // The image covers roughly x in [-5, 9] of the 18 mm box.
        let mut affine = Matrix4::identity();
        affine[(0, 3)] = -5.0;
        affine[(1, 3)] = -2.0;
        affine[(2, 3)] = -2.0;
        let dims = [15, 14, 11, 1];
        let mut data = Vec::new();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let p = affine.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                    data.push(f_affine(&p) as f32);
                }
            }
        }
        let image = Volume::new(dims, affine, data).unwrap();
        let (out, stats) = table.apply(&image).unwrap();
        assert!(stats.sampled > 0 && stats.outside_image > 0, "{stats:?}");
        assert_eq!(stats.sampled + stats.outside_image, stats.inside_mesh);
        let mut outside = 0;
        for (&v, z) in table.voxel_indices().iter().zip(table.sources()) {
            let value = out.data()[v as usize];
            match image.sample_world(z, 0) {
                Some(x) => assert_eq!(value, x as f32),
                None => {
                    outside += 1;
                    assert_eq!(value, 0.0);
                    assert!(z.x > 9.0 - 1e-9);
                }
            }
        }
        assert_eq!(outside, stats.outside_image);
    }

    #[test]
    fn nan_values_propagate() {
        let mesh = kuhn_grid([2, 2, 2], [2.0, 2.0, 2.0]);
        let grid = TemplateGrid::covering(&mesh.positions, [1.0, 1.0, 1.0]).unwrap();
        let table = PullbackTable::new(grid, &mesh.positions, &mesh.tets, &mesh.positions).unwrap();
        let image = Volume::filled([8, 8, 8, 1], Matrix4::identity(), f32::NAN).unwrap();
        let (out, stats) = table.apply(&image).unwrap();
        assert_eq!(stats.sampled, table.len());
        let inside = mask(&table);
        for (idx, &is_in) in inside.iter().enumerate() {
            assert_eq!(out.data()[idx].is_nan(), is_in);
        }
    }

    #[test]
    fn table_is_sorted_and_deterministic() {
        let params = PlacentaParams {
            cells_radial: 6,
            cells_through: 2,
            ..PlacentaParams::default()
        };
        let mesh = placenta_slab(&params).unwrap().mesh;
        let grid = TemplateGrid::covering(&mesh.positions, [4.0, 4.0, 4.0]).unwrap();
        let a = PullbackTable::new(grid, &mesh.positions, &mesh.tets, &mesh.positions).unwrap();
        let b = PullbackTable::new(grid, &mesh.positions, &mesh.tets, &mesh.positions).unwrap();
        assert!(!a.is_empty());
        assert!(a.voxel_indices().windows(2).all(|w| w[0] < w[1]));
        assert_eq!(a.voxel_indices(), b.voxel_indices());
        assert_eq!(a.sources(), b.sources());
        assert_eq!(a.grid(), &grid);
    }

    #[test]
    fn bad_inputs_are_errors() {
        let pts = [Point3::origin(), Point3::new(1.0, 2.0, 3.0)];
        for s in [
            [0.0, 1.0, 1.0],
            [1.0, -1.0, 1.0],
            [1.0, 1.0, f64::NAN],
            [f64::INFINITY, 1.0, 1.0],
        ] {
            assert!(matches!(
                TemplateGrid::covering(&pts, s),
                Err(PullbackError::Spacing { spacing }) if format!("{spacing:?}") == format!("{s:?}")
            ));
        }
        assert!(matches!(
            TemplateGrid::covering(&[], [1.0; 3]),
            Err(PullbackError::NoPoints)
        ));
        assert!(matches!(
            TemplateGrid::covering(&[Point3::new(f64::NAN, 0.0, 0.0)], [1.0; 3]),
            Err(PullbackError::NotFinite {
                what: "point",
                index: 0,
                ..
            })
        ));
        assert!(
            TemplateGrid::covering(
                &[Point3::new(-1e308, 0.0, 0.0), Point3::new(1e308, 0.0, 0.0)],
                [1.0; 3]
            )
            .is_err()
        );
        // Too many voxels: the message names a spacing that fits.
        let far = [Point3::origin(), Point3::new(1000.0, 1000.0, 1000.0)];
        match TemplateGrid::covering(&far, [1.0; 3]) {
            Err(e @ PullbackError::GridTooLarge { fitting, hi, .. }) => {
                assert_eq!(fitting, Some([1.957; 3]));
                assert_eq!(hi, [1000.0; 3]);
                let msg = e.to_string();
                assert!(msg.contains("would fit"), "{msg}");
                assert!(msg.contains("[1.957, 1.957, 1.957]"), "{msg}");
            }
            other => panic!("expected a config error, got {other:?}"),
        }
        assert!(TemplateGrid::covering(&far, [1.957; 3]).is_ok());
        assert!(TemplateGrid::covering(&far, [1.956; 3]).is_err());

        let mesh = kuhn_grid([2, 2, 2], [1.0, 1.0, 1.0]);
        let grid = TemplateGrid::covering(&mesh.positions, [0.5; 3]).unwrap();
        let pos = &mesh.positions;
        let n = pos.len();
        // Compared by their Debug text, so that NaN coordinates match.
        let input_err = |r: Result<PullbackTable, PullbackError>, want: PullbackError| match r {
            Err(e) => assert_eq!(format!("{e:?}"), format!("{want:?}")),
            Ok(_) => panic!("expected {want:?}"),
        };
        input_err(
            PullbackTable::new(grid, pos, &mesh.tets, &pos[1..]),
            PullbackError::LengthMismatch {
                mapped: n,
                sources: n - 1,
            },
        );
        input_err(
            PullbackTable::new(grid, &[], &[], &[]),
            PullbackError::EmptyMesh {
                vertices: 0,
                tets: 0,
            },
        );
        input_err(
            PullbackTable::new(grid, pos, &[], pos),
            PullbackError::EmptyMesh {
                vertices: n,
                tets: 0,
            },
        );
        input_err(
            PullbackTable::new(grid, pos, &[[0, 1, 2, 99]], pos),
            PullbackError::VertexOutOfRange {
                tet: 0,
                corners: [0, 1, 2, 99],
                vertices: n,
            },
        );
        let mut nan = pos.clone();
        nan[5].y = f64::NAN;
        let p5 = |y| [pos[5].x, y, pos[5].z];
        input_err(
            PullbackTable::new(grid, &nan, &mesh.tets, pos),
            PullbackError::NotFinite {
                what: "mapped position",
                index: 5,
                point: p5(f64::NAN),
            },
        );
        input_err(
            PullbackTable::new(grid, pos, &mesh.tets, &nan),
            PullbackError::NotFinite {
                what: "source position",
                index: 5,
                point: p5(f64::NAN),
            },
        );
        nan[5].y = f64::INFINITY;
        input_err(
            PullbackTable::new(grid, pos, &mesh.tets, &nan),
            PullbackError::NotFinite {
                what: "source position",
                index: 5,
                point: p5(f64::INFINITY),
            },
        );
        // Only flat tets.
        input_err(
            PullbackTable::new(grid, pos, &[[0, 1, 2, 2]], pos),
            PullbackError::AllTetsFlat { tets: 1 },
        );
        // Hand-made invalid grids.
        for bad in [
            TemplateGrid {
                spacing: [0.0, 1.0, 1.0],
                ..grid
            },
            TemplateGrid {
                origin: [f64::NAN, 0.0, 0.0],
                ..grid
            },
            TemplateGrid {
                dims: [0, 4, 4],
                ..grid
            },
            TemplateGrid {
                dims: [1024, 1024, 1024],
                ..grid
            },
            TemplateGrid {
                dims: [usize::MAX, 2, 2],
                ..grid
            },
        ] {
            let e = PullbackTable::new(bad, pos, &mesh.tets, pos).unwrap_err();
            assert!(
                matches!(
                    e,
                    PullbackError::Spacing { .. }
                        | PullbackError::Origin { .. }
                        | PullbackError::GridSize { .. }
                ),
                "{e:?}"
            );
            assert!(e.to_string().starts_with("invalid configuration: "), "{e}");
        }
        // A grid missing the mesh gives an empty table, which cannot be
        // applied.
        let away = TemplateGrid {
            origin: [100.0, 100.0, 100.0],
            ..grid
        };
        let table = PullbackTable::new(away, pos, &mesh.tets, pos).unwrap();
        assert!(table.is_empty());
        assert_eq!(table.len(), 0);
        let image = Volume::filled([4, 4, 4, 1], Matrix4::identity(), 1.0f32).unwrap();
        assert!(matches!(
            table.apply(&image),
            Err(PullbackError::EmptyTable { grid_voxels }) if grid_voxels == grid.num_voxels()
        ));
    }

    #[test]
    fn affine_and_centres_agree() {
        let grid = TemplateGrid {
            origin: [-3.0, 2.0, 7.5],
            spacing: [0.5, 1.5, 2.0],
            dims: [4, 5, 6],
        };
        assert_eq!(grid.num_voxels(), 120);
        let a = grid.affine();
        for (i, j, k) in [(0, 0, 0), (3, 4, 5), (1, 2, 3)] {
            let p = a.transform_point(&Point3::new(i as f64, j as f64, k as f64));
            assert!((p - grid.centre(i, j, k)).norm() < 1e-12);
        }
        let (lo, hi) = grid.bounds();
        assert_eq!(lo, Point3::new(-3.25, 1.25, 6.5));
        assert_eq!(hi, Point3::new(-1.25, 8.75, 18.5));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// A rigid motion of the source relative to the template: the
        /// pull-back of an affine intensity is exact inside the mesh.
        #[test]
        fn rigid_motions_pull_back_exactly(
            roll in -3.1..3.1f64, pitch in -1.5..1.5f64, yaw in -3.1..3.1f64,
            tx in -100.0..100.0f64, ty in -100.0..100.0f64, tz in -100.0..100.0f64,
            s in 0.9..1.4f64,
        ) {
            let mesh = kuhn_grid([4, 3, 2], [3.0, 3.0, 3.0]);
            let rot = Rotation3::from_euler_angles(roll, pitch, yaw);
            let t = Vector3::new(tx, ty, tz);
            let motion = |p: &Point3<f64>| rot * p + t;
            let source: Vec<Point3<f64>> = mesh.positions.iter().map(motion).collect();
            let grid = TemplateGrid::covering(&mesh.positions, [s, 1.1 * s, 0.8 * s]).unwrap();
            let table = PullbackTable::new(grid, &mesh.positions, &mesh.tets, &source).unwrap();
            let (lo, hi) = bbox(&source);
            let image = oblique_image(lo, hi, 1, |p, _| f_affine(p));
            let (out, stats) = table.apply(&image).unwrap();
            let inside = mask(&table);
            let mut outside = 0;
            for (idx, &is_in) in inside.iter().enumerate() {
                let [i, j, k] = grid.voxel(idx);
                let p = grid.centre(i, j, k);
                let d = (0..3)
                    .map(|a| p[a].min([12.0, 9.0, 6.0][a] - p[a]))
                    .fold(f64::INFINITY, f64::min);
                prop_assert!(d >= -1e-6 || !is_in);
                prop_assert!(d <= 1e-6 || is_in);
                let value = out.data()[idx] as f64;
                if is_in {
                    let expected = f_affine(&motion(&p));
                    prop_assert!((value - expected).abs() < 1e-3, "{} vs {}", value, expected);
                } else {
                    outside += 1;
                    prop_assert_eq!(value, 0.0);
                }
            }
            prop_assert_eq!(stats.inside_mesh, table.len());
            prop_assert_eq!(stats.inside_mesh + outside, grid.num_voxels());
            prop_assert_eq!(stats.sampled + stats.outside_image, stats.inside_mesh);
            prop_assert_eq!(stats.outside_image, 0);
        }

        /// Every point lies inside the covering grid's outer boundary, with
        /// at least half a voxel to spare, and the grid is not oversized.
        #[test]
        fn covering_contains_every_point(
            pts in prop::collection::vec(
                (-200.0..200.0f64, -200.0..200.0f64, -50.0..50.0f64), 1..40),
            sx in 2.0..20.0f64, sy in 2.0..20.0f64, sz in 0.5..5.0f64,
        ) {
            let pts: Vec<Point3<f64>> =
                pts.into_iter().map(|(x, y, z)| Point3::new(x, y, z)).collect();
            let spacing = [sx, sy, sz];
            let grid = TemplateGrid::covering(&pts, spacing).unwrap();
            let (lo, hi) = grid.bounds();
            let (plo, phi) = bounds_of(&pts);
            for p in &pts {
                for a in 0..3 {
                    prop_assert!(p[a] >= lo[a] + 0.5 * spacing[a] - 1e-9);
                    prop_assert!(p[a] <= hi[a] - 0.5 * spacing[a] + 1e-9);
                }
            }
            for a in 0..3 {
                prop_assert!(grid.dims[a] >= 1);
                prop_assert!(grid.dims[a] as f64 <= (phi[a] - plo[a]) / spacing[a] + 2.0);
            }
            prop_assert_eq!(grid.spacing, spacing);
            prop_assert!(grid.num_voxels() <= MAX_VOXELS);
        }
    }
}
