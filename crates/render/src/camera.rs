//! Orthographic and perspective cameras, and framing a point set.

use nalgebra::{Point3, Vector3};

use crate::RenderError;

/// How a camera projects the view space onto the image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Projection {
    /// Parallel projection; `half_height` is half the world-space height of
    /// the view (the image height maps to `2 half_height`).
    Orthographic {
        /// Half the height of the view in world units, `> 0`.
        half_height: f64,
    },
    /// Pinhole projection; `fovy` is the vertical field of view in radians,
    /// in (0, pi).
    Perspective {
        /// Vertical field of view in radians.
        fovy: f64,
    },
}

/// The kind of camera [`Camera::frame`] builds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Lens {
    /// An orthographic camera (the view extent is chosen by framing).
    Orthographic,
    /// A perspective camera with this vertical field of view in radians.
    Perspective {
        /// Vertical field of view in radians, in (0, pi).
        fovy: f64,
    },
}

/// A point projected to the image: pixel coordinates (x right, y down,
/// pixel `(i, j)` centred at `(i + 0.5, j + 0.5)`) and view depth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projected {
    /// Column coordinate in pixels.
    pub x: f64,
    /// Row coordinate in pixels.
    pub y: f64,
    /// Distance from the eye along the view direction, `(p - eye) . f`.
    pub depth: f64,
}

/// A camera looking from `eye` at `target` with `up` pointing up in the
/// image.
///
/// View frame: forward `f = (target - eye) / |target - eye|`, right
/// `r = (f x up) / |f x up|`, image up `u = r x f`. A point `p` has view
/// coordinates `x_v = (p - eye) . r`, `y_v = (p - eye) . u`,
/// `z_v = (p - eye) . f` (the depth). For a `w x h` image:
///
/// - orthographic: `s = (h / 2) / half_height`,
///   `x = w / 2 + s x_v`, `y = h / 2 - s y_v`;
/// - perspective: `s = (h / 2) / tan(fovy / 2)`,
///   `x = w / 2 + s x_v / z_v`, `y = h / 2 - s y_v / z_v`, defined for
///   `z_v > near` with `near = 10^-3 |target - eye|`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    eye: Point3<f64>,
    target: Point3<f64>,
    projection: Projection,
    forward: Vector3<f64>,
    right: Vector3<f64>,
    up: Vector3<f64>,
    near: f64,
}

impl Camera {
    /// An orthographic camera showing `2 half_height` world units
    /// vertically.
    ///
    /// Errors ([`RenderError::InvalidCamera`]) for non-finite input,
    /// `eye == target`, `up` zero or parallel to the view direction, or
    /// `half_height <= 0`.
    pub fn orthographic(
        eye: Point3<f64>,
        target: Point3<f64>,
        up: Vector3<f64>,
        half_height: f64,
    ) -> Result<Self, RenderError> {
        Self::new(eye, target, up, Projection::Orthographic { half_height })
    }

    /// A perspective camera with vertical field of view `fovy` (radians).
    ///
    /// Errors as [`Camera::orthographic`], and for `fovy` outside (0, pi).
    pub fn perspective(
        eye: Point3<f64>,
        target: Point3<f64>,
        up: Vector3<f64>,
        fovy: f64,
    ) -> Result<Self, RenderError> {
        Self::new(eye, target, up, Projection::Perspective { fovy })
    }

    /// A camera with the given projection; see [`Camera::orthographic`] and
    /// [`Camera::perspective`] for the errors.
    pub fn new(
        eye: Point3<f64>,
        target: Point3<f64>,
        up: Vector3<f64>,
        projection: Projection,
    ) -> Result<Self, RenderError> {
        let bad = |m: &str| Err(RenderError::InvalidCamera(m.to_string()));
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !finite(eye.coords.as_slice())
            || !finite(target.coords.as_slice())
            || !finite(up.as_slice())
        {
            return bad("non-finite eye, target or up");
        }
        match projection {
            Projection::Orthographic { half_height }
                if !(half_height.is_finite() && half_height > 0.0) =>
            {
                return bad("orthographic half height must be finite and > 0");
            }
            Projection::Perspective { fovy } if !(fovy > 0.0 && fovy < std::f64::consts::PI) => {
                return bad("perspective field of view must be in (0, pi) radians");
            }
            _ => {}
        }
        let d = target - eye;
        let dist = d.norm();
        if !(dist > 0.0 && dist.is_finite()) {
            return bad("eye and target coincide");
        }
        let forward = d / dist;
        let up_n = up.norm();
        if up_n.is_nan() || up_n <= 0.0 {
            return bad("up vector is zero");
        }
        let r = forward.cross(&(up / up_n));
        let rn = r.norm();
        if rn.is_nan() || rn <= 1e-9 {
            return bad("up vector is parallel to the view direction");
        }
        let right = r / rn;
        let up = right.cross(&forward);
        Ok(Self {
            eye,
            target,
            projection,
            forward,
            right,
            up,
            near: 1e-3 * dist,
        })
    }

