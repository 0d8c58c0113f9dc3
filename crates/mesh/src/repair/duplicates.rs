//! Duplicate elements: two elements with the same vertex set, in any order
//! and either orientation (a triangle stored twice, once reversed, or the
//! same tet written twice). The first is kept, with its cell data.

use super::work::Work;
use std::collections::HashSet;

/// Drops every element whose sorted vertex set equals an earlier one's;
/// returns how many.
pub(crate) fn drop_duplicates<const K: usize>(w: &mut Work<K>) -> usize {
    let mut seen = HashSet::with_capacity(w.elements.len());
    let dup: Vec<bool> = w
        .elements
        .iter()
        .map(|el| {
            let mut key = *el;
            key.sort_unstable();
            !seen.insert(key)
        })
        .collect();
    w.retain(|e| !dup[e])
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    #[test]
    fn the_first_copy_is_kept_in_any_order() {
        let p = vec![Point3::origin(); 5];
        let mut w = Work::new(&p, &[[0u32, 1, 2], [2, 1, 0], [1, 2, 3], [1, 2, 0]]);
        assert_eq!(drop_duplicates(&mut w), 2);
        assert_eq!(w.rows, vec![0, 2]);
        assert_eq!(drop_duplicates(&mut w), 0);
        let mut t = Work::new(&p, &[[0u32, 1, 2, 3], [3, 2, 1, 0], [0, 1, 2, 4]]);
        assert_eq!(drop_duplicates(&mut t), 1);
        assert_eq!(t.rows, vec![0, 2]);
    }
}
