//! Helpers shared by the tests that run the `unfold` binary.

#![allow(dead_code)] // each test crate uses its own subset

use std::path::Path;
use std::process::{Command, Output};

/// Runs the `unfold` binary built for the tests, from the package root.
pub fn unfold(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_unfold"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the unfold binary runs")
}

/// Its standard output as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Its standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A path as an argument.
pub fn s(p: &Path) -> String {
    p.display().to_string()
}

/// Fails non-zero with a single stderr line naming `needle`.
pub fn assert_one_line_error(o: &Output, needle: &str) {
    assert!(!o.status.success(), "expected failure, got: {}", stdout(o));
    let err = stderr(o);
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err:?}");
    assert!(err.starts_with("unfold: error: "), "{err}");
    assert!(err.contains(needle), "{err:?} should mention {needle:?}");
}

/// Succeeds with nothing on stderr (progress lines only on a terminal).
pub fn assert_ok(o: &Output) {
    assert!(o.status.success(), "{}", stderr(o));
    assert!(o.stderr.is_empty(), "stderr: {}", stderr(o));
}

/// The vertices of `elements` renumbered in the order the elements first use
/// them (the order welding their soup gives back: each welded vertex keeps
/// its first copy): the new positions, the renumbered elements, and the new
/// number of every old vertex (`u32::MAX` for an unused one).
pub fn first_use_order<const N: usize>(
    positions: &[unfold::mesh::nalgebra::Point3<f64>],
    elements: &[[u32; N]],
) -> (
    Vec<unfold::mesh::nalgebra::Point3<f64>>,
    Vec<[u32; N]>,
    Vec<u32>,
) {
    let mut number = vec![u32::MAX; positions.len()];
    let mut ordered = Vec::new();
    for e in elements {
        for &v in e {
            if number[v as usize] == u32::MAX {
                number[v as usize] = ordered.len() as u32;
                ordered.push(positions[v as usize]);
            }
        }
    }
    let renumbered = elements
        .iter()
        .map(|e| e.map(|v| number[v as usize]))
        .collect();
    (ordered, renumbered, number)
}

/// A point as the command line takes it: `X,Y,Z` (full precision).
pub fn pt(p: &unfold::mesh::nalgebra::Point3<f64>) -> String {
    format!("{:?},{:?},{:?}", p.x, p.y, p.z)
}

/// The ventricle cup's S and anatomy surface written into `dir` as
/// `surface.vtp` and `anatomy_in.vtp`: `(anatomy, surface)`.
pub fn write_cup(
    dir: &Path,
    v: &unfold::mesh::shapes::VentricleShape,
) -> (std::path::PathBuf, std::path::PathBuf) {
    use unfold::mesh::CellMesh;
    let surface = dir.join("surface.vtp");
    let anatomy = dir.join("anatomy_in.vtp");
    let o = unfold::io::WriteOptions::default();
    unfold::io::write_mesh(&surface, &CellMesh::from(&v.surface), &o).unwrap();
    unfold::io::write_mesh(&anatomy, &CellMesh::from(&v.anatomy), &o).unwrap();
    (anatomy, surface)
}

/// The heart flags of the cup: `--surface S` and its landmarks, on a 1.5
/// mm grid.
pub fn cup_heart(surface: &Path, v: &unfold::mesh::shapes::VentricleShape) -> Vec<String> {
    vec![
        "--surface".into(),
        s(surface),
        "--anterior".into(),
        pt(&v.anterior),
        "--inferior".into(),
        pt(&v.inferior),
        "--apex".into(),
        pt(&v.apex),
        "--grid-mm".into(),
        "1.5".into(),
    ]
}

/// Runs `unfold COMMAND INPUT <heart> -o OUT EXTRA`.
pub fn run_heart(
    command: &str,
    input: &Path,
    heart: &[String],
    out: &Path,
    extra: &[&str],
) -> Output {
    let mut args = vec![command.to_string(), s(input)];
    args.extend(heart.iter().cloned());
    args.extend(["-o".to_string(), s(out)]);
    args.extend(extra.iter().map(|x| x.to_string()));
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    unfold(&refs)
}

/// Runs `unfold mitral` on the valve files `[anterior, posterior, annulus]`
/// into `out`, with the `extra` flags.
pub fn mitral_on_files(files: &[std::path::PathBuf; 3], out: &Path, extra: &[&str]) -> Output {
    let (a, p, r, o) = (s(&files[0]), s(&files[1]), s(&files[2]), s(out));
    let mut args = vec![
        "mitral",
        "--anterior",
        &a,
        "--posterior",
        &p,
        "--annulus",
        &r,
        "-o",
        &o,
    ];
    args.extend_from_slice(extra);
    unfold(&args)
}
