//! Tet meshes from segmentations (ALGORITHMS 2.8; issue 7): the reference
//! pipeline's mask preparation followed by isosurface stuffing.
//!
//! 1. The mask is cropped to its voxels plus a margin (so the work is
//!    proportional to the object, not to the image).
//! 2. Optionally dilated by the 3x3x3 box ([`mask::dilate_box`], `dilate`
//!    times; the reference dilates once, which thickens the object by a
//!    voxel on every side, so the default here is 0).
//! 3. Smoothed by a Gaussian of `smooth_voxels` voxels (default 1.5, the
//!    reference's) into `s` in `[0, 1]`.
//! 4. The domain is a level set `s > c` in world coordinates,
//!    `f(p) = c - s(A^-1 p)` with `s` interpolated trilinearly between
//!    voxel centres (`A` the voxel-to-world affine), meshed by
//!    [`crate::stuffing::stuff`] with cube side `size_mm` (default: the smallest
//!    voxel spacing) in the mask's *voxel frame* ([`voxel_frame`]): the
//!    lattice's axes are the voxel axes made orthonormal, `Q`, and its
//!    origin is fixed to the cropped grid's first voxel `o`, so stuffing
//!    meshes `g(q) = f(o + Q q)` and the vertices are mapped back by
//!    `p = o + Q q`. The mesh is then a function of the mask alone: a mask
//!    whose affine is moved by a rigid motion `P` (`P A`, the same voxels)
//!    gives the same mesh moved by `P`, which a lattice along the world
//!    axes would not (its cut of the surface would change with the pose,
//!    by up to a lattice cell).
//!
//! The level: the reference takes `c = 0.5` ([`IsoLevel::Fixed`]). Smoothing
//! moves that level set inward where the surface curves, by about
//! `sigma^2 (k1 + k2) / 2` (`k1`, `k2` the principal curvatures): a ball of
//! 20 voxels loses 2.2 % of its volume, a placenta-like slab 26 mm thick at
//! 3 mm voxels 3.2 %. The default, [`IsoLevel::PreserveVolume`], takes the
//! `c` at which as many voxel centres have `s >= c` as the (dilated) mask
//! has voxels, so the mesh keeps the mask's volume (within 0.5 % on those
//! shapes) while its surface stays the smoothed one.
//!
//! 5. Where the smoothed mask is thinner than the lattice resolves (two
//!    blobs touching, a neck thinner than a cube), the cut boundary can
//!    touch itself at a vertex or an edge: the stuffing resolves those
//!    pinches ([`crate::pinch`]: split the vertex, one copy per tet group;
//!    open what splitting cannot by removing the tets at the pinch) and
//!    [`MaskMesh::pinches`] counts what it did. A mask that meshes at one
//!    size therefore meshes at every coarser one (property-tested in
//!    `tests/mesher_pinch.rs`).
//! 6. With `grade`, the interior is coarsened by edge collapses
//!    ([`crate::coarsen::coarsen_interior`]) towards edges of
//!    `size + d / 2` at depth `d` below the boundary, which is kept exactly
//!    (the dihedral angles then stay within `[10, 165]` degrees). The
//!    collapses keep the boundary and obey the link condition, so they
//!    cannot pinch it (checked again afterwards).
//!
//! The mesh is valid by construction (positive tets with dihedral angles
//! bounded away from 0 and 180 degrees, a closed manifold boundary, checked
//! before it is returned); one connected component is kept (the largest)
//! unless all are asked for.

use crate::geometry::{tet_dihedral_angles, total_volume};
use crate::memory::MemoryEstimate;
use crate::pinch::PinchRepair;
use crate::spatial::ClosestPointQuery;
use crate::stuffing::{Implicit, Stuffed, stuff};
use crate::{MeshError, TetMesh, Volume, mask};
use nalgebra::{Matrix3, Matrix4, Point3, Rotation3, Vector3, Vector4};
use serde::{Deserialize, Serialize};

pub use crate::mask_selection::{MaskSelection, mask_from_image};

/// The level `c` of the smoothed mask `s` whose superlevel set `s > c` is
/// meshed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum IsoLevel {
    /// The `c` at which as many voxel centres have `s >= c` as the mask
    /// (after dilation) has voxels: the mesh keeps the mask's volume.
    PreserveVolume,
    /// A fixed level in `(0, 1)` (the reference: 0.5).
    Fixed(f64),
}

