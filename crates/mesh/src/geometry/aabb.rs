//! Axis-aligned bounding boxes.

use nalgebra::{Point3, Vector3};

/// An axis-aligned bounding box `[min, max]` (closed). The empty box has
/// `min = +inf`, `max = -inf`, so that growing it by a point gives that point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Point3<f64>,
    /// Largest corner.
    pub max: Point3<f64>,
}

impl Default for Aabb {
    fn default() -> Self {
        Aabb::empty()
    }
}

impl Aabb {
    /// The empty box (`min = +inf`, `max = -inf`): contains nothing, is the
    /// identity of [`Aabb::union`].
    pub fn empty() -> Self {
        Aabb {
            min: Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY),
            max: Point3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY),
        }
    }

    /// Smallest box holding all points: `min_a = min_i p_i,a`,
    /// `max_a = max_i p_i,a`; empty for no points. NaN coordinates are ignored.
    pub fn from_points(points: &[Point3<f64>]) -> Self {
        let mut b = Aabb::empty();
        for p in points {
            b.grow(p);
        }
        b
    }

    /// Whether the box holds no point (`min_a > max_a` on some axis).
    pub fn is_empty(&self) -> bool {
        !(0..3).all(|a| self.min[a] <= self.max[a])
    }

    /// Enlarges the box to hold `p` (NaN coordinates are ignored).
    pub fn grow(&mut self, p: &Point3<f64>) {
        for a in 0..3 {
            self.min[a] = self.min[a].min(p[a]);
            self.max[a] = self.max[a].max(p[a]);
        }
    }

    /// Smallest box holding both boxes.
    pub fn union(&self, other: &Aabb) -> Aabb {
        let mut b = *self;
        for a in 0..3 {
            b.min[a] = b.min[a].min(other.min[a]);
            b.max[a] = b.max[a].max(other.max[a]);
        }
        b
    }

    /// The box grown by `r >= 0` on every side: `[min - r, max + r]`.
    pub fn padded(&self, r: f64) -> Aabb {
        let d = Vector3::repeat(r);
        Aabb {
            min: self.min - d,
            max: self.max + d,
        }
    }

    /// Side lengths `max - min`; zero for the empty box.
    pub fn extent(&self) -> Vector3<f64> {
        if self.is_empty() {
            Vector3::zeros()
        } else {
            self.max - self.min
        }
    }

    /// Centre `(min + max) / 2` (NaN for the empty box).
    pub fn center(&self) -> Point3<f64> {
        Point3::from((self.min.coords + self.max.coords) * 0.5)
    }

    /// Whether `min <= p <= max` on every axis (boundary included).
    #[inline]
    pub fn contains(&self, p: &Point3<f64>) -> bool {
        (0..3).all(|a| self.min[a] <= p[a] && p[a] <= self.max[a])
    }

    /// Squared Euclidean distance from `p` to the box,
    /// `sum_a max(min_a - p_a, 0, p_a - max_a)^2`; 0 inside, `+inf` for the
    /// empty box.
    #[inline]
    pub fn distance_squared(&self, p: &Point3<f64>) -> f64 {
        let mut d2 = 0.0;
        for a in 0..3 {
            let d = (self.min[a] - p[a]).max(p[a] - self.max[a]).max(0.0);
            d2 += d * d;
        }
        d2
    }

    /// Index (0, 1, 2) of the longest side.
    pub fn longest_axis(&self) -> usize {
        self.extent().imax()
    }
}

/// Bounding box of the points, `None` when there is no (non-NaN) point.
pub fn bounding_box(points: &[Point3<f64>]) -> Option<Aabb> {
    let b = Aabb::from_points(points);
    (!b.is_empty()).then_some(b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn aabb_basics() {
        let e = Aabb::empty();
        assert!(e.is_empty());
        assert_eq!(e.extent(), Vector3::zeros());
        assert_eq!(e.distance_squared(&Point3::origin()), f64::INFINITY);
        assert!(!e.contains(&Point3::origin()));
        assert_eq!(bounding_box(&[]), None);
        let pts = [Point3::new(1.0, -1.0, 2.0), Point3::new(-1.0, 3.0, 2.5)];
        let b = bounding_box(&pts).unwrap();
        assert_eq!(b.min, Point3::new(-1.0, -1.0, 2.0));
        assert_eq!(b.max, Point3::new(1.0, 3.0, 2.5));
        assert_eq!(b.extent(), Vector3::new(2.0, 4.0, 0.5));
        assert_eq!(b.center(), Point3::new(0.0, 1.0, 2.25));
        assert_eq!(b.longest_axis(), 1);
        assert!(b.contains(&pts[0]) && b.contains(&b.center()));
        assert!(!b.contains(&Point3::new(0.0, 0.0, 3.0)));
        assert_eq!(b.distance_squared(&Point3::new(0.0, 0.0, 2.1)), 0.0);
        assert_relative_eq!(b.distance_squared(&Point3::new(2.0, 5.0, 2.0)), 5.0);
        assert_eq!(e.union(&b), b);
        let mut g = b;
        g.grow(&Point3::new(0.0, 0.0, 10.0));
        assert_eq!(g.max.z, 10.0);
        assert_eq!(
            b.union(&Aabb::from_points(&[Point3::new(0.0, 0.0, 10.0)])),
            g
        );
        assert_eq!(Aabb::from_points(&pts), b);
        assert!(b.padded(1.0).contains(&Point3::new(2.0, 4.0, 3.5)));
    }
}
