//! `unfold repair` on meshes made messy programmatically from clean ones: a
//! triangle soup (every triangle with its own vertices, as STL and many
//! exporters store it) with reversed and repeated triangles, fins and
//! T-junction slivers is repaired into the clean surface, and `unfold
//! ventricle` maps the messy surface like the clean one; what cannot be
//! repaired (a Moebius strip) is a one-line error naming its vertices.

use std::collections::HashMap;
use std::path::Path;
use std::process::Output;
use unfold::io::{WriteOptions, read_mesh, write_mesh};
use unfold::mesh::nalgebra::Point3;
use unfold::mesh::shapes::{VentricleParams, VentricleShape, ventricle_cup};
use unfold::mesh::{CellMesh, TriMesh};

mod common;
use common::*;

/// `m` as a soup: own vertices per triangle, every 3rd triangle reversed,
/// every 5th repeated.
fn soup(m: &TriMesh) -> TriMesh {
    let (mut positions, mut triangles) = (Vec::new(), Vec::new());
    for (t, tri) in m.triangles.iter().enumerate() {
        for _ in 0..if t % 5 == 0 { 2 } else { 1 } {
            let base = positions.len() as u32;
            positions.extend(tri.iter().map(|&v| m.positions[v as usize]));
            let mut new = [base, base + 1, base + 2];
            if t % 3 == 0 {
                new.swap(1, 2);
            }
            triangles.push(new);
        }
    }
    TriMesh::new(positions, triangles)
}

fn write(path: &Path, mesh: &TriMesh) {
    write_mesh(path, &CellMesh::from(mesh), &WriteOptions::default()).unwrap();
}

fn pt(p: &Point3<f64>) -> String {
    format!("{:?},{:?},{:?}", p.x, p.y, p.z)
}

/// `unfold ventricle` on the cup's anatomy with `surface`.
fn ventricle(v: &VentricleShape, anatomy: &Path, surface: &Path, out: &Path) -> Output {
    unfold(&[
        "ventricle",
        &s(anatomy),
        "--surface",
        &s(surface),
        "--anterior",
        &pt(&v.anterior),
        "--inferior",
        &pt(&v.inferior),
        "--apex",
        &pt(&v.apex),
        "--grid-mm",
        "1.5",
        "--no-figures",
        "-o",
        &s(out),
    ])
}

fn array(m: &CellMesh, name: &str) -> Vec<f64> {
    m.point_data.get(name).unwrap().values().to_f64()
}

#[test]
fn a_triangle_soup_is_repaired_into_the_surface_that_maps_like_the_clean_one() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let v = ventricle_cup(&VentricleParams::default()).unwrap();
    let (clean, messy, fixed, anatomy) = (
        d.join("clean.vtu"),
        d.join("messy.vtu"),
        d.join("fixed.vtu"),
        d.join("anatomy.vtu"),
    );
    write(&clean, &v.surface);
    let bad = soup(&v.surface);
    write(&messy, &bad);
    write(&anatomy, &v.anatomy);
    let before = std::fs::read(&messy).unwrap();

    // As exported, the surface maps: the pipeline welds it first.
    let o = ventricle(&v, &anatomy, &messy, &d.join("from_soup"));
    assert_ok(&o);

    let o = unfold(&["repair", &s(&messy), "-o", &s(&fixed), "--json"]);
    assert_ok(&o);
    assert_eq!(std::fs::read(&messy).unwrap(), before, "input untouched");
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let (nv, nt) = (v.surface.positions.len(), v.surface.triangles.len());
    let dups = nt.div_ceil(5);
    assert_eq!(j["elements"], "triangles");
    assert_eq!(j["vertices"], nv);
    assert_eq!(j["cells"], nt);
    let r = &j["repair"];
    assert_eq!(r["welded_vertices"], bad.positions.len() - nv);
    assert_eq!(r["duplicate_elements"], dups);
    assert_eq!(r["unused_vertices"], 0);
    assert_eq!(r["components"], 1);
    assert!(r["flipped"].as_u64().unwrap() > 0);
    let info = unfold(&["info", &s(&fixed), "--json"]);
    let info: serde_json::Value = serde_json::from_str(&stdout(&info)).unwrap();
    assert_eq!(info["problems"].as_array().map(Vec::len), Some(0), "{info}");

    // Repaired, it maps exactly like the clean surface.
    let (a, b) = (d.join("from_clean"), d.join("from_fixed"));
    assert_ok(&ventricle(&v, &anatomy, &clean, &a));
    assert_ok(&ventricle(&v, &anatomy, &fixed, &b));
    let (ma, mb) = (
        read_mesh(a.join("normalized.vtu")).unwrap(),
        read_mesh(b.join("normalized.vtu")).unwrap(),
    );
    for name in ["xi", "zeta", "depth"] {
        let worst = array(&ma, name)
            .iter()
            .zip(array(&mb, name))
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-9, "{name}: {worst}");
    }

    // Without welding the soup stays apart (every triangle its own piece).
    let o = unfold(&[
        "repair",
        &s(&messy),
        "-o",
        &s(&d.join("apart.vtu")),
        "--no-weld",
    ]);
    assert_ok(&o);
    assert!(stdout(&o).contains("components"), "{}", stdout(&o));
}

