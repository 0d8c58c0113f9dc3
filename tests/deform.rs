//! `unfold deform` through the binary: flattening a bowl-shaped shell onto
//! an 8 mm slab reaches the true minimum without inverting a tet; bad
//! targets files, surface meshes without a start, inverted input and
//! overwriting the input are one-line errors. The injective-mapping problem
//! (REST, a tangled INIT, exact HANDLES) on generated grids, planar, a
//! surface and tets, checked independently from OUT; an infeasible one
//! exits 3 with its outputs marked; its bad inputs are one-line errors.
//!
//! The acceptance problem ("top surface pulled to z = +4 mm, bottom to
//! -4 mm, rim free") is read as: every vertex of the top (inner, concave)
//! surface gets the target `(x, y, +4)` and every vertex of the bottom
//! (outer, convex) surface the target `(x, y, -4)`, `(x, y)` being the
//! vertex's own rest coordinates; rim vertices have no target. The bowl's
//! poles are at z = +4 (top) and z = -4 (bottom), so this flattens the 8 mm
//! thick bowl into an 8 mm slab by pressing it straight down.

use std::path::{Path, PathBuf};
use unfold::io::{WriteOptions, read_mesh, write_mesh};
use unfold::mesh::shapes::{ShellParams, ShellShape, bowl_shell};
use unfold::mesh::{CellMesh, Field, TetMesh};
use unfold::param::energy::SymmetricDirichlet;
use unfold::param::metrics::inverted_count;
use unfold::param::template::PointTargets;
use unfold::param::{Executor, Objective, ParamMesh, ProjectedNewton, Stopping, TemplateTerm};

mod common;
use common::*;

/// The flattening targets of the shell: top -> `(x, y, +4)`, bottom ->
/// `(x, y, -4)`.
fn flat_targets(shape: &ShellShape) -> Vec<(usize, [f64; 3])> {
    let p = &shape.mesh.positions;
    let side = |vs: &[u32], z: f64| -> Vec<(usize, [f64; 3])> {
        vs.iter()
            .map(|&v| (v as usize, [p[v as usize].x, p[v as usize].y, z]))
            .collect()
    };
    let mut t = side(&shape.top, 4.0);
    t.extend(side(&shape.bottom, -4.0));
    t
}

fn csv(targets: &[(usize, [f64; 3])]) -> String {
    let mut s = String::from("# flatten the bowl\nvertex,x,y,z\n");
    for (v, t) in targets {
        s += &format!("{v},{},{},{}\n", t[0], t[1], t[2]);
    }
    s
}

/// Writes `mesh` (with an extra cell array `region`) as `name` and the
/// targets as `targets.csv` in `dir`; returns both paths.
fn write_problem(
    dir: &Path,
    name: &str,
    mesh: &TetMesh,
    targets: &[(usize, [f64; 3])],
) -> (String, String) {
    let mut cells = CellMesh::from(mesh);
    cells
        .add_cell_field(Field::labels(
            "region",
            (0..mesh.num_tets()).map(|t| (t % 3) as i32).collect(),
        ))
        .unwrap();
    let m = dir.join(name);
    write_mesh(&m, &cells, &WriteOptions::default()).unwrap();
    let t = dir.join("targets.csv");
    std::fs::write(&t, csv(targets)).unwrap();
    (m.display().to_string(), t.display().to_string())
}

fn report(out: &str) -> serde_json::Value {
    let text = std::fs::read_to_string(format!("{out}.report.json")).expect("report written");
    serde_json::from_str(&text).expect("report is JSON")
}

fn small_shell() -> ShellShape {
    bowl_shell(&ShellParams {
        cells_radial: 4,
        cells_through: 1,
        ..ShellParams::default()
    })
    .unwrap()
}

