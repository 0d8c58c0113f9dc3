//! The rest shape of a deformation and its start: REST's cells read as tets
//! or triangles ([`rest_of`]), a start mesh INIT checked against REST (the
//! same vertex count and the same cells in the same order,
//! [`check_same_cells`]) and its positions turned into the library's flat
//! start ([`start_of`]: 3 coordinates per vertex for tets, `x, y` for
//! triangles, which are mapped to the plane `z = 0`).

use crate::app::error::{AppError, about};
use crate::mesh::{CellMesh, CellType, MeshError, TetMesh, TriMesh};
use crate::param::RestShape;

/// REST as the library solves it.
#[derive(Debug, Clone)]
pub enum Rest {
    /// A tet mesh, mapped into space.
    Tets(TetMesh),
    /// A triangle mesh (planar or a surface), mapped to the plane.
    Triangles(TriMesh),
}

impl Rest {
    /// The library's view of it.
    pub fn shape(&self) -> RestShape<'_> {
        match self {
            Rest::Tets(m) => RestShape::Tets(m),
            Rest::Triangles(m) => RestShape::Triangles(m),
        }
    }

    /// `"tets"` or `"triangles"`.
    pub fn elements(&self) -> &'static str {
        match self {
            Rest::Tets(_) => "tets",
            Rest::Triangles(_) => "triangles",
        }
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        match self {
            Rest::Tets(m) => m.num_tets(),
            Rest::Triangles(m) => m.num_triangles(),
        }
    }

    /// Whether there is no element.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        match self {
            Rest::Tets(m) => m.num_vertices(),
            Rest::Triangles(m) => m.num_vertices(),
        }
    }

    /// Coordinates per vertex of a map: 3 (tets) or 2 (triangles).
    pub fn dim(&self) -> usize {
        match self {
            Rest::Tets(_) => 3,
            Rest::Triangles(_) => 2,
        }
    }

    /// The vertex lists of the elements.
    pub fn element_vertices(&self) -> Vec<&[u32]> {
        match self {
            Rest::Tets(m) => m.tets.iter().map(|t| &t[..]).collect(),
            Rest::Triangles(m) => m.triangles.iter().map(|t| &t[..]).collect(),
        }
    }
}

/// REST's cells (REST called `name` in messages) as tets when it has any
/// (then every cell must be a tet), else as triangles (every cell a
/// triangle).
///
/// # Errors
/// [`AppError::Usage`] naming `name` and the first cell of another type, or
/// bad indices.
pub fn rest_of(cells: &CellMesh, name: &str) -> Result<Rest, AppError> {
    cells.check().map_err(|e| about(name, e))?;
    let has_tets = cells.cell_types.contains(&CellType::Tetra);
    let (want, what) = if has_tets {
        (CellType::Tetra, "tets")
    } else {
        (CellType::Triangle, "triangles")
    };
    if let Some(i) = cells.cell_types.iter().position(|&t| t != want) {
        let found = cells.cell_types[i];
        return Err(about(
            name,
            format!(
                "cell {i} is a {found:?}{}; unfold deform maps a mesh of tets only or of \
                 triangles only",
                if has_tets { " beside tets" } else { "" }
            ),
        ));
    }
    if cells.num_cells() == 0 {
        return Err(about(
            name,
            format!("no cells; unfold deform needs {what} (a tet or a triangle mesh)"),
        ));
    }
    let wrong = |e: MeshError| about(name, e);
    Ok(if has_tets {
        Rest::Tets(cells.to_tet_mesh().map_err(wrong)?)
    } else {
        Rest::Triangles(cells.to_tri_mesh().map_err(wrong)?)
    })
}

/// Checks that INIT (`init`, called `name`) has REST's (`rest`) vertex
/// count and the same cells (type and vertices) in the same order.
///
/// # Errors
/// [`AppError::Usage`] naming `name`: the counts, or the first differing
/// cell.
pub fn check_same_cells(rest: &CellMesh, init: &CellMesh, name: &str) -> Result<(), AppError> {
    let fix = "INIT must have REST's vertices and cells, in the same order";
    let (nr, ni) = (rest.num_points(), init.num_points());
    if nr != ni {
        return Err(about(
            name,
            format!("has {ni} vertices, REST has {nr}; {fix}"),
        ));
    }
    for i in 0..rest.num_cells().max(init.num_cells()) {
        let (a, b) = (
            (i < rest.num_cells()).then(|| rest.cell(i)),
            (i < init.num_cells()).then(|| init.cell(i)),
        );
        if a != b {
            let show = |c: Option<(CellType, &[u32])>| match c {
                Some((t, vs)) => format!("{t:?} {vs:?}"),
                None => "missing".to_string(),
            };
            return Err(about(
                name,
                format!(
                    "cell {i} is {} but REST's cell {i} is {}; {fix}",
                    show(b),
                    show(a)
                ),
            ));
        }
    }
    Ok(())
}

