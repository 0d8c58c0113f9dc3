//! The mesh while it is being repaired: current elements over current
//! vertices, each vertex remembering the input vertex it stands for and each
//! element the input element (cell-data row) it came from. Every step only
//! renumbers, drops or copies vertices, so a vertex's position and point
//! data are always those of its input vertex.

use crate::Fields;
use nalgebra::Point3;

/// Elements with `K` corners over vertices traced back to the input.
#[derive(Debug, Clone)]
pub(crate) struct Work<const K: usize> {
    /// Current vertex positions.
    pub positions: Vec<Point3<f64>>,
    /// `origin[v]`: the input vertex that current vertex `v` stands for.
    pub origin: Vec<usize>,
    /// Current elements.
    pub elements: Vec<[u32; K]>,
    /// `rows[e]`: the input element whose cell data element `e` takes.
    pub rows: Vec<usize>,
    /// `current[i]`: the current vertex input vertex `i` became (`u32::MAX`
    /// once dropped; the first copy when it was split).
    pub current: Vec<u32>,
}

impl<const K: usize> Work<K> {
    /// The input mesh, untouched.
    pub fn new(positions: &[Point3<f64>], elements: &[[u32; K]]) -> Self {
        Work {
            positions: positions.to_vec(),
            origin: (0..positions.len()).collect(),
            elements: elements.to_vec(),
            rows: (0..elements.len()).collect(),
            current: (0..positions.len() as u32).collect(),
        }
    }

    /// Keeps the elements for which `keep(e)` holds; returns how many were
    /// dropped.
    pub fn retain(&mut self, mut keep: impl FnMut(usize) -> bool) -> usize {
        let before = self.elements.len();
        let (mut elements, mut rows) = (Vec::with_capacity(before), Vec::with_capacity(before));
        for (e, (el, row)) in self.elements.iter().zip(&self.rows).enumerate() {
            if keep(e) {
                elements.push(*el);
                rows.push(*row);
            }
        }
        self.elements = elements;
        self.rows = rows;
        before - self.elements.len()
    }

    /// Merges vertices: `root[v]` is the vertex `v` becomes (roots are their
    /// own root). The roots are kept in index order, with their positions.
    /// Returns how many vertices were merged away.
    pub fn merge(&mut self, root: &[usize]) -> usize {
        let n = self.positions.len();
        let mut number = vec![u32::MAX; n];
        let mut kept = Vec::new();
        for v in 0..n {
            if root[v] == v {
                number[v] = kept.len() as u32;
                kept.push(v);
            }
        }
        for el in &mut self.elements {
            *el = el.map(|v| number[root[v as usize]]);
        }
        for c in &mut self.current {
            if *c != u32::MAX {
                *c = number[root[*c as usize]];
            }
        }
        self.positions = kept.iter().map(|&v| self.positions[v]).collect();
        self.origin = kept.iter().map(|&v| self.origin[v]).collect();
        n - kept.len()
    }

    /// Drops the vertices no element uses (order kept); returns how many.
    pub fn drop_unreferenced(&mut self) -> usize {
        let n = self.positions.len();
        let mut used = vec![false; n];
        for el in &self.elements {
            for &v in el {
                used[v as usize] = true;
            }
        }
        let kept: Vec<usize> = (0..n).filter(|&v| used[v]).collect();
        let mut number = vec![u32::MAX; n];
        for (k, &v) in kept.iter().enumerate() {
            number[v] = k as u32;
        }
        for el in &mut self.elements {
            *el = el.map(|v| number[v as usize]);
        }
        for c in &mut self.current {
            if *c != u32::MAX {
                *c = number[*c as usize];
            }
        }
        self.positions = kept.iter().map(|&v| self.positions[v]).collect();
        self.origin = kept.iter().map(|&v| self.origin[v]).collect();
        n - kept.len()
    }

    /// The mean length of the element edges (0 without elements).
    pub fn mean_edge(&self) -> f64 {
        let (mut sum, mut count) = (0.0, 0usize);
        for el in &self.elements {
            for i in 0..K {
                for j in i + 1..K {
                    sum += (self.positions[el[i] as usize] - self.positions[el[j] as usize]).norm();
                    count += 1;
                }
            }
        }
        if count == 0 { 0.0 } else { sum / count as f64 }
    }

    /// Where each input vertex went (`None`: dropped).
    pub fn vertex_of_input(&self) -> Vec<Option<u32>> {
        self.current
            .iter()
            .map(|&c| (c != u32::MAX).then_some(c))
            .collect()
    }

    /// The point data and cell data of the current vertices and elements,
    /// selected from the input's.
    pub fn fields(&self, point_data: &Fields, cell_data: &Fields) -> (Fields, Fields) {
        (
            point_data.select(&self.origin),
            cell_data.select(&self.rows),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merge_retain_and_drop_keep_origins() {
        let p: Vec<Point3<f64>> = (0..5).map(|i| Point3::new(i as f64, 0.0, 0.0)).collect();
        let mut w = Work::new(&p, &[[0u32, 1, 2], [2, 3, 4], [1, 3, 4]]);
        assert_eq!(w.merge(&[0, 1, 2, 1, 4]), 1);
        assert_eq!(w.elements, vec![[0, 1, 2], [2, 1, 3], [1, 1, 3]]);
        assert_eq!(w.origin, vec![0, 1, 2, 4]);
        assert_eq!(w.retain(|e| e != 2), 1);
        assert_eq!(w.rows, vec![0, 1]);
        w.elements = vec![[0, 1, 3]];
        w.rows = vec![1];
        assert_eq!(w.drop_unreferenced(), 1);
        assert_eq!(w.origin, vec![0, 1, 4]);
        assert_eq!(w.positions[2].x, 4.0);
        assert_eq!(w.elements, vec![[0, 1, 2]]);
        assert_eq!(w.current, vec![0, 1, u32::MAX, 1, 2]);
    }
}