/// Options of [`mesh_mask`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaskMeshOptions {
    /// Cube side of the lattice, mm (tet edges are this and `sqrt(3)/2` of
    /// it); `None`: the smallest voxel spacing.
    pub size_mm: Option<f64>,
    /// Gaussian smoothing, voxels (0: none). Default 1.5.
    pub smooth_voxels: f64,
    /// Box dilations before smoothing. Default 0.
    pub dilate: usize,
    /// The level meshed. Default [`IsoLevel::PreserveVolume`].
    pub level: IsoLevel,
    /// Keep every connected component instead of the largest. Default
    /// false.
    pub keep_all_components: bool,
    /// Coarser tets inside: target edge length `size + d / 2` at depth `d`
    /// below the boundary. Default false.
    pub grade: bool,
}

impl Default for MaskMeshOptions {
    fn default() -> Self {
        MaskMeshOptions {
            size_mm: None,
            smooth_voxels: 1.5,
            dilate: 0,
            level: IsoLevel::PreserveVolume,
            keep_all_components: false,
            grade: false,
        }
    }
}

/// The lattice cube side at which the mask's volume holds `cubes` cubes:
/// `(n * v / cubes)^(1/3)` for `n` voxels inside (first frame) of volume
/// `v = |det A|` each (`A` the affine's linear part); `None` for an empty
/// mask or a `cubes` that is not finite and positive. A size chosen this
/// way makes the mesh's cost follow the organ, not the image's resolution.
pub fn cube_side_for_cubes(mask: &Volume<bool>, cubes: f64) -> Option<f64> {
    if !(cubes.is_finite() && cubes > 0.0) {
        return None;
    }
    let inside = mask.data()[..mask.frame_len()]
        .iter()
        .filter(|&&b| b)
        .count();
    let voxel = mask.affine().fixed_view::<3, 3>(0, 0).determinant().abs();
    let side = (inside as f64 * voxel / cubes).cbrt();
    (inside > 0 && side.is_finite() && side > 0.0).then_some(side)
}

/// Size and quality figures of a tet mesh.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshQuality {
    /// Vertices.
    pub vertices: usize,
    /// Tets.
    pub tets: usize,
    /// Boundary triangles.
    pub boundary_triangles: usize,
    /// Total volume, mm^3.
    #[serde(with = "crate::nan_as_null")]
    pub volume_mm3: f64,
    /// Smallest dihedral angle, degrees.
    #[serde(with = "crate::nan_as_null")]
    pub min_dihedral_deg: f64,
    /// Largest dihedral angle, degrees.
    #[serde(with = "crate::nan_as_null")]
    pub max_dihedral_deg: f64,
}

impl MeshQuality {
    /// The figures of `mesh`.
    ///
    /// # Errors
    /// As [`crate::topology::tet_boundary`].
    pub fn of(mesh: &TetMesh) -> Result<MeshQuality, MeshError> {
        let boundary = crate::topology::tet_boundary(mesh)?;
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        for t in 0..mesh.num_tets() {
            for a in tet_dihedral_angles(&mesh.tet_points(t)) {
                lo = lo.min(a.to_degrees());
                hi = hi.max(a.to_degrees());
            }
        }
        Ok(MeshQuality {
            vertices: mesh.num_vertices(),
            tets: mesh.num_tets(),
            boundary_triangles: boundary.surface.triangles.len(),
            volume_mm3: total_volume(mesh),
            min_dihedral_deg: lo,
            max_dihedral_deg: hi,
        })
    }
}

/// A mesh of a mask, see [`mesh_mask`].
#[derive(Debug, Clone)]
pub struct MaskMesh {
    /// The tet mesh (mm, world frame of the mask).
    pub mesh: TetMesh,
    /// Connected components of the meshed domain.
    pub components: usize,
    /// Tet counts of the components left out, largest first.
    pub dropped_components: Vec<usize>,
    /// Lattice cube side used, mm.
    pub size_mm: f64,
    /// The level `c` meshed.
    pub level: f64,
    /// Interior vertices removed by grading (0 without).
    pub graded_collapses: usize,
    /// What resolving the boundary's pinches did (see [`crate::pinch`]).
    pub pinches: PinchRepair,
    /// Voxels set in the mask.
    pub mask_voxels: usize,
    /// Their volume, mm^3 (voxel count times voxel volume).
    pub mask_volume_mm3: f64,
}