#[test]
fn deform_flattens_the_7k_bowl_to_the_true_minimum() {
    let shape = bowl_shell(&ShellParams::default()).unwrap();
    assert_eq!(shape.mesh.num_tets(), 7056);
    let targets = flat_targets(&shape);
    let dir = tempfile::tempdir().unwrap();
    let (mesh, tfile) = write_problem(dir.path(), "bowl.vtu", &shape.mesh, &targets);
    let out = dir.path().join("flat.vtu").display().to_string();
    // `--tol` is the gradient-norm tolerance. At the default 1e-4 Newton
    // stops about 4e-8 (relative) above the minimum on this mesh (the
    // volume-normalized objective has small gradients); 1e-6 reaches it to
    // about 1e-11.
    let o = unfold(&[
        "deform",
        &mesh,
        "--targets",
        &tfile,
        "-o",
        &out,
        "--weight",
        "1000",
        "--tol",
        "1e-6",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let line = stdout(&o);
    assert_eq!(line.trim_end().lines().count(), 1, "{line}");
    assert!(
        line.contains("converged") && line.contains("0 inverted tets"),
        "{line}"
    );

    let r = report(&out);
    assert_eq!(r["converged"], true, "{r}");
    assert_eq!(r["end"]["inverted"], 0, "{r}");
    assert_eq!(r["end"]["folded"], 0, "{r}");
    assert_eq!(r["solver"], "newton");
    assert_eq!(r["energy"], "symmetric-dirichlet");
    assert_eq!(r["weight"], 1000.0);
    assert_eq!(r["targets"], targets.len());
    assert!(r["end"]["min_det_j"].as_f64().unwrap() > 0.0, "{r}");
    assert_eq!(r["injective"], true, "{r}");
    assert_eq!(r["tol"], 1e-6);
    assert!(r["grad_norm"].as_f64().unwrap() < 1e-6, "{r}");
    let iterations = r["iterations"].as_u64().unwrap();
    assert!((1..200).contains(&iterations), "{r}");
    for key in ["seconds", "distortion", "objective", "target_term"] {
        assert!(r[key].as_f64().is_some_and(f64::is_finite), "{key}: {r}");
    }
    let objective = r["objective"].as_f64().unwrap();
    let distortion = r["distortion"].as_f64().unwrap();
    assert!(distortion > 6.0, "{r}");
    // Pressed flat: every target met to well under a millimetre.
    assert!(r["target_error_max"].as_f64().unwrap() < 0.1, "{r}");

    // The true minimum: the same problem from the same start, solved with
    // the library to a much tighter tolerance.
    let rest = ParamMesh::from_tets(&shape.mesh).unwrap();
    let n = rest.num_vertices();
    let pt = PointTargets::from_pairs(n, 3, &targets).unwrap();
    let labels = vec![0u8; n];
    let mut weights = vec![0.0; n];
    for (v, _) in &targets {
        weights[*v] = 1000.0;
    }
    let term = TemplateTerm {
        template: &pt,
        labels: &labels,
        weights: &weights,
    };
    let mut obj = Objective::new(&rest, &SymmetricDirichlet, 1.0, Some(term), &[]).unwrap();
    let tight = Stopping {
        grad_tol: 1e-12,
        decrement_tol: 0.0,
        max_iterations: 500,
        ..Stopping::default()
    };
    let mut x = rest.rest_flat();
    let best = Executor::new(&ProjectedNewton::default())
        .stopping(tight)
        .run(&mut obj, &mut x, &mut [])
        .unwrap();
    assert_eq!(inverted_count(&rest, &x), 0);
    let f_min = obj.value(&x, &[]).min(best.value);
    let rel = (objective - f_min) / f_min.abs();
    assert!(
        rel.abs() < 1e-8,
        "objective {objective:.15e} vs true minimum {f_min:.15e}: relative {rel:e}"
    );

    // OUT: the input's cells and arrays, the deformed positions (the
    // report's objective is theirs).
    let input = read_mesh(&mesh).unwrap();
    let output = read_mesh(&out).unwrap();
    assert_eq!(output.num_points(), input.num_points());
    assert_eq!(output.num_cells(), input.num_cells());
    assert_eq!(output.point_data, input.point_data);
    // The input's cell arrays, and where the map is inverted.
    let mut cell_data = output.cell_data.clone();
    let inverted = cell_data.remove("inverted").unwrap();
    assert!(inverted.values().to_f64().iter().all(|&i| i == 0.0));
    let det_j = cell_data.remove("det_j").unwrap().values().to_f64();
    assert!(det_j.iter().all(|&d| d > 0.0), "{det_j:?}");
    assert_eq!(cell_data, input.cell_data);
    assert!(output.point_data.get("side").is_some());
    assert!(output.cell_data.get("region").is_some());
    let xo: Vec<f64> = output
        .positions
        .iter()
        .flat_map(|p| [p.x, p.y, p.z])
        .collect();
    assert_eq!(inverted_count(&rest, &xo), 0);
    let f_out = obj.value(&xo, &[]);
    assert!(
        (f_out - objective).abs() <= 1e-12 * objective,
        "{f_out} vs {objective}"
    );
    // Flat: every vertex off the (free) rim lies within the slab, up to the
    // soft penalty's slack; the rim may bulge.
    let side = output.point_data.get("side").unwrap();
    let zs = (0..output.num_points())
        .filter(|&v| side.get(v, 0) != Some(f64::from(ShellShape::RIM)))
        .map(|v| output.positions[v].z);
    let (lo, hi) = zs.fold((f64::MAX, f64::MIN), |(a, b), z| (a.min(z), b.max(z)));
    assert!(lo > -4.001 && hi < 4.001, "z range [{lo}, {hi}]");
}

#[test]
fn deform_arap_and_gradient_descent_on_a_small_bowl() {
    let shape = small_shell();
    let targets = flat_targets(&shape);
    let dir = tempfile::tempdir().unwrap();
    let (mesh, tfile) = write_problem(dir.path(), "bowl.vtk", &shape.mesh, &targets);
    let rest = ParamMesh::from_tets(&shape.mesh).unwrap();

    let out = dir.path().join("arap.mesh").display().to_string();
    let o = unfold(&[
        "deform",
        &mesh,
        "--targets",
        &tfile,
        "-o",
        &out,
        "--energy",
        "arap",
        "--tol",
        "1e-6",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = report(&out);
    assert_eq!(r["energy"], "arap");
    assert_eq!(r["weight"], 1.0);
    assert_eq!(r["converged"], true, "{r}");
    assert_eq!(r["end"]["inverted"], 0, "{r}");
    assert!(r["grad_norm"].as_f64().unwrap() < 1e-6, "{r}");
    let arap = read_mesh(&out).unwrap();
    assert_eq!(arap.num_cells(), shape.mesh.num_tets());

    // Gradient descent with an iteration limit: stops there, not converged,
    // still flip-free and better than the start; both files written.
    let out = dir.path().join("gd.vtu").display().to_string();
    let o = unfold(&[
        "deform",
        &mesh,
        "--targets",
        &tfile,
        "-o",
        &out,
        "--solver",
        "gd",
        "--max-iterations",
        "30",
    ]);
    // outputs written, exit code 3 and one line saying so
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("the deformation did not converge (max_iterations after 30"),
        "{}",
        stderr(&o)
    );
    assert!(
        stdout(&o).contains("NOT converged (max_iterations)"),
        "{}",
        stdout(&o)
    );
    let r = report(&out);
    assert_eq!(r["solver"], "gd");
    assert_eq!(r["iterations"], 30);
    assert_eq!(r["converged"], false);
    assert_eq!(r["stop_reason"], "max_iterations");
    assert_eq!(r["end"]["inverted"], 0, "{r}");
    let start: f64 = 6.0
        + targets
            .iter()
            .map(|(v, t)| (rest.rest[*v].z - t[2]).powi(2))
            .sum::<f64>();
    assert!(
        r["objective"].as_f64().unwrap() < start,
        "{r} vs start {start}"
    );
    let xo: Vec<f64> = read_mesh(&out)
        .unwrap()
        .positions
        .iter()
        .flat_map(|p| [p.x, p.y, p.z])
        .collect();
    assert_eq!(inverted_count(&rest, &xo), 0);
}

#[test]
fn deform_targets_file_errors_name_the_file_and_line() {
    let shape = small_shell();
    let n = shape.mesh.num_vertices();
    let dir = tempfile::tempdir().unwrap();
    let (mesh, _) = write_problem(dir.path(), "bowl.vtu", &shape.mesh, &flat_targets(&shape));
    let out = dir.path().join("out.vtu");
    let bad = dir.path().join("bad.csv");
    let b = bad.display().to_string();
    for (text, needle) in [
        (
            "vertex,x,y,z\n0,1,2,3\n1,1,two,3\n".to_string(),
            format!("{b}: line 3: bad y coordinate `two`"),
        ),
        (
            "0,1,2,3\nv7,1,2,3\n".to_string(),
            format!("{b}: line 2: bad vertex index `v7`"),
        ),
        (
            format!("# comment\n\n0,0,0,0\n{n},0,0,0\n"),
            format!("{b}: line 4: vertex {n} is out of range (the mesh has {n} vertices"),
        ),
        (
            "5,0,0,0\n6,0,0,0\n5,1,1,1\n".to_string(),
            format!("{b}: line 3: vertex 5 is listed twice (first on line 1)"),
        ),
        (
            "0,0,0,0\n1;0;0;0\n".to_string(),
            format!("{b}: line 2: expected 4 comma-separated fields `vertex,x,y,z`, found 1"),
        ),
        (
            "0,0,0,0,0\n".to_string(),
            format!("{b}: line 1: expected 4 comma-separated fields `vertex,x,y,z`, found 5"),
        ),
        (
            "# header only\nvertex,x,y,z\n\n".to_string(),
            format!("{b}: no targets"),
        ),
    ] {
        std::fs::write(&bad, &text).unwrap();
        let o = unfold(&[
            "deform",
            &mesh,
            "--targets",
            &b,
            "-o",
            &out.display().to_string(),
        ]);
        assert_one_line_error(&o, &needle);
        assert!(!out.exists(), "{text:?} wrote an output");
    }
    let missing = dir.path().join("missing.csv").display().to_string();
    let o = unfold(&[
        "deform",
        &mesh,
        "--targets",
        &missing,
        "-o",
        &out.display().to_string(),
    ]);
    assert_one_line_error(&o, &missing);
}

#[test]
fn deform_needs_a_positive_tet_mesh() {
    let shape = small_shell();
    let targets = flat_targets(&shape);
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n).display().to_string();
    let (_, tfile) = write_problem(dir.path(), "bowl.vtu", &shape.mesh, &targets);

    // A surface mesh: the shell's boundary triangles.
    let surface = unfold::mesh::topology::tet_boundary(&shape.mesh)
        .unwrap()
        .surface;
    let surf = d("surface.vtk");
    write_mesh(&surf, &CellMesh::from(&surface), &WriteOptions::default()).unwrap();
    assert_one_line_error(
        &unfold(&["deform", &surf, "--targets", &tfile, "-o", &d("o.vtu")]),
        &format!("{surf}: a triangle mesh is mapped to the plane: give its start with --init"),
    );

    // A negatively oriented tet.
    let mut inverted = shape.mesh.clone();
    inverted.tets[7].swap(0, 1);
    let inv = d("inverted.vtu");
    write_mesh(&inv, &CellMesh::from(&inverted), &WriteOptions::default()).unwrap();
    assert_one_line_error(
        &unfold(&["deform", &inv, "--targets", &tfile, "-o", &d("o.vtu")]),
        &format!("{inv}: tet 7 is inverted"),
    );
    assert!(!dir.path().join("o.vtu").exists());
}

#[test]
fn deform_refuses_to_overwrite_its_inputs_and_bad_options() {
    let shape = small_shell();
    let dir = tempfile::tempdir().unwrap();
    let (mesh, tfile) = write_problem(dir.path(), "bowl.vtu", &shape.mesh, &flat_targets(&shape));
    let before = std::fs::read(&mesh).unwrap();
    let run = |out: &str, extra: &[&str]| {
        let mut args = vec!["deform", &mesh, "--targets", &tfile, "-o", out];
        args.extend_from_slice(extra);
        unfold(&args)
    };
    assert_one_line_error(&run(&mesh, &[]), "refusing to overwrite");
    assert_eq!(std::fs::read(&mesh).unwrap(), before);
    // The same file through another spelling of its path.
    let other = format!("{}/./bowl.vtu", dir.path().display());
    assert_one_line_error(&run(&other, &[]), "refusing to overwrite");
    assert_eq!(std::fs::read(&mesh).unwrap(), before);

    let out = dir.path().join("o.vtu").display().to_string();
    assert_one_line_error(&run(&out, &["--weight", "0"]), "--weight");
    assert_one_line_error(&run(&out, &["--weight", "nan"]), "--weight");
    assert_one_line_error(&run(&out, &["--tol=-1"]), "--tol");
    let vtp = dir.path().join("o.vtp").display().to_string();
    assert_one_line_error(&run(&vtp, &[]), "cannot hold a tet mesh");
    // every energy of the registry is a choice; anything else is refused
    // naming them
    let o = run(&out, &["--energy", "dirichlet"]);
    assert_one_line_error(&o, "symmetric-dirichlet, mips, arap, area-ratio");
    assert!(!PathBuf::from(&out).exists());
}

#[test]
fn deform_moves_a_targeted_loose_vertex_and_keeps_an_untargeted_one() {
    let shape = small_shell();
    let n = shape.mesh.num_vertices();
    let mut mesh = shape.mesh.clone();
    mesh.point_data = Default::default();
    mesh.positions
        .push(unfold::mesh::nalgebra::Point3::new(100.0, 0.0, 0.0));
    mesh.positions
        .push(unfold::mesh::nalgebra::Point3::new(0.0, 100.0, 0.0));
    let mut targets = flat_targets(&shape);
    targets.push((n, [110.0, 1.0, 2.0]));
    let dir = tempfile::tempdir().unwrap();
    let (m, tfile) = write_problem(dir.path(), "loose.vtu", &mesh, &targets);
    let out = dir.path().join("out.vtu").display().to_string();
    let o = unfold(&["deform", &m, "--targets", &tfile, "-o", &out]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = report(&out);
    assert_eq!(r["converged"], true, "{r}");
    assert_eq!(r["end"]["inverted"], 0, "{r}");
    let p = read_mesh(&out).unwrap().positions;
    assert_eq!(p.len(), n + 2);
    assert!((p[n] - unfold::mesh::nalgebra::Point3::new(110.0, 1.0, 2.0)).norm() < 1e-6);
    assert_eq!(p[n + 1], mesh.positions[n + 1]);
}

#[test]
fn a_tet_soup_deforms_like_the_clean_mesh_in_the_input_numbering() {
    let shape = small_shell();
    let clean = &shape.mesh;
    // Every tet with its own four vertices, renumbered in first-use order
    // so that the welded soup solves the same system as the clean mesh.
    let (positions, tets, number) = first_use_order(&clean.positions, &clean.tets);
    let ordered = TetMesh::new(positions, tets);
    let targets: Vec<(usize, [f64; 3])> = flat_targets(&shape)
        .into_iter()
        .map(|(v, t)| (number[v] as usize, t))
        .collect();
    let mut soup = TetMesh::default();
    let mut copy_of = vec![usize::MAX; ordered.num_vertices()];
    for t in &ordered.tets {
        let base = soup.positions.len() as u32;
        for (k, &v) in t.iter().enumerate() {
            soup.positions.push(ordered.positions[v as usize]);
            if copy_of[v as usize] == usize::MAX {
                copy_of[v as usize] = base as usize + k;
            }
        }
        soup.tets.push([base, base + 1, base + 2, base + 3]);
    }
    let soup_targets: Vec<(usize, [f64; 3])> =
        targets.iter().map(|&(v, t)| (copy_of[v], t)).collect();
    let (dc, ds) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let (mc, tc) = write_problem(dc.path(), "clean.vtu", &ordered, &targets);
    let (ms, ts) = write_problem(ds.path(), "soup.vtu", &soup, &soup_targets);
    let (oc, os) = (
        dc.path().join("out.vtu").display().to_string(),
        ds.path().join("out.vtu").display().to_string(),
    );
    assert_ok(&unfold(&["deform", &mc, "--targets", &tc, "-o", &oc]));
    assert_ok(&unfold(&["deform", &ms, "--targets", &ts, "-o", &os]));
    let r = report(&os);
    assert_eq!(
        r["repair"]["welded_vertices"],
        soup.num_vertices() - ordered.num_vertices(),
        "{}",
        r["repair"]
    );
    assert_eq!(report(&oc)["repair"]["welded_vertices"], 0);
    // OUT keeps the soup's numbering: every copy at its vertex's place.
    let (a, b) = (read_mesh(&oc).unwrap(), read_mesh(&os).unwrap());
    assert_eq!(b.positions.len(), soup.num_vertices());
    let mut worst: f64 = 0.0;
    for (t, tet) in ordered.tets.iter().enumerate() {
        for (k, &v) in tet.iter().enumerate() {
            let (p, q) = (a.positions[v as usize], b.positions[4 * t + k]);
            worst = worst.max((p - q).norm());
        }
    }
    assert!(worst < 1e-9, "the soup moved {worst} mm differently");
}

// ---------------------------------------------------------------------------
// The injective-mapping problem: a rest mesh, a tangled start and handles
// that must stay exactly where they are. Each problem is feasible by
// construction: a smooth bijective warp `phi` (a perturbation of the
// identity with `|D phi - I| < 1`, so injective) maps the rest grid to a
// valid map; the boundary starts at the warp, the interior at the warp plus
// a fixed pseudo-random offset that inverts elements.

use std::f64::consts::PI;
use unfold::mesh::TriMesh;
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::shapes::{grid_disk, kuhn_grid};

/// Deterministic numbers in `[-1, 1)` (xorshift64*), so every run solves the
/// same problem.
struct Scramble(u64);

impl Scramble {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let r = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d);
        (r >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// The planar warp of the `n x n` grid: `(x + a sin(pi y/n), y + a sin(pi
/// x/n))`, `a = 0.08 n`; `det D phi >= 1 - (0.08 pi)^2 > 0`.
fn warp2(p: &Point3<f64>, n: f64) -> Point3<f64> {
    let a = 0.08 * n;
    Point3::new(
        p.x + a * (PI * p.y / n).sin(),
        p.y + a * (PI * p.x / n).sin(),
        0.0,
    )
}

/// The warp of the `n^3` grid: each coordinate shifted by `a sin` of the
/// next one, `a = 0.08 n`.
fn warp3(p: &Point3<f64>, n: f64) -> Point3<f64> {
    let a = 0.08 * n;
    Point3::new(
        p.x + a * (PI * p.y / n).sin(),
        p.y + a * (PI * p.z / n).sin(),
        p.z + a * (PI * p.x / n).sin(),
    )
}

/// Boundary vertices of a grid with corners `0` and `n` in every
/// coordinate.
fn on_grid_boundary(p: &Point3<f64>, n: f64, dims: usize) -> bool {
    [p.x, p.y, p.z][..dims].iter().any(|&c| c == 0.0 || c == n)
}

/// A tangled start of `rest` (positions of a grid with side `n`): the warp
/// on the boundary, warp plus an offset of up to `amplitude` inside.
fn tangled_start(
    rest: &[Point3<f64>],
    n: f64,
    dims: usize,
    amplitude: f64,
    warp: fn(&Point3<f64>, f64) -> Point3<f64>,
) -> Vec<Point3<f64>> {
    let mut r = Scramble(0x9e37_79b9_7f4a_7c15);
    rest.iter()
        .map(|p| {
            let w = warp(p, n);
            if on_grid_boundary(p, n, dims) {
                w
            } else {
                let d = [r.next(), r.next(), r.next()];
                Point3::new(
                    w.x + amplitude * d[0],
                    w.y + amplitude * d[1],
                    if dims == 3 {
                        w.z + amplitude * d[2]
                    } else {
                        0.0
                    },
                )
            }
        })
        .collect()
}

/// Signed area (2D, in the plane) of every triangle of `cells`.
fn signed_areas(cells: &CellMesh) -> Vec<f64> {
    cells
        .cells()
        .map(|(_, v)| {
            let p = |k: usize| cells.positions[v[k] as usize];
            let (a, b, c) = (p(0), p(1), p(2));
            ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)) / 2.0
        })
        .collect()
}

/// Signed volume of every tet of `cells`.
fn signed_volumes(cells: &CellMesh) -> Vec<f64> {
    cells
        .cells()
        .map(|(_, v)| {
            let p = |k: usize| cells.positions[v[k] as usize];
            (p(1) - p(0)).cross(&(p(2) - p(0))).dot(&(p(3) - p(0))) / 6.0
        })
        .collect()
}

/// A benchmark-format problem written to `dir`: REST, INIT and HANDLES.
struct Problem {
    rest: String,
    init: String,
    handles: String,
    /// INIT's positions.
    start: Vec<Point3<f64>>,
    /// The handle vertices.
    fixed: Vec<usize>,
}

fn write_cells(path: &Path, cells: &CellMesh) -> String {
    write_mesh(path, cells, &WriteOptions::default()).unwrap();
    path.display().to_string()
}

/// Writes REST (`rest` with `rest_positions`), INIT (the same cells at
/// `start`) and HANDLES (`fixed`, with a comment and a blank line) to `dir`
/// as `rest.EXT`, `init.EXT` and `handles.txt`.
fn write_benchmark(
    dir: &Path,
    ext: &str,
    rest: &CellMesh,
    start: Vec<Point3<f64>>,
    fixed: Vec<usize>,
) -> Problem {
    let rest_file = write_cells(&dir.join(format!("rest.{ext}")), rest);
    let mut init = rest.clone();
    init.positions = start.clone();
    let init_file = write_cells(&dir.join(format!("init.{ext}")), &init);
    let mut text = String::from("# handle vertices, 0-based\n\n");
    for v in &fixed {
        text += &format!("{v}\n");
    }
    let handles = dir.join("handles.txt");
    std::fs::write(&handles, text).unwrap();
    Problem {
        rest: rest_file,
        init: init_file,
        handles: handles.display().to_string(),
        start,
        fixed,
    }
}

/// The boundary vertices of a grid mesh, and three interior ones (the
/// caller puts them at the warp).
fn grid_handles(positions: &[Point3<f64>], n: f64, dims: usize) -> Vec<usize> {
    let mut h: Vec<usize> = (0..positions.len())
        .filter(|&v| on_grid_boundary(&positions[v], n, dims))
        .collect();
    let interior: Vec<usize> = (0..positions.len())
        .filter(|&v| !on_grid_boundary(&positions[v], n, dims))
        .collect();
    h.extend([
        interior[0],
        interior[interior.len() / 2],
        interior[interior.len() - 1],
    ]);
    h
}

/// The planar problem: a 12 x 12 grid (288 triangles), the warp's boundary
/// and three interior handles, the interior scrambled.
fn planar_problem(dir: &Path, ext: &str, lift: bool) -> Problem {
    let n = 12.0;
    let mut disk: TriMesh = grid_disk(12, 12);
    let mut start = tangled_start(&disk.positions, n, 2, 1.2, warp2);
    let fixed = grid_handles(&disk.positions, n, 2);
    for &v in &fixed {
        start[v] = warp2(&disk.positions[v], n);
    }
    if lift {
        for p in &mut disk.positions {
            p.z = 0.3 * p.x.sin() * p.y.cos();
        }
    }
    write_benchmark(dir, ext, &CellMesh::from(&disk), start, fixed)
}

/// The tet problem: a 4^3 Kuhn grid (384 tets), the warp's boundary and
/// three interior handles, the interior scrambled.
fn tet_problem(dir: &Path) -> Problem {
    let n = 4.0;
    let grid = kuhn_grid([4, 4, 4], [1.0; 3]);
    let mut start = tangled_start(&grid.positions, n, 3, 0.9, warp3);
    let fixed = grid_handles(&grid.positions, n, 3);
    for &v in &fixed {
        start[v] = warp3(&grid.positions[v], n);
    }
    write_benchmark(dir, "vtu", &CellMesh::from(&grid), start, fixed)
}

/// Runs `unfold deform REST --init INIT --fixed HANDLES -o OUT` and checks
/// the result independently: OUT read back, every element positively
/// oriented (signed contents computed here), every handle bit for bit at
/// INIT's position, the report's flips at the start and the end.
fn solve_and_check(p: &Problem, out: &str, tets: bool) -> serde_json::Value {
    let o = unfold(&[
        "deform", &p.rest, "--init", &p.init, "--fixed", &p.handles, "-o", out,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let line = stdout(&o);
    assert_eq!(line.trim_end().lines().count(), 1, "{line}");
    let elements = if tets { "tets" } else { "triangles" };
    assert!(
        line.contains(&format!("-> 0 inverted {elements}, untangled in"))
            && line.contains(&format!("{} fixed", p.fixed.len()))
            && line.ends_with("; injective\n"),
        "{line}"
    );
    let r = report(out);
    assert_eq!(r["injective"], true, "{r}");
    assert_eq!(r["elements"], elements, "{r}");
    assert!(r["start"]["inverted"].as_u64().unwrap() > 0, "{r}");
    assert_eq!(r["end"]["inverted"], 0, "{r}");
    assert_eq!(r["end"]["folded"], 0, "{r}");
    assert_eq!(r["untangle"]["untangled"], true, "{r}");
    assert_eq!(r["fixed"], p.fixed.len(), "{r}");
    assert_eq!(r["fixed_error_max"], 0.0, "{r}");
    assert_eq!(r["init"], p.init.as_str(), "{r}");
    assert_eq!(r["fixed_file"], p.handles.as_str(), "{r}");
    assert_eq!(r["targets_file"], serde_json::Value::Null, "{r}");
    assert_eq!(r["repair"], serde_json::Value::Null, "{r}");

    let m = read_mesh(out).unwrap();
    let contents = if tets {
        signed_volumes(&m)
    } else {
        assert!(m.positions.iter().all(|p| p.z == 0.0));
        signed_areas(&m)
    };
    let worst = contents.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(worst > 0.0, "smallest signed content {worst}");
    for &v in &p.fixed {
        assert_eq!(m.positions[v], p.start[v], "handle {v} moved");
    }
    let inverted = m.cell_data.get("inverted").expect("inverted array");
    let det_j = m.cell_data.get("det_j").expect("det_j array");
    for c in 0..m.num_cells() {
        assert_eq!(inverted.get(c, 0), Some(0.0), "cell {c}");
        assert!(det_j.get(c, 0).unwrap() > 0.0, "cell {c}");
    }
    r
}

#[test]
fn deform_untangles_a_planar_triangle_map_with_exact_handles() {
    let dir = tempfile::tempdir().unwrap();
    let p = planar_problem(dir.path(), "obj", false);
    let out = dir.path().join("out.vtu").display().to_string();
    let r = solve_and_check(&p, &out, false);
    assert_eq!(r["mirrored"], false, "{r}");

    // --fixed-boundary is the same as listing the boundary in HANDLES.
    let interior: Vec<usize> = p.fixed[p.fixed.len() - 3..].to_vec();
    let only = dir.path().join("interior.txt");
    std::fs::write(
        &only,
        interior
            .iter()
            .map(|v| format!("{v}\n"))
            .collect::<String>(),
    )
    .unwrap();
    let out2 = dir.path().join("out2.vtu").display().to_string();
    let o = unfold(&[
        "deform",
        &p.rest,
        "--init",
        &p.init,
        "--fixed",
        &only.display().to_string(),
        "--fixed-boundary",
        "-o",
        &out2,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(report(&out2)["fixed"], p.fixed.len());
    let (a, b) = (read_mesh(&out).unwrap(), read_mesh(&out2).unwrap());
    assert_eq!(a.positions, b.positions);
}

#[test]
fn deform_maps_a_surface_to_the_plane_from_a_tangled_start() {
    let dir = tempfile::tempdir().unwrap();
    let p = planar_problem(dir.path(), "ply", true);
    let out = dir.path().join("out.vtk").display().to_string();
    solve_and_check(&p, &out, false);
}

#[test]
fn deform_untangles_a_tet_map_with_exact_handles() {
    let dir = tempfile::tempdir().unwrap();
    let p = tet_problem(dir.path());
    let out = dir.path().join("out.vtu").display().to_string();
    solve_and_check(&p, &out, true);

    // Without INIT the handles are fixed at REST (which is repaired, its
    // vertex numbers kept) while a soft target pulls an interior vertex.
    let rest = read_mesh(&p.rest).unwrap();
    let free = (0..rest.num_points())
        .find(|v| !p.fixed.contains(v))
        .unwrap();
    let q = rest.positions[free];
    let tfile = dir.path().join("t.csv");
    std::fs::write(&tfile, format!("{free},{},{},{}\n", q.x + 0.3, q.y, q.z)).unwrap();
    let out2 = dir.path().join("pulled.vtu").display().to_string();
    let o = unfold(&[
        "deform",
        &p.rest,
        "--fixed",
        &p.handles,
        "--targets",
        &tfile.display().to_string(),
        "-o",
        &out2,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = report(&out2);
    assert_eq!(
        (r["injective"].clone(), r["fixed"].clone()),
        (true.into(), p.fixed.len().into())
    );
    assert_eq!(r["repair"]["welded_vertices"], 0, "{r}");
    assert_eq!(r["init"], serde_json::Value::Null, "{r}");
    let m = read_mesh(&out2).unwrap();
    for &v in &p.fixed {
        assert_eq!(m.positions[v], rest.positions[v], "handle {v} moved");
    }
    assert!(
        m.positions[free].x > q.x + 0.05,
        "{} vs {}",
        m.positions[free].x,
        q.x
    );
    assert!(signed_volumes(&m).iter().all(|&v| v > 0.0));
}

#[test]
fn deform_without_an_injective_map_exits_3_with_the_outputs_marked() {
    let dir = tempfile::tempdir().unwrap();
    let n = 6.0;
    let disk = grid_disk(6, 6);
    let mut start = tangled_start(&disk.positions, n, 2, 0.0, warp2);
    // An interior triangle with its three handles given clockwise: c
    // mirrored across the line ab.
    let t = 2 * (6 * 2 + 2);
    let [a, b, c] = disk.triangles[t].map(|v| v as usize);
    let (pa, pb, pc) = (start[a], start[b], start[c]);
    let ab = (pb - pa).normalize();
    let foot = pa + ab * (pc - pa).dot(&ab);
    start[c] = foot + (foot - pc);
    let mut fixed: Vec<usize> = (0..disk.positions.len())
        .filter(|&v| on_grid_boundary(&disk.positions[v], n, 2))
        .collect();
    fixed.extend([a, b, c]);
    let p = write_benchmark(dir.path(), "vtu", &CellMesh::from(&disk), start, fixed);
    let out = dir.path().join("out.vtu").display().to_string();
    let o = unfold(&[
        "deform", &p.rest, "--init", &p.init, "--fixed", &p.handles, "-o", &out,
    ]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let err = stderr(&o);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains("no injective map found: ")
            && err.contains(" still inverted")
            && err.contains("(smallest det J -")
            && err.contains(&format!("{out} and its report are marked injective: false"))
            && err.contains("fewer fixed vertices"),
        "{err}"
    );
    assert!(stdout(&o).contains("NOT injective"), "{}", stdout(&o));
    let r = report(&out);
    assert_eq!(r["injective"], false, "{r}");
    assert!(r["end"]["inverted"].as_u64().unwrap() >= 1, "{r}");
    let m = read_mesh(&out).unwrap();
    let inverted = m.cell_data.get("inverted").unwrap();
    assert_eq!(inverted.get(t, 0), Some(1.0));
    assert!(m.cell_data.get("det_j").unwrap().get(t, 0).unwrap() < 0.0);
    for &v in &p.fixed {
        assert_eq!(m.positions[v], p.start[v], "handle {v} moved");
    }
}

#[test]
fn deform_benchmark_inputs_errors_are_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = |name: &str| dir.path().join(name).display().to_string();
    let p = planar_problem(dir.path(), "vtu", false);
    let rest = read_mesh(&p.rest).unwrap();
    let nv = rest.num_points();
    let out = d("out.vtu");
    let run = |extra: &[&str]| {
        let mut args = vec!["deform", &p.rest];
        args.extend_from_slice(extra);
        unfold(&args)
    };

    // INIT with another vertex count, another cell, off the plane.
    let mut more = rest.clone();
    more.positions.push(Point3::new(1.0, 1.0, 0.0));
    let more_file = write_cells(&dir.path().join("more.vtu"), &more);
    assert_one_line_error(
        &run(&["--init", &more_file, "--fixed-boundary", "-o", &out]),
        &format!("{more_file}: has {} vertices, REST has {nv}", nv + 1),
    );
    let mut other = rest.clone();
    other.connectivity.swap(15, 16);
    let other_file = write_cells(&dir.path().join("other.vtu"), &other);
    assert_one_line_error(
        &run(&["--init", &other_file, "--fixed-boundary", "-o", &out]),
        &format!("{other_file}: cell 5 is Triangle"),
    );
    let mut lifted = rest.clone();
    lifted.positions[7].z = 0.25;
    let lifted_file = write_cells(&dir.path().join("lifted.vtu"), &lifted);
    assert_one_line_error(
        &run(&["--init", &lifted_file, "--fixed-boundary", "-o", &out]),
        &format!("{lifted_file}: vertex 7 has z = 2.5e-1; a triangle mesh is mapped to the plane"),
    );

    // HANDLES: not an integer, out of range, repeated (file and line).
    let h = d("h.txt");
    for (text, needle) in [
        (
            "0\nabc\n".to_string(),
            format!("{h}: line 2: `abc` is not a vertex index"),
        ),
        (
            format!("{nv}\n"),
            format!("{h}: line 1: vertex {nv} is out of range (the mesh has {nv} vertices"),
        ),
        (
            "4\n# again\n4\n".to_string(),
            format!("{h}: line 3: vertex 4 is listed twice (first on line 1)"),
        ),
    ] {
        std::fs::write(&h, text).unwrap();
        assert_one_line_error(
            &run(&["--init", &p.init, "--fixed", &h, "-o", &out]),
            &needle,
        );
    }

    // A degenerate rest triangle (vertex 14 on vertex 13): named at REST.
    let mut flat = rest.clone();
    flat.positions[14] = flat.positions[13];
    let flat_file = write_cells(&dir.path().join("flat.vtu"), &flat);
    assert_one_line_error(
        &unfold(&[
            "deform",
            &flat_file,
            "--init",
            &p.init,
            "--fixed-boundary",
            "-o",
            &out,
        ]),
        &format!("{flat_file}: element 1 is degenerate (rest area or volume 0e0); REST is"),
    );

    // Nothing to do; a triangle REST without a start.
    assert_one_line_error(
        &run(&["-o", &out]),
        "nothing to do: give --targets FILE, --init INIT",
    );
    assert_one_line_error(
        &run(&["--fixed-boundary", "-o", &out]),
        &format!(
            "{}: a triangle mesh is mapped to the plane: give its start with --init",
            p.rest
        ),
    );
    // An OUT that cannot hold the cells (or the exact handles).
    let grid = CellMesh::from(&kuhn_grid([1, 1, 1], [1.0; 3]));
    let tets = write_cells(&dir.path().join("tets.vtu"), &grid);
    let obj = d("out.obj");
    assert_one_line_error(
        &unfold(&["deform", &tets, "--fixed-boundary", "-o", &obj]),
        &format!("{obj}: cannot hold a tet mesh; write .vtu, .vtk or .mesh"),
    );
    let stl = d("out.stl");
    assert_one_line_error(
        &run(&["--init", &p.init, "--fixed-boundary", "-o", &stl]),
        &format!("{stl}: stores single-precision positions"),
    );
    assert!(!PathBuf::from(&out).exists() && !PathBuf::from(&obj).exists());
}

/// The TLC-PN example of the Locally Injective Mappings benchmark
/// (`tests/data/tlc`, MIT; a 3D disk of 2,000 triangles mapped to the
/// plane, 42 of them inverted in its start, its 46 boundary vertices the
/// handles): untangled with every handle exact, from the problem file and
/// from the same problem split into REST, INIT and HANDLES, bit for bit
/// the same. The distortion solve is left out (`--max-iterations 0`, so
/// exit 3 with `converged: false`): it takes 359 Newton iterations, too
/// long for an unoptimized test build; the untangled map is what is
/// checked here.
#[test]
fn deform_untangles_the_public_benchmark_example_with_its_handles_exact() {
    use unfold::io::tlc::read_injectivity_problem;
    use unfold::mesh::CellType;
    let file = "tests/data/tlc/tlc-pn-example.input";
    let problem = read_injectivity_problem(Path::new(file)).unwrap();
    let unfold::io::tlc::Cells::Triangles(tris) = &problem.cells else {
        panic!("the example maps triangles");
    };
    let dir = tempfile::tempdir().unwrap();
    let at = |name: &str| dir.path().join(name).display().to_string();
    let mut rest = CellMesh::from_points(problem.rest.iter().map(|p| Point3::from(*p)).collect());
    for t in tris {
        rest.push_cell(CellType::Triangle, t);
    }
    let rest_file = write_cells(Path::new(&at("rest.vtu")), &rest);
    let mut init = rest.clone();
    init.positions = problem
        .init
        .iter()
        .map(|p| Point3::new(p[0], p[1], 0.0))
        .collect();
    let init_file = write_cells(Path::new(&at("init.vtu")), &init);
    let handles: String = problem.handles.iter().map(|h| format!("{h}\n")).collect();
    std::fs::write(at("handles.txt"), handles).unwrap();

    let (a, b, c, h) = (at("a.vtu"), at("b.vtu"), at("c.vtu"), at("handles.txt"));
    let runs = [
        vec!["deform", file, "-o", &a, "--max-iterations", "0"],
        vec![
            "deform",
            &rest_file,
            "--init",
            &init_file,
            "--fixed",
            &h,
            "-o",
            &b,
            "--max-iterations",
            "0",
        ],
    ];
    let mut results = Vec::new();
    for (args, out) in runs.iter().zip([&a, &b]) {
        let o = unfold(args);
        assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
        assert!(stderr(&o).contains("did not converge"), "{}", stderr(&o));
        let r = report(out);
        assert_eq!(r["injective"], true, "{r}");
        assert_eq!(r["start"]["inverted"], 42, "{r}");
        assert_eq!(r["end"]["inverted"], 0, "{r}");
        assert_eq!(r["fixed"], 46, "{r}");
        assert_eq!(r["fixed_error_max"], 0.0, "{r}");
        let m = read_mesh(out).unwrap();
        let worst = signed_areas(&m).into_iter().fold(f64::INFINITY, f64::min);
        assert!(worst > 0.0, "smallest signed area {worst}");
        for &h in &problem.handles {
            let (p, q) = (m.positions[h as usize], problem.init[h as usize]);
            assert_eq!([p.x, p.y], [q[0], q[1]], "handle {h} moved");
        }
        results.push(m.positions);
    }
    assert_eq!(results[0], results[1]);
    // A problem file holds its own start.
    let o = unfold(&["deform", file, "--init", &init_file, "-o", &c]);
    assert_one_line_error(&o, "holds its own start; drop --init");
}
