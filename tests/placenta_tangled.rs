//! Injectivity, not just orientation, through the binary: a tangled
//! placenta mesh (a vertex dragged past its neighbour; a strong jitter) is
//! refused with the first folded face named, a slab wound through itself
//! (locally injective, overlapping globally) with the two boundary faces
//! that meet named, a mirrored one (every tet negative, nothing
//! overlapping) is mapped, and the report counts the output's folded and
//! overlapping boundary faces as well as its inverted tets; a full mask is
//! refused for what it is.

use unfold::io::{WriteOptions, write_mesh};
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::shapes::{PlacentaParams, placenta_slab};
use unfold::mesh::{CellMesh, TetMesh};

mod common;
#[path = "common/wound.rs"]
mod wound;
use common::*;
use wound::wound_slab;

fn slab() -> TetMesh {
    placenta_slab(&PlacentaParams {
        cells_radial: 6,
        cells_through: 2,
        ..PlacentaParams::default()
    })
    .expect("valid slab parameters")
    .mesh
}

/// An interior vertex of `mesh` (not on the boundary) and a neighbour.
fn interior_vertex_and_neighbour(mesh: &TetMesh) -> (usize, usize) {
    let boundary = unfold::mesh::topology::tet_boundary(mesh).unwrap();
    let on_boundary: std::collections::HashSet<u32> = boundary.to_volume.iter().copied().collect();
    for t in &mesh.tets {
        for &a in t {
            if !on_boundary.contains(&a) {
                let b = t.iter().copied().find(|&b| b != a).unwrap();
                return (a as usize, b as usize);
            }
        }
    }
    panic!("the slab has interior vertices");
}

fn run(dir: &std::path::Path, name: &str, mesh: &TetMesh) -> std::process::Output {
    let path = dir.join(format!("{name}.vtu"));
    write_mesh(&path, &CellMesh::from(mesh), &WriteOptions::default()).unwrap();
    unfold(&[
        "placenta",
        &s(&path),
        "-o",
        &s(&dir.join(name)),
        "--no-figures",
    ])
}

#[test]
fn tangled_meshes_are_refused_and_mirrored_ones_mapped() {
    let dir = tempfile::tempdir().unwrap();
    let clean = slab();
    let (a, b) = interior_vertex_and_neighbour(&clean);

    // A vertex dragged past its neighbour.
    let mut dragged = clean.clone();
    let (pa, pb) = (clean.positions[a], clean.positions[b]);
    dragged.positions[a] = pa + (pb - pa) * 1.7;
    let o = run(dir.path(), "dragged", &dragged);
    assert_one_line_error(&o, "the mesh is tangled");
    assert!(stderr(&o).contains("untangle or remesh"), "{}", stderr(&o));
    assert!(!dir.path().join("dragged").exists(), "nothing written");

    // A jitter of the order of the cell size tangles many faces.
    let mut jittered = clean.clone();
    let h = 3.0;
    for (k, p) in jittered.positions.iter_mut().enumerate() {
        let f = k as f64;
        *p += unfold::mesh::nalgebra::Vector3::new(
            h * (1.3 * f).sin(),
            h * (2.1 * f).cos(),
            0.5 * h * (0.7 * f).sin(),
        );
    }
    let o = run(dir.path(), "jittered", &jittered);
    assert_one_line_error(&o, "the mesh is tangled");

    // Mirrored: every tet negative, nothing folded: mapped, reoriented.
    let mut mirrored = clean.clone();
    for p in &mut mirrored.positions {
        *p = Point3::new(-p.x, p.y, p.z);
    }
    let o = run(dir.path(), "mirrored", &mirrored);
    assert_ok(&o);
    let r: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("mirrored/report.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(r["input"]["reoriented_tets"], clean.tets.len());
    assert_eq!(r["folded_faces"], 0);
    assert_eq!(r["overlapping_boundary_faces"], 0);
    assert_eq!(r["inverted_tets"], 0);
}

/// Locally injective but overlapping globally: refused naming the two
/// boundary faces that meet and where, before any optimization.
#[test]
fn a_slab_wound_through_itself_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let wound = wound_slab(150, 1.25);
    assert!(unfold::mesh::geometry::folded_faces(&wound).is_empty());
    let pos = &wound.positions;
    assert!(wound.tets.iter().all(|t| {
        let [a, b, c, d] = t.map(|v| pos[v as usize]);
        unfold::mesh::geometry::tet_signed_volume(&a, &b, &c, &d) > 0.0
    }));
    let o = run(dir.path(), "wound", &wound);
    assert_one_line_error(
        &o,
        "the mesh overlaps itself: its boundary meets itself at (",
    );
    let e = stderr(&o);
    assert!(e.contains("remesh it"), "{e}");
    assert!(
        e.contains("boundary face [") && e.contains(" of tet "),
        "{e}"
    );
    assert!(!e.contains("tangled"), "{e}");
    // the point named lies in the overlapping stretch of the ring
    let at = &e[e.find("at (").unwrap() + 4..];
    let xyz: Vec<f64> = at[..at.find(')').unwrap()]
        .split(", ")
        .map(|c| c.parse().unwrap())
        .collect();
    let r = xyz[0].hypot(xyz[1]);
    assert!((26.0..=30.5).contains(&r), "{xyz:?}");
    assert!(!dir.path().join("wound").exists(), "nothing written");
}

/// A mask with every voxel set (an inverted mask) is refused for what it
/// is, not blamed on `--margin-mm`.
#[test]
fn a_full_mask_is_refused_for_what_it_is() {
    let dir = tempfile::tempdir().unwrap();
    let mask = dir.path().join("ones.nii.gz");
    let affine = unfold::mesh::nalgebra::Matrix4::new_scaling(3.0);
    let mut affine = affine;
    affine[(3, 3)] = 1.0;
    let vol = unfold::mesh::Volume::new([12, 12, 6, 1], affine, vec![1.0f32; 864]).unwrap();
    unfold::io::write_image(&mask, &unfold::io::NiftiImage::new(vol)).unwrap();
    let o = unfold(&[
        "placenta",
        "--seg",
        &s(&mask),
        "-o",
        &s(&dir.path().join("out")),
        "--no-figures",
    ]);
    assert_one_line_error(&o, "every one of the segmentation's 864 voxels is set");
    assert!(!stderr(&o).contains("--margin-mm"), "{}", stderr(&o));
}