/// `mask` restricted to the voxels `lo .. lo + dims` (indices may lie
/// outside the image: those voxels are unset), the affine moved so every
/// voxel keeps its world position.
fn crop(mask: &Volume<bool>, lo: [i64; 3], dims: [usize; 3]) -> Result<Volume<bool>, MeshError> {
    let src = mask.dims();
    let mut data = vec![false; dims[0] * dims[1] * dims[2]];
    for k in 0..dims[2] {
        let sk = lo[2] + k as i64;
        if sk < 0 || sk >= src[2] as i64 {
            continue;
        }
        for j in 0..dims[1] {
            let sj = lo[1] + j as i64;
            if sj < 0 || sj >= src[1] as i64 {
                continue;
            }
            for i in 0..dims[0] {
                let si = lo[0] + i as i64;
                if si >= 0 && si < src[0] as i64 {
                    data[i + dims[0] * (j + dims[1] * k)] =
                        mask.data()[mask.index(si as usize, sj as usize, sk as usize, 0)];
                }
            }
        }
    }
    let mut affine: Matrix4<f64> = *mask.affine();
    let shift = affine * Vector4::new(lo[0] as f64, lo[1] as f64, lo[2] as f64, 1.0);
    affine[(0, 3)] = shift.x;
    affine[(1, 3)] = shift.y;
    affine[(2, 3)] = shift.z;
    Volume::new([dims[0], dims[1], dims[2], 1], affine, data)
}

/// The rotation whose columns are the voxel axes of `affine` made
/// orthonormal (Gram-Schmidt in the order i, j, k):
///
/// ```text
/// e0 = a0 / |a0|,  e1 = (a1 - (a1 . e0) e0) / |...|,  e2 = e0 x e1
/// ```
///
/// (`a_j` the affine's columns). `e2` is `+-a2 / |a2|` for an affine with
/// orthogonal axes (`-` when the affine mirrors), so the lattice's cubes
/// line up with the voxels either way while `Q` stays a rotation (tets keep
/// their orientation). `None` when the first two axes are parallel or not
/// finite.
pub fn voxel_frame(affine: &Matrix4<f64>) -> Option<Rotation3<f64>> {
    let a0: Vector3<f64> = affine.fixed_view::<3, 1>(0, 0).into_owned();
    let a1: Vector3<f64> = affine.fixed_view::<3, 1>(0, 1).into_owned();
    let e0 = a0.try_normalize(1e-12)?;
    let e1 = (a1 - a1.dot(&e0) * e0).try_normalize(1e-12 * a1.norm())?;
    let e2 = e0.cross(&e1);
    let q = Matrix3::from_columns(&[e0, e1, e2]);
    q.iter()
        .all(|x| x.is_finite())
        .then(|| Rotation3::from_matrix_unchecked(q))
}

/// The smoothed mask as an implicit function in the lattice frame:
/// `g(q) = c - s(o + Q q)` (`s` = 0 outside the grid).
struct SmoothedMask {
    s: Volume<f64>,
    c: f64,
    /// The lattice frame's axes in world coordinates.
    frame: Rotation3<f64>,
    /// The lattice frame's origin in world coordinates.
    origin: Point3<f64>,
}

impl SmoothedMask {
    /// The world point of lattice-frame point `q`: `o + Q q`.
    fn world(&self, q: &Point3<f64>) -> Point3<f64> {
        self.origin + self.frame * q.coords
    }

    /// The lattice-frame point of world point `p`: `Q^T (p - o)`.
    fn local(&self, p: &Point3<f64>) -> Point3<f64> {
        Point3::from(self.frame.inverse() * (p - self.origin))
    }
}

impl Implicit for SmoothedMask {
    fn value(&self, q: &Point3<f64>) -> f64 {
        self.c - self.s.sample_world(&self.world(q), 0).unwrap_or(0.0)
    }
}

/// Coarsens the interior of `mesh` towards edges of `size + d / 2` at
/// depth `d` below its boundary ([`crate::coarsen::coarsen_interior`] with
/// its default angle bounds), then checks the boundary again.
///
/// # Errors
/// As [`crate::coarsen::coarsen_interior`] and
/// [`crate::stuffing::check_closed_manifold`].
pub fn grade(mesh: &TetMesh, size: f64) -> Result<crate::coarsen::Coarsened, MeshError> {
    let boundary = crate::topology::tet_boundary(mesh)?;
    let query = ClosestPointQuery::new(&boundary.surface);
    let target = |p: &Point3<f64>| match query.closest(p) {
        Some(c) => size + 0.5 * c.distance,
        None => size,
    };
    let out = crate::coarsen::coarsen_interior(
        mesh,
        &target,
        &crate::coarsen::CoarsenOptions::default(),
    )?;
    crate::stuffing::check_closed_manifold(&out.mesh)?;
    Ok(out)
}