/// The library's flat start from INIT's positions (`positions`, called
/// `name`) for `rest`: `x, y, z` per vertex for tets, `x, y` for triangles,
/// whose INIT must lie in the plane `z = 0`.
///
/// # Errors
/// [`AppError::Usage`] naming `name`: another vertex count, a triangle
/// start with a vertex off the plane (the first, with its `z`).
pub fn start_of(
    rest: &Rest,
    positions: &[crate::mesh::nalgebra::Point3<f64>],
    name: &str,
) -> Result<Vec<f64>, AppError> {
    let n = rest.num_vertices();
    if positions.len() != n {
        return Err(about(
            name,
            format!(
                "has {} vertices, REST has {n}; INIT must have REST's vertices and cells, in the \
                 same order",
                positions.len()
            ),
        ));
    }
    match rest {
        Rest::Tets(_) => Ok(positions.iter().flat_map(|p| [p.x, p.y, p.z]).collect()),
        Rest::Triangles(_) => {
            if let Some(v) = positions.iter().position(|p| p.z != 0.0) {
                return Err(about(
                    name,
                    format!(
                        "vertex {v} has z = {:e}; a triangle mesh is mapped to the plane, so its \
                         start must lie in z = 0",
                        positions[v].z
                    ),
                ));
            }
            Ok(positions.iter().flat_map(|p| [p.x, p.y]).collect())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::nalgebra::Point3;

    fn tri_cells() -> CellMesh {
        CellMesh::from(&crate::mesh::shapes::grid_disk(2, 1))
    }

    #[test]
    fn rest_is_tets_or_triangles_only() {
        let tris = tri_cells();
        assert!(matches!(rest_of(&tris, "r").unwrap(), Rest::Triangles(_)));
        let tets = CellMesh::from(&crate::mesh::shapes::kuhn_grid([1, 1, 1], [1.0; 3]));
        let rest = rest_of(&tets, "r").unwrap();
        assert_eq!((rest.elements(), rest.len(), rest.dim()), ("tets", 6, 3));
        let mut mixed = tets.clone();
        mixed.push_cell(CellType::Triangle, &[0, 1, 2]);
        let e = rest_of(&mixed, "r").unwrap_err().to_string();
        assert!(e.starts_with("r: cell 6 is a Triangle beside tets"), "{e}");
        let mut quad = tris.clone();
        quad.push_cell(CellType::Quad, &[0, 1, 2, 3]);
        let e = rest_of(&quad, "r").unwrap_err().to_string();
        assert!(
            e.starts_with("r: cell 4 is a Quad; unfold deform maps"),
            "{e}"
        );
        let e = rest_of(&CellMesh::from_points(vec![Point3::origin()]), "r")
            .unwrap_err()
            .to_string();
        assert!(e.contains("r: no cells"), "{e}");
    }

    #[test]
    fn init_must_have_the_same_cells() {
        let rest = tri_cells();
        check_same_cells(&rest, &rest, "i").unwrap();
        let mut other = rest.clone();
        other.connectivity[4] = 5;
        let e = check_same_cells(&rest, &other, "i")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(
                "i: cell 1 is Triangle [0, 5, 3] but REST's cell 1 is Triangle [0, 4, 3]"
            ),
            "{e}"
        );
        let mut fewer = rest.clone();
        fewer.positions.pop();
        let e = check_same_cells(&rest, &fewer, "i")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("i: has 5 vertices, REST has 6"), "{e}");
        let mut more = rest.clone();
        more.push_cell(CellType::Triangle, &[0, 1, 2]);
        let e = check_same_cells(&rest, &more, "i").unwrap_err().to_string();
        assert!(
            e.contains("cell 4 is Triangle [0, 1, 2] but REST's cell 4 is missing"),
            "{e}"
        );
    }

    #[test]
    fn a_triangle_start_lies_in_the_plane() {
        let cells = tri_cells();
        let rest = rest_of(&cells, "r").unwrap();
        let mut p = cells.positions.clone();
        assert_eq!(start_of(&rest, &p, "i").unwrap().len(), 12);
        p[3].z = 0.5;
        let e = start_of(&rest, &p, "i").unwrap_err().to_string();
        assert!(e.starts_with("i: vertex 3 has z = 5e-1"), "{e}");
    }
}
