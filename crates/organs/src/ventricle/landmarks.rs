//! Landmarks of the enclosing surface S (ALGORITHMS 3.1): two points on the
//! basal rim (for the LV the anterior and inferior RV insertion points, for
//! the RV the two septal corners) and the apex.

use crate::OrganError;
use unfold_mesh::TriMesh;
use unfold_mesh::nalgebra::Point3;
use unfold_param::initializer::disk_boundary_loop;

/// Default largest distance, mm, from a given rim landmark to the rim
/// vertex it snaps to.
pub const DEFAULT_SNAP_MM: f64 = 5.0;

/// The landmarks as vertices of S, and S's boundary loop.
#[derive(Debug, Clone, PartialEq)]
pub struct Landmarks {
    /// The boundary loop of S (the basal rim), in the direction of its
    /// boundary half-edges.
    pub rim: Vec<u32>,
    /// Position in `rim` of the first rim landmark: the anterior RV
    /// insertion point (LV), or the first septal corner (RV).
    pub anterior: usize,
    /// Position in `rim` of the second rim landmark: the inferior RV
    /// insertion point (LV), or the second septal corner (RV).
    pub inferior: usize,
    /// The apex vertex of S.
    pub apex: u32,
    /// Distances, mm, from the given points to the vertices they snapped to
    /// (`[anterior, inferior, apex]`; 0 for a computed apex).
    pub snap_distances_mm: [f64; 3],
}

impl Landmarks {
    /// Snaps the two rim landmarks to their nearest rim vertices and the
    /// apex (when given) to its nearest vertex of S; without an apex, the
    /// vertex of S farthest from the rim's centroid (vertex average).
    ///
    /// # Errors
    /// - `Input` when S is not a disk (one connected piece, one boundary
    ///   loop, no handles; the message says which);
    /// - `Input` when a landmark is not finite, or a rim landmark lies
    ///   farther than `snap_mm` from every rim vertex ("off the boundary");
    /// - `Input` when both rim landmarks snap to the same vertex, or the
    ///   apex snaps to a rim vertex;
    /// - `Config` for a `snap_mm` that is not finite and `> 0`.
    pub fn resolve(
        surface: &TriMesh,
        anterior: &Point3<f64>,
        inferior: &Point3<f64>,
        apex: Option<&Point3<f64>>,
        snap_mm: f64,
    ) -> Result<Landmarks, OrganError> {
        OrganError::check_positive(&[("landmark snap distance (mm)", snap_mm)])?;
        let rim = disk_boundary_loop(surface).map_err(|e| {
            OrganError::Input(format!("the enclosing surface S is not a disk: {e}"))
        })?;
        let finite = |what: &str, p: &Point3<f64>| {
            if p.coords.iter().all(|x| x.is_finite()) {
                Ok(())
            } else {
                Err(OrganError::Input(format!(
                    "the {what} landmark is not finite: {p:?}"
                )))
            }
        };
        let pos = &surface.positions;
        let nearest_on_rim = |what: &str, p: &Point3<f64>| -> Result<(usize, f64), OrganError> {
            finite(what, p)?;
            let (k, d) = rim
                .iter()
                .enumerate()
                .map(|(k, &v)| (k, (pos[v as usize] - p).norm()))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .ok_or_else(|| OrganError::Input("S has an empty boundary loop".into()))?;
            if d > snap_mm {
                return Err(OrganError::Input(format!(
                    "the {what} landmark {:?} is {d:.3} mm from the nearest vertex of S's \
                     boundary loop (more than {snap_mm} mm): it must lie on the basal rim",
                    [p.x, p.y, p.z]
                )));
            }
            Ok((k, d))
        };
        let (a, da) = nearest_on_rim("anterior", anterior)?;
        let (i, di) = nearest_on_rim("inferior", inferior)?;
        if a == i {
            return Err(OrganError::Input(format!(
                "the anterior and inferior landmarks snap to the same rim vertex {}",
                rim[a]
            )));
        }
        let mut used = vec![false; pos.len()];
        for t in &surface.triangles {
            for &v in t {
                used[v as usize] = true;
            }
        }
        let (apex, dx) = match apex {
            Some(p) => {
                finite("apex", p)?;
                let (v, d) = (0..pos.len())
                    .filter(|&v| used[v])
                    .map(|v| (v, (pos[v] - p).norm()))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                    .ok_or_else(|| OrganError::Input("S has no vertex".into()))?;
                (v as u32, d)
            }
            None => {
                let c = rim
                    .iter()
                    .fold(Point3::origin(), |acc, &v| acc + pos[v as usize].coords)
                    / rim.len() as f64;
                let (v, _) = (0..pos.len())
                    .filter(|&v| used[v])
                    .map(|v| (v, (pos[v] - c).norm()))
                    .max_by(|a, b| a.1.total_cmp(&b.1))
                    .ok_or_else(|| OrganError::Input("S has no vertex".into()))?;
                (v as u32, 0.0)
            }
        };
        if rim.contains(&apex) {
            return Err(OrganError::Input(format!(
                "the apex is the rim vertex {apex}: it must be inside S, away from the basal rim"
            )));
        }
        Ok(Landmarks {
            rim,
            anterior: a,
            inferior: i,
            apex,
            snap_distances_mm: [da, di, dx],
        })
    }
}