/// The hint of [`MeshError::Pinched`] from the mesher: what a user changes
/// in the mask or the options.
const PINCH_HINT: &str = "the mask is thinner there than the elements resolve: smooth it more \
                          (--smooth-voxels 2), close it (--dilate 1), or mesh at another \
                          --size-mm";

/// The mesher's errors with its hint for a pinch.
fn with_pinch_hint(e: MeshError) -> MeshError {
    match e {
        MeshError::Pinched {
            at,
            edges,
            vertices,
            rounds,
            ..
        } => MeshError::Pinched {
            at,
            edges,
            vertices,
            rounds,
            hint: PINCH_HINT,
        },
        e => e,
    }
}

/// The largest working grid of the mesher (the mask cropped to its voxels
/// plus the smoothing margin): `512^3` voxels.
pub const MAX_WORKING_VOXELS: usize = 512 * 512 * 512;

/// Bytes per voxel of the working grid: the mask (1), its smoothed copy and
/// the separable filter's buffer (8 each).
const WORKING_BYTES_PER_VOXEL: f64 = 17.0;

/// The mask's checks and sizes (see [`mesh_mask`]'s errors).
fn plan(mask: &Volume<bool>, opts: &MaskMeshOptions) -> Result<Plan, MeshError> {
    let d = mask.dims();
    if d[3] != 1 {
        return Err(MeshError::Image(format!(
            "a mask must be a 3D image, got {} frames",
            d[3]
        )));
    }
    if !(opts.smooth_voxels.is_finite() && opts.smooth_voxels >= 0.0) {
        return Err(MeshError::InvalidArgument(format!(
            "the smoothing must be finite and >= 0 voxels, got {}",
            opts.smooth_voxels
        )));
    }
    if let IsoLevel::Fixed(c) = opts.level
        && !(c > 0.0 && c < 1.0)
    {
        return Err(MeshError::InvalidArgument(format!(
            "the level must be in (0, 1), got {c}"
        )));
    }
    if opts.dilate > 8 {
        return Err(MeshError::InvalidArgument(format!(
            "at most 8 dilations, got {}",
            opts.dilate
        )));
    }
    let spacing = mask.spacing();
    let size = opts
        .size_mm
        .unwrap_or_else(|| spacing.iter().cloned().fold(f64::INFINITY, f64::min));
    if !(size.is_finite() && size > 0.0) {
        return Err(MeshError::InvalidArgument(format!(
            "the element size must be finite and > 0 mm, got {size}"
        )));
    }
    // the voxels set
    let (mut lo, mut hi) = ([usize::MAX; 3], [0usize; 3]);
    let mut count = 0usize;
    for k in 0..d[2] {
        for j in 0..d[1] {
            for i in 0..d[0] {
                if mask.data()[mask.index(i, j, k, 0)] {
                    count += 1;
                    for (a, x) in [i, j, k].into_iter().enumerate() {
                        lo[a] = lo[a].min(x);
                        hi[a] = hi[a].max(x);
                    }
                }
            }
        }
    }
    if count == 0 {
        return Err(MeshError::Empty {
            what: "mask voxels (the mask has no voxel set)",
        });
    }
    let voxel_volume = mask.affine().fixed_view::<3, 3>(0, 0).determinant().abs();
    // crop with room for the dilations, the smoothing kernel and one voxel;
    // its size is checked before anything is allocated (a huge smoothing
    // would otherwise overflow or exhaust memory)
    let margin_f = opts.dilate as f64 + (3.0 * opts.smooth_voxels).ceil() + 2.0;
    let crop_dims: [f64; 3] = std::array::from_fn(|a| (hi[a] - lo[a] + 1) as f64 + 2.0 * margin_f);
    let crop_voxels: f64 = crop_dims.iter().product();
    if crop_voxels > MAX_WORKING_VOXELS as f64 {
        return Err(MeshError::WorkingGridTooLarge {
            what: "smoothing the mask",
            dims: crop_dims,
            voxels: crop_voxels,
            gib: crop_voxels * WORKING_BYTES_PER_VOXEL / f64::from(1u32 << 30),
            limit: MAX_WORKING_VOXELS,
            hint: "lower --smooth-voxels (the kernel reaches 3 sigma) or crop the mask",
        });
    }
    Ok(Plan {
        lo,
        hi,
        count,
        size,
        margin_f,
        voxel_volume,
    })
}

