//! The fixed vertices of a deformation (hard constraints): the HANDLES
//! file ([`parse_handles`]) and the boundary ([`boundary_vertices`]).
//!
//! HANDLES file: one 0-based vertex index per line. Blank lines and `#`
//! comments (a whole line, or the rest of a line) are ignored. Every
//! problem is reported with the file and line: a line that is not a
//! non-negative integer, a vertex out of range, a vertex listed twice, no
//! vertex at all.

use crate::app::error::{AppError, at};
use std::path::Path;

/// Parses the HANDLES `text` (from `file`, for messages) for a mesh of
/// `num_vertices` vertices: the vertices in file order (module doc).
///
/// # Errors
/// [`AppError::Usage`] naming the file and the line.
pub fn parse_handles(text: &str, file: &Path, num_vertices: usize) -> Result<Vec<usize>, AppError> {
    let err = |line: usize, msg: String| at(file, format!("line {line}: {msg}"));
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    // Line (1-based) of each vertex; 0 = not listed yet.
    let mut line_of = vec![0usize; num_vertices];
    let mut handles = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let v: usize = line.parse().map_err(|_| {
            err(
                line_no,
                format!("`{line}` is not a vertex index (expected a non-negative integer)"),
            )
        })?;
        if v >= num_vertices {
            return Err(err(
                line_no,
                format!(
                    "vertex {v} is out of range (the mesh has {num_vertices} vertices, numbered \
                     from 0)"
                ),
            ));
        }
        if line_of[v] != 0 {
            return Err(err(
                line_no,
                format!("vertex {v} is listed twice (first on line {})", line_of[v]),
            ));
        }
        line_of[v] = line_no;
        handles.push(v);
    }
    if handles.is_empty() {
        return Err(at(file, "no vertex indices (expected one per line)"));
    }
    Ok(handles)
}

/// The boundary vertices, ascending: the vertices of the facets used by one
/// element, a facet being an element's vertex list less one vertex (the
/// faces of tets, the edges of triangles), compared as vertex sets.
pub fn boundary_vertices(elements: &[&[u32]], num_vertices: usize) -> Vec<usize> {
    let mut facets: Vec<Vec<u32>> = Vec::with_capacity(elements.len() * 4);
    for e in elements {
        for skip in 0..e.len() {
            let mut f: Vec<u32> = (0..e.len()).filter(|&k| k != skip).map(|k| e[k]).collect();
            f.sort_unstable();
            facets.push(f);
        }
    }
    facets.sort_unstable();
    let mut on = vec![false; num_vertices];
    let mut i = 0;
    while i < facets.len() {
        let mut j = i + 1;
        while j < facets.len() && facets[j] == facets[i] {
            j += 1;
        }
        if j - i == 1 {
            for &v in &facets[i] {
                on[v as usize] = true;
            }
        }
        i = j;
    }
    (0..num_vertices).filter(|&v| on[v]).collect()
}

/// The fixed vertices: `handles` and, with `boundary`, every boundary
/// vertex of `elements` ([`boundary_vertices`]); ascending, each once.
pub fn fixed_vertices(
    handles: &[usize],
    boundary: bool,
    elements: &[&[u32]],
    num_vertices: usize,
) -> Vec<usize> {
    let mut fixed = handles.to_vec();
    if boundary {
        fixed.extend(boundary_vertices(elements, num_vertices));
    }
    fixed.sort_unstable();
    fixed.dedup();
    fixed
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Vec<usize>, String> {
        parse_handles(text, Path::new("h.txt"), 5).map_err(|e| e.to_string())
    }

    #[test]
    fn handles_with_comments_and_blanks() {
        assert_eq!(
            parse("\u{feff}# handles\n\n 3 \r\n0 # the corner\n4\n").unwrap(),
            vec![3, 0, 4]
        );
    }

    #[test]
    fn handles_errors_name_the_line() {
        for (text, needle) in [
            ("1\nx\n", "h.txt: line 2: `x` is not a vertex index"),
            ("-1\n", "line 1: `-1` is not a vertex index"),
            ("1.0\n", "line 1: `1.0` is not a vertex index"),
            ("1 2\n", "line 1: `1 2` is not a vertex index"),
            (
                "\n5\n",
                "h.txt: line 2: vertex 5 is out of range (the mesh has 5 vertices",
            ),
            (
                "2\n\n2\n",
                "h.txt: line 3: vertex 2 is listed twice (first on line 1)",
            ),
            ("# none\n\n", "h.txt: no vertex indices"),
        ] {
            let e = parse(text).unwrap_err();
            assert!(e.contains(needle), "{text:?}: {e:?} lacks {needle:?}");
        }
    }

    #[test]
    fn boundary_of_a_grid() {
        // 3 x 3 vertices: all but the centre are on the boundary.
        let disk = crate::mesh::shapes::grid_disk(2, 2);
        let els: Vec<&[u32]> = disk.triangles.iter().map(|t| &t[..]).collect();
        assert_eq!(boundary_vertices(&els, 9), vec![0, 1, 2, 3, 5, 6, 7, 8]);
        let cube = crate::mesh::shapes::kuhn_grid([2, 2, 2], [1.0; 3]);
        let els: Vec<&[u32]> = cube.tets.iter().map(|t| &t[..]).collect();
        let b = boundary_vertices(&els, 27);
        assert_eq!(b.len(), 26);
        assert!(!b.contains(&13));
        assert_eq!(fixed_vertices(&[13, 0], true, &els, 27).len(), 27);
        assert_eq!(fixed_vertices(&[13, 0], false, &els, 27), vec![0, 13]);
    }
}