impl Landmarks {
    /// Checks that these landmarks fit `surface` (for landmarks built by
    /// hand rather than by [`Landmarks::resolve`]): rim vertices and apex in
    /// range, at least 3 rim vertices, the two rim positions in range and
    /// distinct, the apex not on the rim.
    ///
    /// # Errors
    /// `Input` naming the first problem.
    pub fn check(&self, surface: &TriMesh) -> Result<(), OrganError> {
        let n = surface.positions.len();
        let bad = |m: String| Err(OrganError::Input(format!("landmarks: {m}")));
        if self.rim.len() < 3 {
            return bad(format!("a rim of {} vertices", self.rim.len()));
        }
        if let Some(v) = self.rim.iter().find(|&&v| v as usize >= n) {
            return bad(format!("rim vertex {v} out of range ({n} vertices)"));
        }
        let m = self.rim.len();
        if self.anterior >= m || self.inferior >= m || self.anterior == self.inferior {
            return bad(format!(
                "rim positions {} and {} for a rim of {m} vertices (two distinct ones needed)",
                self.anterior, self.inferior
            ));
        }
        if self.apex as usize >= n || self.rim.contains(&self.apex) {
            return bad(format!("apex {} out of range or on the rim", self.apex));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use unfold_mesh::shapes::{VentricleParams, ventricle_cup};

    #[test]
    fn the_cup_landmarks_snap_exactly_and_the_apex_is_found() {
        let cup = ventricle_cup(&VentricleParams::default()).unwrap();
        let l = Landmarks::resolve(
            &cup.surface,
            &cup.anterior,
            &cup.inferior,
            None,
            DEFAULT_SNAP_MM,
        )
        .unwrap();
        let pos = &cup.surface.positions;
        assert_eq!(pos[l.rim[l.anterior] as usize], cup.anterior);
        assert_eq!(pos[l.rim[l.inferior] as usize], cup.inferior);
        assert_eq!(pos[l.apex as usize], cup.apex);
        assert_eq!(l.snap_distances_mm, [0.0, 0.0, 0.0]);
        // A given apex near the true one snaps to it.
        let near = cup.apex + unfold_mesh::nalgebra::Vector3::new(0.3, -0.2, 0.1);
        let g = Landmarks::resolve(
            &cup.surface,
            &cup.anterior,
            &cup.inferior,
            Some(&near),
            DEFAULT_SNAP_MM,
        )
        .unwrap();
        assert_eq!(g.apex, l.apex);
        assert!((g.snap_distances_mm[2] - (near - cup.apex).norm()).abs() < 1e-12);
    }

    #[test]
    fn bad_landmarks_are_refused_with_a_clear_error() {
        let cup = ventricle_cup(&VentricleParams::default()).unwrap();
        let s = &cup.surface;
        let msg = |r: Result<Landmarks, OrganError>| match r {
            Err(e) => e.to_string(),
            Ok(l) => panic!("expected an error, got {l:?}"),
        };
        // Off the boundary: the apex given as the anterior landmark.
        let m = msg(Landmarks::resolve(s, &cup.apex, &cup.inferior, None, 5.0));
        assert!(m.contains("anterior") && m.contains("basal rim"), "{m}");
        let m = msg(Landmarks::resolve(
            s,
            &cup.anterior,
            &cup.anterior,
            None,
            5.0,
        ));
        assert!(m.contains("same rim vertex"), "{m}");
        let nan = Point3::new(f64::NAN, 0.0, 0.0);
        let m = msg(Landmarks::resolve(s, &cup.anterior, &nan, None, 5.0));
        assert!(m.contains("inferior") && m.contains("not finite"), "{m}");
        let m = msg(Landmarks::resolve(
            s,
            &cup.anterior,
            &cup.inferior,
            Some(&cup.anterior),
            5.0,
        ));
        assert!(m.contains("apex"), "{m}");
        let m = msg(Landmarks::resolve(
            s,
            &cup.anterior,
            &cup.inferior,
            None,
            0.0,
        ));
        assert!(m.contains("snap"), "{m}");
        // Not a disk: the cup closed by a fan over its rim.
        let mut closed = s.clone();
        let c = closed.positions.len() as u32;
        let centre = cup.rim.iter().fold(Point3::origin(), |acc, &v| {
            acc + closed.positions[v as usize].coords
        }) / cup.rim.len() as f64;
        closed.positions.push(centre);
        for k in 0..cup.rim.len() {
            let (a, b) = (cup.rim[k], cup.rim[(k + 1) % cup.rim.len()]);
            closed.triangles.push([a, b, c]);
        }
        let m = msg(Landmarks::resolve(
            &closed,
            &cup.anterior,
            &cup.inferior,
            None,
            5.0,
        ));
        assert!(m.contains("not a disk"), "{m}");
    }

    #[test]
    fn hand_made_landmarks_are_checked() {
        let cup = ventricle_cup(&VentricleParams::default()).unwrap();
        let s = &cup.surface;
        let good = Landmarks::resolve(s, &cup.anterior, &cup.inferior, None, 5.0).unwrap();
        assert!(good.check(s).is_ok());
        let n = good.rim.len();
        for l in [
            Landmarks {
                anterior: n,
                ..good.clone()
            },
            Landmarks {
                inferior: good.anterior,
                ..good.clone()
            },
            Landmarks {
                apex: good.rim[0],
                ..good.clone()
            },
            Landmarks {
                apex: u32::MAX,
                ..good.clone()
            },
            Landmarks {
                rim: vec![0, 1],
                ..good.clone()
            },
        ] {
            assert!(matches!(l.check(s), Err(OrganError::Input(_))), "{l:?}");
            assert!(crate::ventricle::disk::lv_disk(s, &l).is_err());
            assert!(crate::ventricle::disk::rv_half_disk(s, &l).is_err());
        }
    }
}
