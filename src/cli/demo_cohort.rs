//! `unfold demo --cohort [-o DIR]`: a small synthetic cohort run through
//! `unfold batch` (issue 19), so a new user sees the cohort outputs in one
//! command.
//!
//! `DIR/inputs/` gets 8 placenta slabs (7,200 tets; `--placentas N` for
//! another number, e.g. the cohort bench's 100) of different sizes and poses, each
//! with an MRI whose tissue values move with the body (plus a per-subject
//! offset, so the cohort statistics have something to show), 6 ventricle
//! cups of different radii and poses with their landmarks, and 6 mitral
//! valves of different diameters and one valve over three time steps (a
//! series); `DIR/manifest.csv` names them with the
//! covariates `age_weeks`, `group` and, for the valves, `phase` (`open`:
//! the free edges 6 mm apart, `closed`: 1 mm); then `unfold batch` runs them into
//! `DIR/study/` (every placenta on one template grid, so
//! `DIR/study/cohort/` holds the voxel-wise statistics) and gathers the
//! cohort table, every subject's figures and the report page
//! `DIR/study/index.html`. Rerunning skips the subjects already done.

use super::AppError;
use crate::io::{NiftiImage, WriteOptions, write_image, write_mesh};
use crate::mesh::nalgebra::{Matrix4, Point3, Vector3};
use crate::mesh::shapes::{
    PlacentaParams, Pose, ValveParams, VentricleParams, mitral_valve, placenta_slab, ventricle_cup,
};
use crate::mesh::spatial::TetLocator;
use crate::mesh::{CellMesh, CellType, Volume};
use std::fmt::Write as _;
use std::path::Path;

/// The common template grid of the placentas, mm, and its spacing.
const GRID: &str = "-120,120,-120,120,-40,40";
const GRID_SPACING_MM: &str = "3";

/// An MRI around a slab in `pose`: 2 mm voxels, the body's value
/// `400 + 2 x - 3 y + 5 z + offset` at its rest position `(x, y, z)` inside
/// the mesh, 50 outside.
fn mri(mesh: &crate::mesh::TetMesh, pose: &Pose, offset: f64) -> Result<NiftiImage, AppError> {
    let (mut lo, mut hi) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for p in &mesh.positions {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    lo -= Vector3::repeat(8.0);
    hi += Vector3::repeat(8.0);
    let spacing = 2.0;
    let dims: [usize; 3] = std::array::from_fn(|a| ((hi[a] - lo[a]) / spacing).ceil() as usize + 1);
    let mut affine = Matrix4::new_scaling(spacing);
    affine[(3, 3)] = 1.0;
    affine.fixed_view_mut::<3, 1>(0, 3).copy_from(&lo);
    let inside = TetLocator::new(mesh);
    let back = pose.isometry().inverse();
    let mut data = Vec::with_capacity(dims.iter().product());
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = affine.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                let v = if inside.locate(&p).is_some() {
                    let q = back * p;
                    400.0 + 2.0 * q.x - 3.0 * q.y + 5.0 * q.z + offset
                } else {
                    50.0
                };
                data.push(v as f32);
            }
        }
    }
    Ok(NiftiImage::new(Volume::new(
        [dims[0], dims[1], dims[2], 1],
        affine,
        data,
    )?))
}

/// `x,y,z` quoted for a CSV cell.
fn xyz(p: &Point3<f64>) -> String {
    format!("\"{:?},{:?},{:?}\"", p.x, p.y, p.z)
}

/// A closed ring as line segments.
fn ring(points: &[Point3<f64>]) -> CellMesh {
    let mut m = CellMesh::from_points(points.to_vec());
    let n = points.len() as u32;
    for i in 0..n {
        m.push_cell(CellType::Line, &[i, (i + 1) % n]);
    }
    m
}

