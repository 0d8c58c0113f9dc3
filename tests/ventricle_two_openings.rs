//! `unfold ventricle` on an LV with two openings, built from
//! scratch: the built-in cup, whose basal rim is the mitral ring, with a
//! smaller "aortic" opening cut into its wall just below the base, off to
//! one side. The RV insertion points sit outside the wall beside the aortic
//! opening, where the old derivation took the aortic ring for the base.

use std::path::{Path, PathBuf};
use std::process::Output;
use unfold::io::{WriteOptions, write_mesh};
use unfold::mesh::nalgebra::{Point3, Vector3};
use unfold::mesh::shapes::{VentricleParams, VentricleShape, ventricle_cup};
use unfold::mesh::topology::boundary_loops;
use unfold::mesh::{CellMesh, TriMesh};

mod common;
use common::*;

/// Azimuth of the aortic opening, radians (the anterior landmark of the cup
/// sits at +55 degrees, the inferior at -55).
const AORTIC_AZ: f64 = 2.4;
/// Height of the aortic opening's centre below the base, mm.
const AORTIC_Z: f64 = -12.0;
/// Radius of the aortic opening, mm (triangles with a vertex within it
/// are removed).
const AORTIC_MM: f64 = 6.0;

fn cup() -> VentricleShape {
    ventricle_cup(&VentricleParams::default()).unwrap()
}

/// The vertex of `s` nearest the wall point at azimuth `az` and height `z`.
fn wall(s: &TriMesh, az: f64, z: f64) -> Point3<f64> {
    let p = Point3::new(25.0 * az.cos(), 25.0 * az.sin(), z);
    *s.positions
        .iter()
        .min_by(|a, b| (*a - p).norm().total_cmp(&(*b - p).norm()))
        .unwrap()
}

/// The LV: the cup without the triangles near the aortic opening's centre.
fn two_openings(v: &VentricleShape) -> TriMesh {
    let c = wall(&v.surface, AORTIC_AZ, AORTIC_Z);
    let s = &v.surface;
    TriMesh::new(
        s.positions.clone(),
        s.triangles
            .iter()
            .filter(|t| {
                !t.iter()
                    .any(|&w| (s.positions[w as usize] - c).norm() < AORTIC_MM)
            })
            .copied()
            .collect(),
    )
}

/// The two RV insertion points: outside the wall, 9 mm below the base, on
/// either side of the aortic opening (their midpoint is nearer the aortic
/// ring than the mitral one).
fn rv_points() -> [Point3<f64>; 2] {
    [AORTIC_AZ - 0.45, AORTIC_AZ + 0.45].map(|a| Point3::new(30.0 * a.cos(), 30.0 * a.sin(), -9.0))
}

/// Length-weighted centroid of a loop.
fn centroid(s: &TriMesh, l: &[u32]) -> Point3<f64> {
    let m = l.len();
    let (mut sum, mut len) = (Vector3::zeros(), 0.0);
    for k in 0..m {
        let (a, b) = (
            s.positions[l[k] as usize],
            s.positions[l[(k + 1) % m] as usize],
        );
        let e = (b - a).norm();
        sum += (a.coords + b.coords) * (0.5 * e);
        len += e;
    }
    Point3::from(sum / len)
}

struct Case {
    dir: tempfile::TempDir,
    v: VentricleShape,
    surface: TriMesh,
    anatomy: PathBuf,
    lv: PathBuf,
    mitral: Vec<u32>,
    aortic: Vec<u32>,
}

fn case() -> Case {
    let dir = tempfile::tempdir().unwrap();
    let v = cup();
    let surface = two_openings(&v);
    let loops = boundary_loops(&surface).unwrap();
    assert_eq!(loops.len(), 2);
    let (mitral, aortic) = (loops[0].clone(), loops[1].clone());
    assert_eq!(mitral.len(), v.rim.len());
    let anatomy = dir.path().join("anatomy.vtp");
    let lv = dir.path().join("lv.vtp");
    let w = |p: &Path, m: CellMesh| write_mesh(p, &m, &WriteOptions::default()).unwrap();
    w(&anatomy, CellMesh::from(&v.anatomy));
    w(&lv, CellMesh::from(&surface));
    Case {
        dir,
        v,
        surface,
        anatomy,
        lv,
        mitral,
        aortic,
    }
}

impl Case {
    /// `unfold ventricle ANATOMY --surface LV --grid-mm 1.5 --no-figures -o
    /// DIR/name` plus `extra`.
    fn run(&self, name: &str, extra: &[String]) -> (Output, PathBuf) {
        let out = self.dir.path().join(name);
        let mut args = vec![
            "ventricle".to_string(),
            s(&self.anatomy),
            "--surface".into(),
            s(&self.lv),
            "--grid-mm".into(),
            "1.5".into(),
            "--no-figures".into(),
            "-o".into(),
            s(&out),
        ];
        args.extend(extra.iter().cloned());
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        (unfold(&refs), out)
    }

