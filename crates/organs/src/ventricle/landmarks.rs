//! Landmarks of the enclosing surface S (ALGORITHMS 3.1): two points on the
//! basal rim (for the LV the anterior and inferior RV insertion points, for
//! the RV the two septal corners) and the apex.

use super::error::VentricleError;
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
    /// - [`VentricleError::NotADisk`] when S is not a disk (one connected
    ///   piece, one boundary loop, no handles; the message says which);
    /// - [`VentricleError::LandmarkNotFinite`] when a landmark is not
    ///   finite, [`VentricleError::LandmarkOffRim`] when a rim landmark lies
    ///   farther than `snap_mm` from every rim vertex;
    /// - [`VentricleError::SameRimVertex`] when both rim landmarks snap to
    ///   the same vertex, [`VentricleError::ApexOnRim`] when the apex snaps
    ///   to a rim vertex;
    /// - `Config` for a `snap_mm` that is not finite and `> 0`.
    pub fn resolve(
        surface: &TriMesh,
        anterior: &Point3<f64>,
        inferior: &Point3<f64>,
        apex: Option<&Point3<f64>>,
        snap_mm: f64,
    ) -> Result<Landmarks, OrganError> {
        OrganError::check_positive(&[("landmark snap distance (mm)", snap_mm)])?;
        let rim = disk_boundary_loop(surface).map_err(VentricleError::NotADisk)?;
        let finite = check_finite_landmark;
        let pos = &surface.positions;
        let nearest_on_rim =
            |landmark: &'static str, p: &Point3<f64>| -> Result<(usize, f64), VentricleError> {
                finite(landmark, p)?;
                let (k, d) = rim
                    .iter()
                    .enumerate()
                    .map(|(k, &v)| (k, (pos[v as usize] - p).norm()))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                    .ok_or(VentricleError::EmptyRim)?;
                if d > snap_mm {
                    return Err(VentricleError::LandmarkOffRim {
                        landmark,
                        point: [p.x, p.y, p.z],
                        distance_mm: d,
                        snap_mm,
                    });
                }
                Ok((k, d))
            };
        let (a, da) = nearest_on_rim("anterior", anterior)?;
        let (i, di) = nearest_on_rim("inferior", inferior)?;
        if a == i {
            return Err(VentricleError::SameRimVertex { vertex: rim[a] }.into());
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
                    .ok_or(VentricleError::NoVertex)?;
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
                    .ok_or(VentricleError::NoVertex)?;
                (v as u32, 0.0)
            }
        };
        if rim.contains(&apex) {
            return Err(VentricleError::ApexOnRim { apex }.into());
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
    /// [`VentricleError::RimTooShort`], [`VentricleError::RimVertexOutOfRange`],
    /// [`VentricleError::RimPositions`] or [`VentricleError::ApexInvalid`]
    /// for the first problem.
    pub fn check(&self, surface: &TriMesh) -> Result<(), VentricleError> {
        let n = surface.positions.len();
        let m = self.rim.len();
        if m < 3 {
            return Err(VentricleError::RimTooShort { rim: m });
        }
        if let Some(&vertex) = self.rim.iter().find(|&&v| v as usize >= n) {
            return Err(VentricleError::RimVertexOutOfRange {
                vertex,
                vertices: n,
            });
        }
        if self.anterior >= m || self.inferior >= m || self.anterior == self.inferior {
            return Err(VentricleError::RimPositions {
                anterior: self.anterior,
                inferior: self.inferior,
                rim: m,
            });
        }
        if self.apex as usize >= n || self.rim.contains(&self.apex) {
            return Err(VentricleError::ApexInvalid {
                apex: self.apex,
                vertices: n,
            });
        }
        Ok(())
    }
}

/// `Ok` when every coordinate of the landmark `p` is finite, else
/// [`VentricleError::LandmarkNotFinite`] naming it.
pub(crate) fn check_finite_landmark(
    landmark: &'static str,
    p: &Point3<f64>,
) -> Result<(), VentricleError> {
    if p.coords.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(VentricleError::LandmarkNotFinite {
            landmark,
            point: [p.x, p.y, p.z],
        })
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
        let err = |r: Result<Landmarks, OrganError>| match r {
            Err(e) => e,
            Ok(l) => panic!("expected an error, got {l:?}"),
        };
        let msg = |r: Result<Landmarks, OrganError>| err(r).to_string();
        // Off the boundary: the apex given as the anterior landmark.
        let r = Landmarks::resolve(s, &cup.apex, &cup.inferior, None, 5.0);
        assert!(
            matches!(
                r,
                Err(OrganError::Ventricle(VentricleError::LandmarkOffRim {
                    landmark: "anterior",
                    snap_mm: 5.0,
                    ..
                }))
            ),
            "{r:?}"
        );
        let m = msg(r);
        assert!(m.contains("anterior") && m.contains("basal rim"), "{m}");
        let r = Landmarks::resolve(s, &cup.anterior, &cup.anterior, None, 5.0);
        assert!(
            matches!(
                r,
                Err(OrganError::Ventricle(VentricleError::SameRimVertex { .. }))
            ),
            "{r:?}"
        );
        let m = msg(r);
        assert!(m.contains("same rim vertex"), "{m}");
        let nan = Point3::new(f64::NAN, 0.0, 0.0);
        let r = Landmarks::resolve(s, &cup.anterior, &nan, None, 5.0);
        assert!(
            matches!(
                r,
                Err(OrganError::Ventricle(VentricleError::LandmarkNotFinite {
                    landmark: "inferior",
                    ..
                }))
            ),
            "{r:?}"
        );
        let m = msg(r);
        assert!(m.contains("inferior") && m.contains("not finite"), "{m}");
        let r = Landmarks::resolve(s, &cup.anterior, &cup.inferior, Some(&cup.anterior), 5.0);
        assert!(
            matches!(
                r,
                Err(OrganError::Ventricle(VentricleError::ApexOnRim { .. }))
            ),
            "{r:?}"
        );
        let m = msg(r);
        assert!(m.contains("apex"), "{m}");
        let r = Landmarks::resolve(s, &cup.anterior, &cup.inferior, None, 0.0);
        assert!(matches!(r, Err(OrganError::Config(_))), "{r:?}");
        let m = msg(r);
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
        let e = err(Landmarks::resolve(
            &closed,
            &cup.anterior,
            &cup.inferior,
            None,
            5.0,
        ));
        assert!(
            matches!(e, OrganError::Ventricle(VentricleError::NotADisk(_))),
            "{e:?}"
        );
        let m = e.to_string();
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
            let e = l.check(s).unwrap_err();
            assert!(e.to_string().starts_with("landmarks: "), "{e}");
            assert!(
                crate::ventricle::disk::lv_disk(s, &l, &super::super::harmonic_disk::HarmonicDisk)
                    .is_err()
            );
            assert!(
                crate::ventricle::disk::rv_half_disk(
                    s,
                    &l,
                    &super::super::harmonic_disk::HarmonicDisk
                )
                .is_err()
            );
        }
    }
}