/// Writes the cohort's inputs and manifest into `dir`, returns the
/// manifest's path.
fn write_inputs(dir: &Path, placentas: usize) -> Result<std::path::PathBuf, AppError> {
    let opts = WriteOptions::default();
    let inputs = dir.join("inputs");
    super::ensure_dir(&inputs)?;
    let mut csv = String::from(
        "id,organ,input,image,grid,spacing-mm,surface,anterior,inferior,apex,grid-mm,posterior,\
         annulus,series,age_weeks,group,phase\n",
    );
    for k in 0..placentas {
        let f = k as f64;
        let pose = Pose::new(
            [10.0 * f - 35.0, 20.0 * (f * 0.7).sin(), 15.0 * f],
            [5.0 * f, -3.0 * f, 2.0 * f],
        );
        let shape = placenta_slab(&PlacentaParams {
            length: 150.0 + 8.0 * (f % 8.0),
            width: 120.0 + 5.0 * (f % 8.0),
            cells_radial: 10,
            cells_through: 4,
            pose,
            ..PlacentaParams::default()
        })?;
        let id = format!("placenta{:03}", k + 1);
        // one folder per subject: every image is `t2`, so the cohort
        // gathers them under one name
        super::ensure_dir(&inputs.join(&id))?;
        let mesh_path = inputs.join(&id).join("mesh.vtu");
        write_mesh(&mesh_path, &CellMesh::from(&shape.mesh), &opts)?;
        let img_path = inputs.join(&id).join("t2.nii.gz");
        write_image(&img_path, &mri(&shape.mesh, &pose, 10.0 * f)?)?;
        let _ = writeln!(
            csv,
            "{id},placenta,inputs/{id}/mesh.vtu,inputs/{id}/t2.nii.gz,\"{GRID}\",{GRID_SPACING_MM},,,,,,,,,\
             {},{},",
            28 + 2 * (k % 8),
            if k % 2 == 0 { "singleton" } else { "twin" }
        );
    }
    for k in 0..6 {
        let f = k as f64;
        let v = ventricle_cup(&VentricleParams {
            radius: 20.0 + 1.5 * f,
            pose: Pose::new(
                [15.0 * f, -10.0 * f, 20.0 * f],
                [3.0 * f, 4.0 * f, -2.0 * f],
            ),
            ..VentricleParams::default()
        })?;
        let id = format!("ventricle{:02}", k + 1);
        write_mesh(
            inputs.join(format!("{id}_surface.vtu")),
            &CellMesh::from(&v.surface),
            &opts,
        )?;
        write_mesh(
            inputs.join(format!("{id}_anatomy.vtu")),
            &CellMesh::from(&v.anatomy),
            &opts,
        )?;
        let _ = writeln!(
            csv,
            "{id},ventricle,inputs/{id}_anatomy.vtu,,,,inputs/{id}_surface.vtu,{},{},{},1.5,,,,\
             {},{},",
            xyz(&v.anterior),
            xyz(&v.inferior),
            xyz(&v.apex),
            30 + 3 * k,
            if k < 3 { "control" } else { "patient" }
        );
    }
    for k in 0..6 {
        let f = k as f64;
        // even valves open (diastole: the free edges 6 mm apart), odd ones
        // closed (1 mm)
        let open = k % 2 == 0;
        let valve = mitral_valve(&ValveParams {
            commissural_diameter: 34.0 + 1.5 * f,
            anteroposterior_diameter: 26.0 + 1.0 * f,
            coaptation_gap: if open { 6.0 } else { 1.0 },
            ..ValveParams::default()
        })?;
        let id = format!("valve{:02}", k + 1);
        let (a, p, r) = (
            format!("inputs/{id}_anterior.vtu"),
            format!("inputs/{id}_posterior.vtu"),
            format!("inputs/{id}_annulus.vtu"),
        );
        write_mesh(dir.join(&a), &CellMesh::from(&valve.anterior), &opts)?;
        write_mesh(dir.join(&p), &CellMesh::from(&valve.posterior), &opts)?;
        write_mesh(dir.join(&r), &ring(&valve.annulus), &opts)?;
        let _ = writeln!(
            csv,
            "{id},mitral,,,,,,{a},,,,{p},{r},,{},{},{}",
            40 + 4 * k,
            if open { "open" } else { "closed" },
            if open { "open" } else { "closed" }
        );
    }
    // one valve over three time steps (the coaptation gap opening)
    let series = inputs.join("valveseries");
    super::ensure_dir(&series)?;
    for step in 0..3 {
        let valve = mitral_valve(&ValveParams {
            coaptation_gap: 1.0 + 3.0 * step as f64,
            ..ValveParams::default()
        })?;
        let p = |what: &str| series.join(format!("t{step:02}_{what}.vtu"));
        write_mesh(p("anterior"), &CellMesh::from(&valve.anterior), &opts)?;
        write_mesh(p("posterior"), &CellMesh::from(&valve.posterior), &opts)?;
        write_mesh(p("annulus"), &ring(&valve.annulus), &opts)?;
    }
    let _ = writeln!(
        csv,
        "valveseries,mitral,,,,,,,,,,,,inputs/valveseries,44,series,"
    );
    let manifest = dir.join("manifest.csv");
    crate::io::atomic_write(&manifest, csv.as_bytes())?;
    Ok(manifest)
}

/// Runs `unfold demo --cohort` into `dir`.
///
/// # Errors
/// Writing the inputs; the batch's errors (a failed subject).
pub(crate) fn run(dir: &Path, placentas: usize) -> Result<(), AppError> {
    let manifest = write_inputs(dir, placentas)?;
    println!(
        "wrote {} ({placentas} placentas, 6 ventricles, 6 valves and a valve series, covariates \
         age_weeks, group and phase)",
        manifest.display()
    );
    super::cohort::run_manifest(&manifest, &dir.join("study"), None)
}