    /// `--rv-landmarks P Q --apex A`.
    fn rv_flags(&self) -> Vec<String> {
        let [p, q] = rv_points();
        vec![
            "--rv-landmarks".into(),
            pt(&p),
            pt(&q),
            "--apex".into(),
            pt(&self.v.apex),
        ]
    }

    fn on_loop(&self, l: &[u32], p: [f64; 3]) -> bool {
        l.iter()
            .any(|&w| (self.surface.positions[w as usize] - Point3::from(p)).norm() < 1e-9)
    }
}

fn report(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap()
}

fn f(x: &serde_json::Value) -> f64 {
    x.as_f64().unwrap()
}

fn point(x: &serde_json::Value) -> [f64; 3] {
    [f(&x[0]), f(&x[1]), f(&x[2])]
}

/// The gate `name` of a report: (value, passed).
fn gate(r: &serde_json::Value, name: &str) -> (f64, bool) {
    let g = r["gates"]
        .as_array()
        .unwrap()
        .iter()
        .find(|g| g["name"] == name)
        .unwrap_or_else(|| panic!("no gate {name}: {}", r["gates"]));
    (f(&g["value"]), g["passed"].as_bool().unwrap())
}

/// The case: `--rv-landmarks` beside the aortic opening and
/// `--apex`: the mitral ring is the base (the anatomy), the landmarks are
/// derived on it, the aortic opening is capped and the AHA segments are
/// balanced; rim landmarks on the aortic ring are refused naming
/// `--rim-near`.
#[test]
fn the_mitral_ring_is_the_base_and_the_landmarks_lie_on_it() {
    let c = case();
    let (o, out) = c.run("rv", &c.rv_flags());
    assert_ok(&o);
    let r = report(&out);
    let openings = &r["openings"];
    let rim = &openings["loops"][openings["rim"].as_u64().unwrap() as usize];
    assert_eq!(rim["vertices"], c.mitral.len());
    assert_eq!(r["inputs"]["rv_landmarks"]["rim_chosen_by"], "anatomy");
    assert_eq!(openings["chosen_by"], "landmarks");
    for l in r["inputs"]["rv_landmarks"]["landmarks"].as_array().unwrap() {
        assert!(
            c.on_loop(&c.mitral, point(l)),
            "{l} is not on the mitral ring"
        );
    }
    let aortic = openings["loops"]
        .as_array()
        .unwrap()
        .iter()
        .find(|l| l["rim"] == false)
        .unwrap();
    assert_eq!(aortic["vertices"], c.aortic.len());
    assert_eq!(aortic["cap_triangles"], c.aortic.len());
    assert!(f(&rim["perimeter_mm"]) > 2.0 * f(&aortic["perimeter_mm"]));
    let (agrees, ok) = gate(&r, "base.rim_agrees");
    assert!(ok && agrees == 1.0, "{agrees}");
    let (balance, ok) = gate(&r, "aha.balance");
    eprintln!(
        "mitral base: aha.balance {balance:.3}, aha points {}",
        r["aha_points"]
    );
    assert!(ok && balance > 0.9, "{balance}");
    let counts: Vec<u64> = r["aha_points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect();
    assert!(counts[..16].iter().all(|&n| n > 0), "{counts:?}");

    // rim landmarks on the aortic ring, with the apex: refused, naming both
    // openings and the flag that picks one
    let a = c.surface.positions[c.aortic[0] as usize];
    let i = c.surface.positions[c.aortic[c.aortic.len() / 3] as usize];
    let args = [
        "--anterior".into(),
        pt(&a),
        "--inferior".into(),
        pt(&i),
        "--apex".into(),
        pt(&c.v.apex),
    ];
    let (o, out) = c.run("aortic_landmarks", &args);
    assert_one_line_error(&o, "the rim landmarks lie on opening 1");
    assert_one_line_error(&o, &format!("opening 0 ({} vertices", c.mitral.len()));
    assert_one_line_error(&o, "--rim-near X,Y,Z");
    assert!(!out.join("report.json").exists());
}

/// `--rim-near` at the mitral opening's centre and at a mitral ring vertex
/// both name the base; at the aortic opening's centre it names the aortic
/// ring: the RV points beside it cannot give landmarks there (refused), and
/// with rim landmarks on it the map is kept with the gates `base.rim_agrees`
/// and `aha.balance` failed and their fallbacks recorded.
#[test]
fn rim_near_names_an_opening_by_its_centre_or_its_ring() {
    let c = case();
    let mitral_centre = centroid(&c.surface, &c.mitral);
    // a mitral vertex away from the aortic side
    let far_vertex = *c
        .mitral
        .iter()
        .max_by(|&&a, &&b| {
            let d =
                |w: u32| (c.surface.positions[w as usize] - centroid(&c.surface, &c.aortic)).norm();
            d(a).total_cmp(&d(b))
        })
        .unwrap();
    for (name, near) in [
        ("centre", mitral_centre),
        ("vertex", c.surface.positions[far_vertex as usize]),
    ] {
        let mut args = c.rv_flags();
        args.extend(["--rim-near".into(), pt(&near)]);
        let (o, out) = c.run(name, &args);
        assert_ok(&o);
        let r = report(&out);
        assert_eq!(r["openings"]["chosen_by"], "rim-near", "{name}");
        assert_eq!(r["inputs"]["rv_landmarks"]["rim_chosen_by"], "rim-near");
        let rim = &r["openings"]["loops"][r["openings"]["rim"].as_u64().unwrap() as usize];
        assert_eq!(rim["vertices"], c.mitral.len(), "{name}");
        assert!(
            f(&rim["distance_mm"]) < 1e-6,
            "{name}: {}",
            rim["distance_mm"]
        );
        for l in r["inputs"]["rv_landmarks"]["landmarks"].as_array().unwrap() {
            assert!(c.on_loop(&c.mitral, point(l)), "{name}: {l}");
        }
        assert!(gate(&r, "aha.balance").1);
    }

    // the aortic opening's centre names the aortic ring: the rays from its
    // centre through the RV points (beside it) miss S, and the run says so
    let aortic_centre = centroid(&c.surface, &c.aortic);
    let mut args = c.rv_flags();
    args.extend(["--rim-near".into(), pt(&aortic_centre)]);
    let (o, out) = c.run("aortic_rv", &args);
    assert_one_line_error(&o, "through the anterior RV insertion point");
    assert_one_line_error(&o, "meets no triangle of S");
    assert!(!out.join("report.json").exists());
    // with rim landmarks on the aortic ring it is the base: the mitral
    // opening is capped and the map is kept, with both gates failed and
    // their fallbacks in the report (the anatomy's rim is the mitral ring;
    // the mid ring's segment areas spread tenfold)
    let mut args = vec![
        "--anterior".into(),
        pt(&c.surface.positions[c.aortic[0] as usize]),
        "--inferior".into(),
        pt(&c.surface.positions[c.aortic[c.aortic.len() / 3] as usize]),
        "--apex".into(),
        pt(&c.v.apex),
    ];
    args.extend(["--rim-near".into(), pt(&aortic_centre)]);
    let (o, out) = c.run("aortic", &args);
    assert_ok(&o);
    let r = report(&out);
    assert_eq!(r["openings"]["chosen_by"], "rim-near");
    let rim = &r["openings"]["loops"][r["openings"]["rim"].as_u64().unwrap() as usize];
    assert_eq!(rim["vertices"], c.aortic.len());
    let (agrees, ok) = gate(&r, "base.rim_agrees");
    assert!(!ok && agrees < 0.5, "{agrees}");
    let (balance, ok) = gate(&r, "aha.balance");
    eprintln!("aortic base: aha.balance {balance:.3}, rim_agrees {agrees:.3}");
    assert!(!ok && balance < 0.15, "{balance}");
    for g in r["gates"].as_array().unwrap() {
        assert_eq!(g["passed"] == false, g["fallback"].is_string(), "{g}");
    }
}

/// Two openings of one size facing away from the apex (an open tube): with
/// `--rv-landmarks` and no `--rim-near` the choice is refused naming each
/// opening and `--rim-near`; without any landmark the message names every
/// way to give them.
#[test]
fn openings_of_one_size_and_missing_landmarks_are_refused_in_one_line() {
    let c = case();
    let n = 48u32;
    let mut pos = Vec::new();
    for z in [-40.0, -30.0, -20.0, -10.0, 0.0] {
        for k in 0..n {
            let t = k as f64 * std::f64::consts::TAU / n as f64;
            pos.push(Point3::new(20.0 * t.cos(), 20.0 * t.sin(), z));
        }
    }
    let mut tris = Vec::new();
    for i in 0..4 {
        for k in 0..n {
            let (a, b) = (i * n + k, i * n + (k + 1) % n);
            tris.push([a, b, b + n]);
            tris.push([a, b + n, a + n]);
        }
    }
    let tube = c.dir.path().join("tube.vtp");
    write_mesh(
        &tube,
        &CellMesh::from(&TriMesh::new(pos, tris)),
        &WriteOptions::default(),
    )
    .unwrap();
    let out = c.dir.path().join("tube");
    let o = unfold(&[
        "ventricle",
        &s(&c.anatomy),
        "--surface",
        &s(&tube),
        "--rv-landmarks",
        "30,0,-5",
        "0,30,-5",
        "--apex",
        "0,0,-20",
        "-o",
        &s(&out),
    ]);
    assert_one_line_error(&o, "the basal rim is ambiguous: opening 0 (48 vertices");
    assert_one_line_error(&o, "opening 1 (48 vertices");
    assert_one_line_error(&o, "both face away from the apex");
    assert_one_line_error(&o, "--rim-near X,Y,Z");

    let o = unfold(&[
        "ventricle",
        &s(&c.anatomy),
        "--surface",
        &s(&c.lv),
        "-o",
        &s(&out),
    ]);
    for route in [
        "--anterior and --inferior",
        "--landmarks FILE",
        "--rv-landmarks P Q",
    ] {
        assert_one_line_error(&o, route);
    }
    assert!(!out.exists());
}
