//! What a repair changed, one count per kind.

use serde::{Deserialize, Serialize};
use std::fmt;

/// What [`super::repair_tri_mesh`] / [`super::repair_tet_mesh`] changed, in
/// the order the steps run (see [`super`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RepairReport {
    /// Vertices merged into a coincident one (welding).
    pub welded_vertices: usize,
    /// Elements removed because they use a vertex more than once (in the
    /// input or after welding).
    pub repeated_vertex_elements: usize,
    /// Zero-area triangles (collapsed, with the triangles that collapsed
    /// with them) or zero-volume tets (dropped) removed.
    pub degenerate_elements: usize,
    /// Vertices merged into an endpoint of a zero-area triangle's longest
    /// edge (triangle meshes).
    pub collapsed_vertices: usize,
    /// Elements removed because an earlier element has the same vertex set
    /// (in either orientation).
    pub duplicate_elements: usize,
    /// Triangles removed as fins: extra triangles or patches glued onto an
    /// edge that already had two.
    pub fin_triangles: usize,
    /// Vertices whose triangles formed several fans, split into one vertex
    /// per fan.
    pub non_manifold_vertices_split: usize,
    /// Elements whose orientation was reversed.
    pub flipped: usize,
    /// Boundary loops closed (`--fill-holes-mm`).
    pub holes_filled: usize,
    /// Triangles added to close them.
    pub hole_triangles: usize,
    /// Loops short enough to close that were left open: every way of
    /// closing them over their own vertices makes an edge of more than two
    /// triangles (a chord of the loop is an edge of the mesh already).
    #[serde(default)]
    pub holes_left_open: usize,
    /// Vertices removed because no (remaining) element uses them.
    pub unused_vertices: usize,
    /// Connected components of the repaired mesh.
    pub components: usize,
}

impl RepairReport {
    /// True when the repair changed nothing.
    pub fn is_clean(&self) -> bool {
        *self
            == RepairReport {
                components: self.components,
                ..Default::default()
            }
    }
}

fn n(count: usize, one: &str, many: &str) -> String {
    format!("{count} {}", if count == 1 { one } else { many })
}

impl fmt::Display for RepairReport {
    /// One line, e.g. `removed 2 duplicate elements, 1 unused vertex;
    /// flipped 3 elements; 1 component`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut removed = Vec::new();
        let mut push = |count: usize, one: &str, many: &str| {
            if count > 0 {
                removed.push(n(count, one, many));
            }
        };
        push(
            self.welded_vertices,
            "coincident vertex (welded)",
            "coincident vertices (welded)",
        );
        push(
            self.duplicate_elements,
            "duplicate element",
            "duplicate elements",
        );
        push(
            self.repeated_vertex_elements,
            "element with a repeated vertex",
            "elements with a repeated vertex",
        );
        push(
            self.degenerate_elements,
            "degenerate element",
            "degenerate elements",
        );
        push(
            self.collapsed_vertices,
            "vertex of a sliver (collapsed)",
            "vertices of slivers (collapsed)",
        );
        push(self.fin_triangles, "fin triangle", "fin triangles");
        push(self.unused_vertices, "unused vertex", "unused vertices");
        let mut parts = Vec::new();
        if !removed.is_empty() {
            parts.push(format!("removed {}", removed.join(", ")));
        }
        if self.non_manifold_vertices_split > 0 {
            parts.push(format!(
                "split {}",
                n(
                    self.non_manifold_vertices_split,
                    "non-manifold vertex",
                    "non-manifold vertices"
                )
            ));
        }
        if self.flipped > 0 {
            parts.push(format!(
                "flipped {}",
                n(self.flipped, "element", "elements")
            ));
        }
        if self.holes_filled > 0 {
            parts.push(format!(
                "filled {} with {}",
                n(self.holes_filled, "hole", "holes"),
                n(self.hole_triangles, "triangle", "triangles")
            ));
        }
        if self.holes_left_open > 0 {
            parts.push(format!(
                "left {} open (closing would make a non-manifold edge)",
                n(self.holes_left_open, "hole", "holes")
            ));
        }
        if parts.is_empty() {
            parts.push("nothing to repair".into());
        }
        parts.push(n(self.components, "component", "components"));
        write!(f, "{}", parts.join("; "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_display_is_one_line() {
        let r = RepairReport {
            duplicate_elements: 2,
            repeated_vertex_elements: 1,
            unused_vertices: 1,
            flipped: 3,
            components: 1,
            ..Default::default()
        };
        assert_eq!(
            r.to_string(),
            "removed 2 duplicate elements, 1 element with a repeated vertex, 1 unused vertex; \
             flipped 3 elements; 1 component"
        );
        assert!(!r.is_clean());
        let clean = RepairReport {
            components: 2,
            ..Default::default()
        };
        assert!(clean.is_clean());
        assert_eq!(clean.to_string(), "nothing to repair; 2 components");
        let welded = RepairReport {
            welded_vertices: 5,
            components: 1,
            ..Default::default()
        };
        assert_eq!(
            welded.to_string(),
            "removed 5 coincident vertices (welded); 1 component"
        );
        let all = RepairReport {
            degenerate_elements: 2,
            collapsed_vertices: 1,
            fin_triangles: 1,
            non_manifold_vertices_split: 1,
            holes_filled: 1,
            hole_triangles: 4,
            components: 1,
            ..Default::default()
        };
        assert_eq!(
            all.to_string(),
            "removed 2 degenerate elements, 1 vertex of a sliver (collapsed), 1 fin triangle; \
             split 1 non-manifold vertex; filled 1 hole with 4 triangles; 1 component"
        );
        assert!(!all.to_string().contains('\n'));
    }
}
