//! `unfold demo [-o DIR]`: the built-in synthetic shapes, written with their
//! info; the placenta pipeline run on a built-in slab with the synthetic
//! MRI (outputs in `DIR/placenta/`) and the mitral pipeline on the built-in
//! valve (outputs in `DIR/mitral/`), and the ventricle pipeline on the
//! built-in cup (its inner cup as the anatomy, outputs in
//! `DIR/ventricle/`).

use super::AppError;
use crate::app::placenta::ImageInput;
use crate::app::run::StagedOutputs;
use crate::io::{NiftiImage, WriteOptions, atomic_write, write_image, write_mesh};
use crate::mesh::geometry::bounding_box;
use crate::mesh::nalgebra::{Matrix4, Point3, Rotation3, Vector3};
use crate::mesh::shapes::{
    PlacentaParams, Pose, ValveParams, VentricleParams, VentricleShape, mitral_valve,
    placenta_slab, ventricle_cup,
};
use crate::mesh::spatial::TetLocator;
use crate::mesh::{CellMesh, CellType, Volume};
use crate::organs::placenta::prepare_mesh;
use crate::organs::ventricle::rings_meridians::rings_and_meridians;
use clap::Args;
use std::path::{Path, PathBuf};

/// Arguments of `unfold demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Output directory (created if missing) [default: unfold-demo, with --cohort
    /// unfold-cohort-demo].
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Instead: a small synthetic cohort (8 placentas, 6 ventricles, 6 valves) run through
    /// `unfold batch` into DIR/study/, with the cohort table and statistics.
    #[arg(long)]
    cohort: bool,
    /// With --cohort: the number of placentas (7,200 tets each, one MRI each).
    #[arg(long, value_name = "N", default_value_t = 8, requires = "cohort",
          value_parser = clap::value_parser!(u32).range(1..=10000))]
    placentas: u32,
}

fn points_mesh(points: &[crate::mesh::nalgebra::Point3<f64>]) -> CellMesh {
    let mut m = CellMesh::from_points(points.to_vec());
    for i in 0..points.len() as u32 {
        m.push_cell(CellType::Vertex, &[i]);
    }
    m
}

/// A closed ring as 2-point line segments (meshio reads `line` cells, not
/// VTK's poly-lines).
fn ring_mesh(points: &[crate::mesh::nalgebra::Point3<f64>]) -> CellMesh {
    let mut m = CellMesh::from_points(points.to_vec());
    let n = points.len() as u32;
    for i in 0..n {
        m.push_cell(CellType::Line, &[i, (i + 1) % n]);
    }
    m
}

/// Runs `unfold demo`.
pub fn run(a: &DemoArgs) -> Result<(), AppError> {
    if a.cohort {
        let dir = a
            .output
            .clone()
            .unwrap_or_else(|| PathBuf::from("unfold-cohort-demo"));
        return super::demo_cohort::run(&dir, a.placentas as usize);
    }
    let output = a
        .output
        .clone()
        .unwrap_or_else(|| PathBuf::from("unfold-demo"));
    // Everything is written into a staging directory and put in place at
    // the end (`StagedOutputs`); messages name the final paths.
    let mut staged = StagedOutputs::new(Vec::<PathBuf>::new());
    let staging = staged.dir(&output)?;
    write_demo(&staging, &staged).map_err(|e| super::shown(&staged, e))?;
    Ok(staged.commit()?)
}