    /// Frames `points` seen along `view_dir` so that they fill a
    /// `width x height` image with a relative `margin` on each side.
    ///
    /// Bounding sphere: centre `c` = the middle of the axis-aligned bounding
    /// box, radius `R = max |p - c|` (at least `10^-9 max(1, |c|)` so a single
    /// point still gives a camera). The extent to show is `R' = R (1 + margin)`
    /// across the smaller image side, so framing does not depend on the view
    /// direction (all views of one mesh share the scale):
    ///
    /// - orthographic: `half_height = R' max(1, h / w)`, eye at `c - 2 R f`;
    /// - perspective: with `alpha = min(fovy, fovx) / 2`, the eye at distance
    ///   `R' / sin(alpha)` from `c`.
    ///
    /// Errors: [`RenderError::Empty`] without points,
    /// [`RenderError::NonFinite`] for a non-finite point, invalid size,
    /// negative or non-finite `margin`, and the [`Camera::new`] errors (for
    /// instance `up` parallel to `view_dir`).
    #[allow(clippy::too_many_arguments)]
    pub fn frame(
        points: &[Point3<f64>],
        view_dir: Vector3<f64>,
        up: Vector3<f64>,
        lens: Lens,
        width: u32,
        height: u32,
        margin: f64,
    ) -> Result<Self, RenderError> {
        crate::image::check_size(width, height)?;
        if !(margin.is_finite() && margin >= 0.0) {
            return Err(RenderError::InvalidArgument(format!(
                "margin {margin} must be finite and >= 0"
            )));
        }
        let (c, radius) = bounding_sphere(points)?;
        let n = view_dir.norm();
        if !(n > 0.0 && n.is_finite()) {
            return Err(RenderError::InvalidCamera(
                "view direction is zero or not finite".into(),
            ));
        }
        let f = view_dir / n;
        let extent = radius * (1.0 + margin);
        let (w, h) = (f64::from(width), f64::from(height));
        match lens {
            Lens::Orthographic => {
                let half_height = extent * (h / w).max(1.0);
                Self::orthographic(c - f * (2.0 * radius), c, up, half_height)
            }
            Lens::Perspective { fovy } => {
                if !(fovy > 0.0 && fovy < std::f64::consts::PI) {
                    return Err(RenderError::InvalidCamera(
                        "perspective field of view must be in (0, pi) radians".into(),
                    ));
                }
                let fovx = 2.0 * ((fovy / 2.0).tan() * w / h).atan();
                let alpha = 0.5 * fovy.min(fovx);
                let dist = extent / alpha.sin();
                Self::perspective(c - f * dist, c, up, fovy)
            }
        }
    }

    /// The eye position.
    pub fn eye(&self) -> Point3<f64> {
        self.eye
    }

    /// The target (the point imaged at the centre).
    pub fn target(&self) -> Point3<f64> {
        self.target
    }

    /// The projection.
    pub fn projection(&self) -> Projection {
        self.projection
    }

    /// The unit view direction `f` (from the eye towards the target).
    pub fn forward(&self) -> Vector3<f64> {
        self.forward
    }

    /// The unit right vector `r` of the image.
    pub fn right(&self) -> Vector3<f64> {
        self.right
    }

    /// The unit up vector `u` of the image (orthogonal to `f` and `r`).
    pub fn up(&self) -> Vector3<f64> {
        self.up
    }

    /// The near distance: perspective cameras only project points with
    /// depth `> near` (`10^-3 |target - eye|`); orthographic ones ignore it.
    pub fn near(&self) -> f64 {
        self.near
    }

    /// Whether the camera is a perspective one.
    pub fn is_perspective(&self) -> bool {
        matches!(self.projection, Projection::Perspective { .. })
    }

    /// Projects `p` into a `width x height` image (formulas in the type's
    /// documentation). `None` for a non-finite point, and for perspective
    /// cameras when `depth <= near`. The pixel coordinates may lie outside
    /// the image.
    pub fn project(&self, p: &Point3<f64>, width: u32, height: u32) -> Option<Projected> {
        let d = p - self.eye;
        let (xv, yv, zv) = (d.dot(&self.right), d.dot(&self.up), d.dot(&self.forward));
        if !(xv.is_finite() && yv.is_finite() && zv.is_finite()) {
            return None;
        }
        let (w, h) = (f64::from(width), f64::from(height));
        let (x, y) = match self.projection {
            Projection::Orthographic { half_height } => {
                let s = 0.5 * h / half_height;
                (0.5 * w + s * xv, 0.5 * h - s * yv)
            }
            Projection::Perspective { fovy } => {
                if zv <= self.near {
                    return None;
                }
                let s = 0.5 * h / (0.5 * fovy).tan();
                (0.5 * w + s * xv / zv, 0.5 * h - s * yv / zv)
            }
        };
        Some(Projected { x, y, depth: zv })
    }
}

/// Centre of the bounding box of `points` and the largest distance from it.
fn bounding_sphere(points: &[Point3<f64>]) -> Result<(Point3<f64>, f64), RenderError> {
    if points.is_empty() {
        return Err(RenderError::Empty("no points to frame"));
    }
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for (i, p) in points.iter().enumerate() {
        if !p.coords.iter().all(|x| x.is_finite()) {
            return Err(RenderError::NonFinite {
                what: "point",
                index: i,
            });
        }
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    let c = Point3::from((lo + hi) * 0.5);
    let r = points.iter().map(|p| (p - c).norm()).fold(0.0f64, f64::max);
    let r = r.max(1e-9 * c.coords.norm().max(1.0));
    Ok((c, r))
}