#[test]
fn a_tet_mesh_with_copied_vertices_and_tets_is_repaired() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cube = unfold::mesh::shapes::kuhn_grid([2, 2, 2], [1.0, 1.0, 1.0]);
    // Every tet with its own vertices, and the first tet twice.
    let (mut positions, mut tets) = (Vec::new(), Vec::new());
    for (t, tet) in cube.tets.iter().chain(&cube.tets[..1]).enumerate() {
        let base = positions.len() as u32;
        positions.extend(tet.iter().map(|&v| cube.positions[v as usize]));
        let mut new = [base, base + 1, base + 2, base + 3];
        if t % 2 == 0 {
            new.swap(2, 3);
        }
        tets.push(new);
    }
    let messy = unfold::mesh::TetMesh::new(positions, tets);
    let (input, output) = (d.join("messy.vtu"), d.join("fixed.vtu"));
    write_mesh(&input, &CellMesh::from(&messy), &WriteOptions::default()).unwrap();
    let o = unfold(&["repair", &s(&input), "-o", &s(&output), "--json"]);
    assert_ok(&o);
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(j["elements"], "tets");
    assert_eq!(j["vertices"], cube.positions.len());
    assert_eq!(j["cells"], cube.tets.len());
    assert_eq!(j["repair"]["duplicate_elements"], 1);
    let fixed = read_mesh(&output).unwrap().to_tet_mesh().unwrap();
    for t in 0..fixed.tets.len() {
        let [a, b, c, e] = fixed.tet_points(t);
        assert!(
            (b - a).dot(&(c - a).cross(&(e - a))) > 0.0,
            "tet {t} positive"
        );
    }
}

/// A surface with a speck beside it (a triangle far off, as a
/// segmentation's island exports): `--largest-component` keeps the surface
/// as it was and says what it dropped; without the flag both are kept.
#[test]
fn the_largest_component_is_kept_on_request() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cup = ventricle_cup(&VentricleParams::default()).unwrap().surface;
    let mut specked = cup.clone();
    let n = specked.positions.len() as u32;
    specked.positions.extend([
        Point3::new(200.0, 0.0, 0.0),
        Point3::new(201.0, 0.0, 0.0),
        Point3::new(200.0, 1.0, 0.0),
    ]);
    specked.triangles.push([n, n + 1, n + 2]);
    let input = d.join("specked.vtu");
    write(&input, &specked);
    let kept = d.join("kept.vtu");
    let o = unfold(&[
        "repair",
        &s(&input),
        "-o",
        &s(&kept),
        "--largest-component",
        "--json",
    ]);
    assert_ok(&o);
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(j["repair"]["components"], 2);
    assert_eq!(j["largest_component"]["components"], 2);
    assert_eq!(j["largest_component"]["elements"], 1);
    assert_eq!(j["largest_component"]["vertices"], 3);
    let got = read_mesh(&kept).unwrap().to_tri_mesh().unwrap();
    assert_eq!(got.positions, cup.positions);
    assert_eq!(got.triangles, cup.triangles);
    let both = d.join("both.vtu");
    let o = unfold(&["repair", &s(&input), "-o", &s(&both), "--json"]);
    assert_ok(&o);
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert!(j.get("largest_component").is_none(), "{j}");
    assert_eq!(j["cells"], cup.triangles.len() + 1);
}