/// Writes the demo's shapes and pipeline outputs into `dir`, the staging
/// directory of `staged`.
fn write_demo(dir: &Path, staged: &StagedOutputs) -> Result<(), AppError> {
    let opts = WriteOptions::default();
    let mut written: Vec<(PathBuf, String)> = Vec::new();
    let mut put = |name: &str, mesh: CellMesh, what: &str| -> Result<(), AppError> {
        let p = dir.join(name);
        write_mesh(&p, &mesh, &opts)?;
        written.push((p, what.to_string()));
        Ok(())
    };

    let placenta = placenta_slab(&PlacentaParams {
        pose: SCANNER_POSE,
        ..PlacentaParams::default()
    })?;
    put(
        "placenta.vtu",
        CellMesh::from(&placenta.mesh),
        "placenta-like slab (tets), point array `side`: 0 interior, 1 fetal, 2 maternal, 3 rim",
    )?;

    let v = ventricle_cup(&VentricleParams::default())?;
    put(
        "ventricle_surface.vtu",
        CellMesh::from(&v.surface),
        "ventricle-like cup S (disk topology, basal rim)",
    )?;
    put(
        "ventricle_anatomy.vtu",
        CellMesh::from(&v.anatomy),
        "anatomy surface inside S",
    )?;
    put(
        "ventricle_points.vtu",
        points_mesh(&v.anatomy_points),
        "anatomy points inside S (rings and meridians)",
    )?;
    put(
        "ventricle_landmarks.vtu",
        points_mesh(&[v.anterior, v.inferior, v.apex]),
        "landmarks: anterior, inferior, apex",
    )?;

    let valve = mitral_valve(&ValveParams::default())?;
    put(
        "valve_anterior.vtu",
        CellMesh::from(&valve.anterior),
        "anterior leaflet",
    )?;
    put(
        "valve_posterior.vtu",
        CellMesh::from(&valve.posterior),
        "posterior leaflet",
    )?;
    put(
        "valve_annulus.vtu",
        ring_mesh(&valve.annulus),
        "annulus ring (closed, as line segments, clockwise from the atrium, from the anterolateral commissure)",
    )?;

    // The pipeline runs on a coarser slab of the same shape (about 10,000
    // tets, so the demo stays quick in debug builds); the MRI covers both.
    let small = placenta_slab(&PlacentaParams {
        cells_radial: PIPELINE_CELLS_RADIAL,
        pose: SCANNER_POSE,
        ..PlacentaParams::default()
    })?;
    let covered: Vec<Point3<f64>> = placenta
        .mesh
        .positions
        .iter()
        .chain(&small.mesh.positions)
        .copied()
        .collect();
    let img = synthetic_mri(&covered, &TetLocator::new(&placenta.mesh))?;
    let img_path = dir.join("placenta_mri.nii.gz");
    write_image(&img_path, &img)?;
    written.push((
        img_path,
        "synthetic MRI around the slab: 2 mm oblique grid, intensity a smooth function of position"
            .into(),
    ));

    let mut infos = Vec::new();
    for (p, what) in &written {
        let (json, valid) = crate::app::mesh::info::info_json(p)?;
        infos.push(format!("\"{}\": {json}", file_name(p)));
        println!(
            "wrote {} ({what}){}",
            staged.shown(p).display(),
            if valid {
                ""
            } else {
                " [has validity problems]"
            }
        );
    }
    let json = format!("{{\n{}\n}}\n", infos.join(",\n"));
    let info_path = dir.join("info.json");
    atomic_write(&info_path, json.as_bytes())?;
    println!(
        "wrote {} (info of every file above)",
        staged.shown(&info_path).display()
    );

    let label = format!(
        "built-in placenta slab ({PIPELINE_CELLS_RADIAL} radial cells, {} tets)",
        small.mesh.num_tets()
    );
    let inputs = crate::app::placenta::Inputs {
        label: label.clone(),
        mesh: prepare_mesh(&small.mesh).map_err(|source| AppError::Organ {
            path: label.clone(),
            source,
        })?,
        images: vec![ImageInput {
            path: dir.join("placenta_mri.nii.gz"),
            name: "placenta_mri".into(),
            image: img,
        }],
        frame: crate::io::Frame::Ras,
        voxel_mm: crate::app::placenta::settings::DEFAULT_VOXEL_MM,
        segmentation: None,
    };
    let settings = crate::app::placenta::Settings::default();
    let mut progress = super::progress::Progress::new(true);
    let run = crate::app::placenta::run(&settings, &inputs, &mut progress)?;
    let written = crate::app::placenta::write(
        &run,
        &settings,
        &inputs,
        &crate::app::placenta::Outputs {
            dir: &dir.join("placenta"),
            displacement: None,
            staged,
        },
        &mut progress,
    )?;
    drop(progress);
    let summary = super::placenta::Summary {
        label: label.clone(),
        report: run.report.report,
        written,
    };
    println!("{summary}");

    // The mitral pipeline, from the valve files written above.
    let files = crate::app::mitral::ValveFiles {
        anterior: dir.join("valve_anterior.vtu"),
        posterior: dir.join("valve_posterior.vtu"),
        annulus: Some(dir.join("valve_annulus.vtu")),
    };
    let mitral_dir = dir.join("mitral");
    let run = crate::app::mitral::run_valve(
        &files,
        &crate::organs::mitral::Pipeline::new(),
        &crate::app::mitral::Outputs {
            dir: &mitral_dir,
            staged,
        },
        true,
        &mut crate::app::observer::Quiet,
    )?;
    println!(
        "built-in mitral valve: {}",
        crate::app::mitral::summary(&run.outcome.report)
    );
    println!(
        "wrote {} (valve3d.vtu, valve2d.vtu, report.json)",
        staged.shown(&mitral_dir).display()
    );

    // The ventricle pipeline on the built-in cup, its inner cup the anatomy.
    let ventricle_dir = dir.join("ventricle");
    let settings = crate::app::ventricle::Settings {
        chart: crate::app::ventricle::ChartSettings {
            grid_mm: VENTRICLE_GRID_MM,
            ..Default::default()
        },
        ..Default::default()
    };
    let (anatomy, rings, meridians) = cup_anatomy(&v);
    let inputs = crate::app::ventricle::Inputs {
        anatomy_label: "built-in ventricle cup: inner cup, rings and meridians".into(),
        anatomy,
        surface_label: "built-in ventricle cup: S".into(),
        surface: v.surface.clone(),
        landmarks: crate::organs::ventricle::LandmarkPoints {
            anterior: v.anterior,
            inferior: v.inferior,
            apex: Some(v.apex),
            rim_near: None,
        },
        from_rv: None,
        enclosing: None,
        transfer: None,
    };
    let mut progress = super::progress::Progress::new(false);
    let run = crate::app::ventricle::run(&settings, &inputs, &mut progress)?;
    crate::app::ventricle::write(
        &run,
        &settings,
        &inputs,
        &crate::app::ventricle::Outputs {
            dir: &ventricle_dir,
            staged,
        },
    )?;
    drop(progress);
    println!(
        "built-in ventricle cup: {}",
        super::ventricle::summary(&run.outcome.report)
    );
    let check = rings_and_meridians(&run.outcome.coords, &rings, &meridians);
    println!(
        "built-in ventricle cup: {} rings of constant height -> circles of the disk (worst \
         radius spread {:.2} %), {} meridians -> rays (worst angle spread {:.2} deg); drawn in \
         figures/cylinder.png",
        rings.len(),
        100.0 * check.worst_radius_spread,
        meridians.len(),
        check.worst_angle_deg
    );
    println!(
        "wrote {} (normalized.vtu, anatomy.vtu, disk.vtu, report.json)",
        staged.shown(&ventricle_dir).display()
    );
    Ok(())
}