/// What [`plan`] finds before meshing: the voxels set and the sizes.
struct Plan {
    /// The voxels set span `lo ..= hi`.
    lo: [usize; 3],
    hi: [usize; 3],
    /// Voxels set.
    count: usize,
    /// Lattice cube side, mm.
    size: f64,
    /// Crop margin, voxels.
    margin_f: f64,
    /// Volume of one voxel, mm^3.
    voxel_volume: f64,
}

/// Bytes per BCC lattice vertex at the stuffing's peak: position, value
/// and nearest cut (72 B) and the position copy of the output (24 B),
/// with the allocator's slack (a least-squares fit of the peaks of
/// `unfold mesh` at 0.5 .. 2 mm gave 160 B per vertex of the lattice
/// without the smoothing's reach, which this box includes; kept about 20 %
/// above what the runs need, as peaks vary by some 10 % run to run).
const BYTES_PER_LATTICE_VERTEX: f64 = 150.0;
/// Bytes per output tet at the peak (the filled tets, their compacted
/// copy, components and the writer's buffers; fitted 79 B, kept above
/// every measured run with a 20 % margin: the estimate is 1.2 to 1.9
/// times the measured peak from 3 mm to 0.5 mm on a 2 mm placenta mask).
const BYTES_PER_TET: f64 = 200.0;
/// Tets per lattice cube inside the domain (12 in the BCC fill, a few
/// more along the boundary: 12.2 .. 12.6 measured).
const TETS_PER_CUBE: f64 = 13.0;
/// What the process holds besides (the binary, threads, buffers).
const BASE_BYTES: f64 = 48.0 * 1024.0 * 1024.0;

impl Plan {
    /// The memory [`mesh_mask`] will allocate: the working grid (the
    /// cropped mask, its smoothed copy, the filter's buffer:
    /// 17 B per voxel), the BCC lattice over the box to mesh
    /// (`(n+1)^3 + n^3` vertices for `n` cubes per axis, the box the
    /// voxels set plus the smoothing's reach in the lattice frame) and the
    /// tets (`13 V / h^3` for the mask's volume `V`).
    fn estimate(&self, mask: &Volume<bool>, opts: &MaskMeshOptions) -> MemoryEstimate {
        let crop: f64 = (0..3)
            .map(|a| (self.hi[a] - self.lo[a] + 1) as f64 + 2.0 * self.margin_f)
            .product();
        let reach = (opts.dilate + 1) as f64 + (3.0 * opts.smooth_voxels).ceil();
        let frame = voxel_frame(mask.affine()).unwrap_or_else(Rotation3::identity);
        let (mut bmin, mut bmax) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for c in 0..8 {
            let corner = |a: usize| {
                if c & (1 << a) == 0 {
                    self.lo[a] as f64 - reach
                } else {
                    self.hi[a] as f64 + reach
                }
            };
            let w = mask.voxel_to_world(&Point3::new(corner(0), corner(1), corner(2)));
            let q = frame.inverse() * w.coords;
            for a in 0..3 {
                bmin[a] = bmin[a].min(q[a]);
                bmax[a] = bmax[a].max(q[a]);
            }
        }
        let cubes: Vec<f64> = (0..3)
            .map(|a| ((bmax[a] - bmin[a]) / self.size).ceil() + 4.0)
            .collect();
        let lattice =
            cubes.iter().map(|n| n + 1.0).product::<f64>() + cubes.iter().product::<f64>();
        let volume =
            self.count as f64 * self.voxel_volume * f64::from(opts.dilate as u32 + 1).powi(3);
        let tets = TETS_PER_CUBE * volume / self.size.powi(3);
        let mut e = MemoryEstimate::new()
            .with("base", 1.0, BASE_BYTES)
            .with("working grid", crop, WORKING_BYTES_PER_VOXEL)
            .with("lattice", lattice, BYTES_PER_LATTICE_VERTEX)
            .with("tets", tets, BYTES_PER_TET);
        if opts.grade {
            // the closest-point tree of the boundary and the collapse
            // queues: about as much again per tet
            e.add("grading", tets * BYTES_PER_TET);
        }
        e
    }
}