#[test]
fn bad_repair_requests_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let m = d.join("m.vtu");
    write(
        &m,
        &ventricle_cup(&VentricleParams::default()).unwrap().surface,
    );
    let out = s(&d.join("o.vtu"));
    assert_one_line_error(
        &unfold(&["repair", &s(&m), "-o", &out, "--weld-mm", "-1"]),
        "--weld-mm",
    );
    assert_one_line_error(
        &unfold(&["repair", &s(&m), "-o", &out, "--weld-mm", "1", "--no-weld"]),
        "--no-weld",
    );
    assert_one_line_error(
        &unfold(&["repair", &s(&m), "-o", &s(&m)]),
        "refusing to overwrite",
    );
    assert_one_line_error(
        &unfold(&["repair", "/no/such/mesh.vtu", "-o", &out]),
        "/no/such/mesh.vtu",
    );
    assert!(!d.join("o.vtu").exists());
}

/// What [`mess`] injected.
#[derive(Debug)]
struct Injected {
    fins: usize,
    slivers: usize,
    duplicates: usize,
}

/// `m` as exporters leave it: `fins` triangles standing on interior edges
/// (each with its own apex), `slivers` T-junctions (a triangle `[a, b, c]`
/// split at the midpoint `x` of its interior edge `a-b` into `[a, x, c]`,
/// `[x, b, c]`, the crack closed by the zero-area `[a, b, x]`); then as a
/// soup (own vertices per triangle), every 2nd triangle reversed and every
/// 7th untouched clean triangle repeated.
fn mess(m: &TriMesh, fins: usize, slivers: usize) -> (TriMesh, Injected) {
    let mut count: HashMap<(u32, u32), usize> = HashMap::new();
    for t in &m.triangles {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut positions = m.positions.clone();
    let mut tris: Vec<[u32; 3]> = m.triangles.clone();
    let mut touched = vec![false; m.triangles.len()];
    let mut used = vec![false; m.positions.len()];
    let mut extra = Vec::new();
    let mut inj = Injected {
        fins: 0,
        slivers: 0,
        duplicates: 0,
    };
    for t in (0..m.triangles.len()).step_by(11) {
        if inj.fins == fins && inj.slivers == slivers {
            break;
        }
        let [a, b, c] = m.triangles[t];
        if count[&(a.min(b), a.max(b))] != 2 || [a, b, c].iter().any(|&v| used[v as usize]) {
            continue;
        }
        for v in [a, b, c] {
            used[v as usize] = true;
        }
        let (pa, pb, pc) = (
            positions[a as usize],
            positions[b as usize],
            positions[c as usize],
        );
        let mid = Point3::from((pa.coords + pb.coords) / 2.0);
        let x = positions.len() as u32;
        if inj.fins < fins {
            let n = (pb - pa).cross(&(pc - pa)).normalize();
            positions.push(mid + n * (pb - pa).norm());
            extra.push([a, b, x]);
            inj.fins += 1;
        } else {
            positions.push(mid);
            tris[t] = [a, x, c];
            touched[t] = true;
            extra.push([x, b, c]);
            extra.push([a, b, x]);
            inj.slivers += 1;
        }
    }
    let mut out = TriMesh::default();
    for (t, tri) in tris.iter().chain(&extra).enumerate() {
        let copies = if t < touched.len() && !touched[t] && t % 7 == 0 {
            inj.duplicates += 1;
            2
        } else {
            1
        };
        for _ in 0..copies {
            let base = out.positions.len() as u32;
            out.positions
                .extend(tri.iter().map(|&v| positions[v as usize]));
            out.triangles.push(if t % 2 == 0 {
                [base, base + 2, base + 1]
            } else {
                [base, base + 1, base + 2]
            });
        }
    }
    (out, inj)
}

/// Position -> vertex, exact.
fn by_position(m: &TriMesh) -> HashMap<[u64; 3], u32> {
    m.positions
        .iter()
        .enumerate()
        .map(|(v, p)| ([p.x, p.y, p.z].map(f64::to_bits), v as u32))
        .collect()
}

/// `got` is `want` up to vertex order and a global orientation flip.
fn assert_same_mesh(got: &TriMesh, want: &TriMesh) {
    assert_eq!(got.positions.len(), want.positions.len());
    assert_eq!(got.triangles.len(), want.triangles.len());
    let index = by_position(want);
    let to_want: Vec<u32> = got
        .positions
        .iter()
        .map(|p| index[&[p.x, p.y, p.z].map(f64::to_bits)])
        .collect();
    let mut seen = to_want.clone();
    seen.sort_unstable();
    seen.dedup();
    assert_eq!(seen.len(), want.positions.len(), "a bijection of vertices");
    let canon = |t: [u32; 3]| {
        let i = (0..3).min_by_key(|&i| t[i]).unwrap();
        [t[i], t[(i + 1) % 3], t[(i + 2) % 3]]
    };
    let mut w: Vec<[u32; 3]> = want.triangles.iter().map(|&t| canon(t)).collect();
    w.sort_unstable();
    for flip in [false, true] {
        let mut g: Vec<[u32; 3]> = got
            .triangles
            .iter()
            .map(|t| {
                let t = t.map(|v| to_want[v as usize]);
                canon(if flip { [t[0], t[2], t[1]] } else { t })
            })
            .collect();
        g.sort_unstable();
        if g == w {
            return;
        }
    }
    panic!("the triangles differ from the clean mesh's");
}

#[test]
fn a_messy_lv_surface_repairs_to_the_clean_one_and_maps_like_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let v = ventricle_cup(&VentricleParams::default()).unwrap();
    let (bad, inj) = mess(&v.surface, 3, 3);
    assert_eq!((inj.fins, inj.slivers), (3, 3), "injected as asked");
    let (clean, messy, fixed, anatomy) = (
        d.join("clean.vtu"),
        d.join("messy.vtu"),
        d.join("fixed.vtu"),
        d.join("anatomy.vtu"),
    );
    write(&clean, &v.surface);
    write(&messy, &bad);
    write(&anatomy, &v.anatomy);

    // (a) unfold repair gives the clean mesh back, counting every kind.
    let o = unfold(&["repair", &s(&messy), "-o", &s(&fixed), "--json"]);
    assert_ok(&o);
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let r = &j["repair"];
    let nv = v.surface.positions.len();
    assert_eq!(
        r["welded_vertices"],
        bad.positions.len() - nv - inj.fins - inj.slivers,
        "{r}"
    );
    assert_eq!(r["duplicate_elements"], inj.duplicates, "{r}");
    assert_eq!(r["fin_triangles"], inj.fins, "{r}");
    assert_eq!(r["collapsed_vertices"], inj.slivers, "{r}");
    assert_eq!(r["degenerate_elements"], 2 * inj.slivers, "{r}");
    assert_eq!(r["unused_vertices"], inj.fins, "{r}");
    assert_eq!(r["non_manifold_vertices_split"], 0, "{r}");
    assert_eq!(r["components"], 1);
    assert!(r["flipped"].as_u64().unwrap() > 0);
    let got = read_mesh(&fixed).unwrap().to_tri_mesh().unwrap();
    assert_same_mesh(&got, &v.surface);
    // The same written as STL (single precision, the midpoints rounded off
    // their edges): the same repairs.
    let stl = d.join("messy.stl");
    write(&stl, &bad);
    let o = unfold(&[
        "repair",
        &s(&stl),
        "-o",
        &s(&d.join("from_stl.vtu")),
        "--json",
    ]);
    assert_ok(&o);
    let js: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    for k in [
        "fin_triangles",
        "collapsed_vertices",
        "degenerate_elements",
        "duplicate_elements",
    ] {
        assert_eq!(js["repair"][k], r[k], "{k}: {js}");
    }
    assert_eq!(js["vertices"], nv);
    assert_eq!(js["cells"], v.surface.triangles.len());
    // Repairing the repaired mesh changes nothing.
    let o = unfold(&["repair", &s(&fixed), "-o", &s(&d.join("again.vtu"))]);
    assert_ok(&o);
    assert!(stdout(&o).contains("nothing to repair"), "{}", stdout(&o));

    // (b) unfold ventricle on the messy S maps the anatomy like on the
    // clean S; (d) its report counts the repair.
    let (a, b) = (d.join("from_clean"), d.join("from_messy"));
    assert_ok(&ventricle(&v, &anatomy, &clean, &a));
    assert_ok(&ventricle(&v, &anatomy, &messy, &b));
    let (ma, mb) = (
        read_mesh(a.join("normalized.vtu")).unwrap(),
        read_mesh(b.join("normalized.vtu")).unwrap(),
    );
    for name in ["xi", "zeta", "depth"] {
        let worst = array(&ma, name)
            .iter()
            .zip(array(&mb, name))
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-9, "{name}: {worst}");
    }
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(b.join("report.json")).unwrap()).unwrap();
    let sr = &report["surface_repair"];
    assert_eq!(sr["fin_triangles"], inj.fins, "{sr}");
    assert_eq!(sr["collapsed_vertices"], inj.slivers, "{sr}");
    assert_eq!(sr["duplicate_elements"], inj.duplicates, "{sr}");
    assert_eq!(sr["welded_vertices"], r["welded_vertices"], "{sr}");
}