/// The demo's ventricle anatomy: the cup's inner cup (triangles), then
/// its rings of constant height (closed polylines) and its meridians (open
/// polylines, apex to base), so that the cylinder figure shows where they
/// go (ALGORITHMS 3.7: rings to circles, meridians to rays). Returns the
/// mesh and the rings and meridians as indices into its points.
fn cup_anatomy(v: &VentricleShape) -> (CellMesh, Vec<Vec<usize>>, Vec<Vec<usize>>) {
    let mut mesh = CellMesh::from(&v.anatomy);
    let offset = mesh.positions.len();
    mesh.positions.extend(v.anatomy_points.iter().copied());
    let shift = |line: &[usize]| -> Vec<usize> { line.iter().map(|&i| i + offset).collect() };
    let rings: Vec<Vec<usize>> = v.anatomy_rings.iter().map(|r| shift(r)).collect();
    let meridians: Vec<Vec<usize>> = v.anatomy_meridians.iter().map(|m| shift(m)).collect();
    for ring in &rings {
        let mut closed: Vec<u32> = ring.iter().map(|&i| i as u32).collect();
        if let Some(&first) = closed.first() {
            closed.push(first);
        }
        mesh.push_cell(CellType::PolyLine, &closed);
    }
    for m in &meridians {
        let line: Vec<u32> = m.iter().map(|&i| i as u32).collect();
        mesh.push_cell(CellType::PolyLine, &line);
    }
    (mesh, rings, meridians)
}