/// The memory [`mesh_mask`] will allocate on `mask` with `opts`, before
/// it allocates anything (one pass over the mask for its voxels set): see
/// `Plan::estimate`.
///
/// # Errors
/// Those of [`mesh_mask`]'s checks of the mask and the options.
pub fn estimate_memory(
    mask: &Volume<bool>,
    opts: &MaskMeshOptions,
) -> Result<MemoryEstimate, MeshError> {
    Ok(plan(mask, opts)?.estimate(mask, opts))
}

/// Meshes the mask (see the module doc).
///
/// # Errors
/// `Image` for a 4D mask; `Empty` for a mask with no voxel set or one whose
/// smoothed level set is empty (an object thinner than the smoothing
/// removes); `InvalidArgument` for bad options; `WorkingGridTooLarge` when
/// the cropped mask plus the smoothing margin would exceed
/// [`MAX_WORKING_VOXELS`]; the errors of [`stuff`].
pub fn mesh_mask(mask: &Volume<bool>, opts: &MaskMeshOptions) -> Result<MaskMesh, MeshError> {
    let Plan {
        lo,
        hi,
        count,
        size,
        margin_f,
        voxel_volume,
    } = plan(mask, opts)?;
    let margin = margin_f as i64;
    let start = lo.map(|x| x as i64 - margin);
    let dims = [0, 1, 2].map(|a| hi[a] - lo[a] + 1 + 2 * margin as usize);
    let mut m = crop(mask, start, dims)?;
    for _ in 0..opts.dilate {
        m = mask::dilate_box(&m)?;
    }
    let s = mask::gaussian_smooth(&m.map(|b| if b { 1.0 } else { 0.0 }), opts.smooth_voxels)?;
    let c = match opts.level {
        IsoLevel::Fixed(c) => c,
        IsoLevel::PreserveVolume => {
            let n = m.data().iter().filter(|&&b| b).count();
            let mut v = s.data().to_vec();
            let (_, nth, _) = v.select_nth_unstable_by(n - 1, |a, b| b.total_cmp(a));
            *nth
        }
    };
    // s > c only within one voxel of the (dilated) voxels set when c >= 0.5;
    // lower levels reach farther
    let c = c.clamp(1e-3, 1.0 - 1e-3);
    let reach = (opts.dilate + 1) as f64
        + if c < 0.5 {
            (3.0 * opts.smooth_voxels).ceil()
        } else {
            0.0
        };
    let frame = voxel_frame(s.affine()).ok_or_else(|| {
        MeshError::Image(format!(
            "the mask's voxel axes are degenerate (affine {:?}); fix its header",
            s.affine()
        ))
    })?;
    let origin = s.voxel_to_world(&Point3::origin());
    let f = SmoothedMask {
        s,
        c,
        frame,
        origin,
    };
    // the box to mesh, in the lattice frame
    let (mut bmin, mut bmax) = (
        Point3::from([f64::INFINITY; 3]),
        Point3::from([f64::NEG_INFINITY; 3]),
    );
    // in the crop's voxel coordinates the voxels set span
    // [margin, margin + hi - lo] per axis
    for c in 0..8 {
        let corner = |a: usize| {
            if c & (1 << a) == 0 {
                margin as f64 - reach
            } else {
                (margin as usize + hi[a] - lo[a]) as f64 + reach
            }
        };
        let w = f.local(&f.s.voxel_to_world(&Point3::new(corner(0), corner(1), corner(2))));
        for a in 0..3 {
            bmin[a] = bmin[a].min(w[a]);
            bmax[a] = bmax[a].max(w[a]);
        }
    }
    let Stuffed {
        mut mesh,
        components,
        dropped_components,
        pinches,
        ..
    } = stuff(&f, bmin, bmax, size, opts.keep_all_components).map_err(|e| match e {
        MeshError::Empty { .. } => MeshError::Empty {
            what: "tets (nothing of the mask is left above the level after smoothing)",
        },
        e => with_pinch_hint(e),
    })?;
    // back to world coordinates (a rotation: the tets keep their orientation)
    for p in &mut mesh.positions {
        *p = f.world(p);
    }
    let (mesh, graded_collapses) = if opts.grade {
        let g = grade(&mesh, size)?;
        (g.mesh, g.collapses)
    } else {
        (mesh, 0)
    };
    Ok(MaskMesh {
        mesh,
        pinches,
        graded_collapses,
        components,
        dropped_components,
        size_mm: size,
        level: c,
        mask_voxels: count,
        mask_volume_mm3: count as f64 * voxel_volume,
    })
}