/// A strip of 6 quads glued end to end with a half twist.
fn mobius() -> TriMesh {
    let n = 6usize;
    let mut positions = Vec::new();
    for i in 0..n {
        let u = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
        for w in [-3.0, 3.0] {
            let r = 10.0 + w * (u / 2.0).cos();
            positions.push(Point3::new(r * u.cos(), r * u.sin(), w * (u / 2.0).sin()));
        }
    }
    let mut triangles = Vec::new();
    for i in 0..n as u32 {
        let (a, b) = (2 * i, 2 * i + 1);
        let (c, e) = if i + 1 < n as u32 {
            (a + 2, b + 2)
        } else {
            (1, 0)
        };
        triangles.push([a, c, e]);
        triangles.push([a, e, b]);
    }
    TriMesh::new(positions, triangles)
}

#[test]
fn a_moebius_strip_is_refused_naming_its_vertices() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let m = d.join("moebius.vtu");
    write(&m, &mobius());
    let out = d.join("o.vtu");
    let o = unfold(&["repair", &s(&m), "-o", &s(&out)]);
    assert_one_line_error(&o, "not orientable");
    assert_one_line_error(&o, &s(&m));
    assert_one_line_error(&o, "from vertex ");
    assert!(!out.exists(), "nothing written");
}