/// Grid spacing of the demo's Laplace field, mm (coarser than the default
/// 0.5 mm, so that the demo stays quick).
const VENTRICLE_GRID_MM: f64 = 1.0;

/// Where the demo's placenta lies in the scanner (RAS, mm), as in a real
/// scan away from the origin: so that a mesh mirrored in x and y (LPS read
/// as RAS) misses the placenta in the MRI.
const SCANNER_POSE: Pose = Pose {
    rotation_deg: [0.0, 0.0, 20.0],
    translation: [70.0, 40.0, 10.0],
};

/// Radial resolution of the slab the demo runs the placenta pipeline on:
/// `18 n^2 m` = 10,368 tets with the default 4 layers.
const PIPELINE_CELLS_RADIAL: usize = 12;

fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// The intensity of the synthetic MRI at world point `p` (mm) inside the
/// placenta: smooth (from about 100 to 300), so that a pull-back through
/// any map can be checked against it.
pub fn synthetic_intensity(p: &Point3<f64>) -> f64 {
    200.0 + 40.0 * (p.x / 15.0).sin() + 30.0 * (p.y / 20.0).cos() + 2.0 * (p.z - 10.0)
}

/// The synthetic MRI's background (outside the placenta).
const BACKGROUND: f64 = 20.0;

/// A 2 mm image covering `points` with a 10 mm margin, on a grid rotated by
/// 10 degrees about z (an oblique scanner frame), holding
/// [`synthetic_intensity`] inside the placenta (`inside`) and a dark
/// background elsewhere.
fn synthetic_mri(points: &[Point3<f64>], inside: &TetLocator) -> Result<NiftiImage, AppError> {
    let spacing = 2.0;
    let bb = bounding_box(points).ok_or_else(|| AppError::Usage("empty shape".into()))?;
    let rot = Rotation3::from_axis_angle(&Vector3::z_axis(), 10f64.to_radians());
    // Extent of the box in the rotated frame, from its 8 corners.
    let centre = bb.center();
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for c in 0..8 {
        let corner = Vector3::new(
            if c & 1 == 0 { bb.min.x } else { bb.max.x },
            if c & 2 == 0 { bb.min.y } else { bb.max.y },
            if c & 4 == 0 { bb.min.z } else { bb.max.z },
        );
        let q = rot.inverse() * (corner - centre.coords);
        lo = lo.inf(&q);
        hi = hi.sup(&q);
    }
    lo -= Vector3::repeat(10.0);
    hi += Vector3::repeat(10.0);
    let dims: [usize; 3] = std::array::from_fn(|a| ((hi[a] - lo[a]) / spacing).ceil() as usize + 1);
    let mut affine = Matrix4::identity();
    let m = rot.matrix() * spacing;
    affine.fixed_view_mut::<3, 3>(0, 0).copy_from(&m);
    let origin = centre.coords + rot * lo;
    affine.fixed_view_mut::<3, 1>(0, 3).copy_from(&origin);
    let mut data = Vec::with_capacity(dims.iter().product());
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = affine.transform_point(&Point3::new(i as f64, j as f64, k as f64));
                let v = if inside.locate(&p).is_some() {
                    synthetic_intensity(&p)
                } else {
                    BACKGROUND
                };
                data.push(v as f32);
            }
        }
    }
    let vol = Volume::new([dims[0], dims[1], dims[2], 1], affine, data)?;
    Ok(NiftiImage::new(vol))
}