#[test]
fn small_holes_are_filled_on_request() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let v = ventricle_cup(&VentricleParams::default()).unwrap();
    // Remove the fan of one interior vertex (not on the rim).
    let mut boundary = vec![false; v.surface.positions.len()];
    let mut count: HashMap<(u32, u32), usize> = HashMap::new();
    for t in &v.surface.triangles {
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    for (&(a, b), &c) in &count {
        if c == 1 {
            boundary[a as usize] = true;
            boundary[b as usize] = true;
        }
    }
    let centre = (0..boundary.len() as u32)
        .rev()
        .find(|&c| {
            !boundary[c as usize]
                && v.surface
                    .triangles
                    .iter()
                    .filter(|t| t.contains(&c))
                    .flatten()
                    .all(|&w| !boundary[w as usize])
        })
        .unwrap();
    let mut holed = v.surface.clone();
    holed.triangles.retain(|t| !t.contains(&centre));
    let removed = v.surface.triangles.len() - holed.triangles.len();
    let (inp, out) = (d.join("holed.vtu"), d.join("filled.vtu"));
    write(&inp, &holed);
    let o = unfold(&[
        "repair",
        &s(&inp),
        "-o",
        &s(&out),
        "--fill-holes-mm",
        "100",
        "--json",
    ]);
    assert_ok(&o);
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    // The rim (perimeter far above 100 mm) stays open; the hole is closed.
    assert_eq!(j["repair"]["holes_filled"], 1, "{j}");
    assert_eq!(j["repair"]["hole_triangles"], removed - 2, "{j}");
    assert_eq!(j["repair"]["unused_vertices"], 1, "{j}");
    let info = unfold(&["info", &s(&out), "--json"]);
    let info: serde_json::Value = serde_json::from_str(&stdout(&info)).unwrap();
    assert_eq!(info["problems"].as_array().map(Vec::len), Some(0), "{info}");
    // Without the flag the hole stays, and the text says so.
    let o = unfold(&["repair", &s(&inp), "-o", &s(&d.join("kept.vtu"))]);
    assert_ok(&o);
    assert!(!stdout(&o).contains("filled"), "{}", stdout(&o));
    for bad in ["0", "-2", "nan"] {
        assert_one_line_error(
            &unfold(&["repair", &s(&inp), "-o", &s(&out), "--fill-holes-mm", bad]),
            "--fill-holes-mm",
        );
    }
}
