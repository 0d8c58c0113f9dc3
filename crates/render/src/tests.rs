//! Tests of the renderer: coverage and fill rule, depth, cameras, shading,
//! colours, wireframes, 2D primitives, text, widgets, PNG, bad input.

use nalgebra::{Point3, Vector3};
use proptest::prelude::*;

use crate::raster::raster_triangle;
use crate::*;

const BG: Rgba = Rgba::new(10, 20, 30, 255);
const RED: Rgb = Rgb::new(220, 20, 20);
const BLUE: Rgb = Rgb::new(20, 40, 220);

fn count(img: &Image, c: Rgba) -> usize {
    img.as_bytes()
        .chunks_exact(4)
        .filter(|p| *p == [c.r, c.g, c.b, c.a])
        .count()
}

fn non_bg(img: &Image) -> usize {
    img.as_bytes()
        .chunks_exact(4)
        .filter(|p| *p != [BG.r, BG.g, BG.b, BG.a])
        .count()
}

/// An orthographic camera looking down -z for which world `(x, h - y, z)`
/// lands on pixel coordinates `(x, y)`; depth `10 - z` (larger z is nearer).
fn pixel_camera(w: u32, h: u32) -> Camera {
    let (cx, cy) = (f64::from(w) / 2.0, f64::from(h) / 2.0);
    Camera::orthographic(
        Point3::new(cx, cy, 10.0),
        Point3::new(cx, cy, 0.0),
        Vector3::y(),
        cy,
    )
    .unwrap()
}

/// The world point that `pixel_camera(_, h)` maps to pixel coordinates `(x, y)`.
fn pix(h: u32, x: f64, y: f64, z: f64) -> Point3<f64> {
    Point3::new(x, f64::from(h) - y, z)
}

/// Coverage counts of triangles given in pixel coordinates (fixed point).
fn coverage(w: u32, h: u32, tris: &[[[f64; 2]; 3]]) -> Vec<u32> {
    let mut counts = vec![0u32; (w * h) as usize];
    for t in tris {
        let v = t.map(|p| {
            [
                (p[0] * SUBPIXEL as f64).round() as i64,
                (p[1] * SUBPIXEL as f64).round() as i64,
            ]
        });
        raster_triangle(v, w, h, |x, y, l| {
            assert!((l[0] + l[1] + l[2] - 1.0).abs() < 1e-9);
            assert!(l.iter().all(|&b| b >= -1e-12));
            counts[y * w as usize + x] += 1;
        });
    }
    counts
}

/// A UV sphere of radius `r` about the origin.
fn sphere(nlat: usize, nlon: usize, r: f64) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
    use std::f64::consts::PI;
    let mut p = vec![Point3::new(0.0, 0.0, r)];
    for i in 1..nlat {
        let th = PI * i as f64 / nlat as f64;
        for j in 0..nlon {
            let ph = 2.0 * PI * j as f64 / nlon as f64;
            p.push(Point3::new(
                r * th.sin() * ph.cos(),
                r * th.sin() * ph.sin(),
                r * th.cos(),
            ));
        }
    }
    p.push(Point3::new(0.0, 0.0, -r));
    let south = (p.len() - 1) as u32;
    let ring = |i: usize, j: usize| (1 + (i - 1) * nlon + j % nlon) as u32;
    let mut t = Vec::new();
    for j in 0..nlon {
        t.push([0, ring(1, j), ring(1, j + 1)]);
        t.push([south, ring(nlat - 1, j + 1), ring(nlat - 1, j)]);
    }
    for i in 1..nlat - 1 {
        for j in 0..nlon {
            t.push([ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)]);
            t.push([ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)]);
        }
    }
    (p, t)
}

fn sphere_renderer(shading: Shading, coloring: Coloring<'_>, w: u32, h: u32) -> Renderer {
    let (p, t) = sphere(24, 48, 1.0);
    let cam = Camera::frame(
        &p,
        Vector3::new(-1.0, -0.5, -0.7),
        Vector3::z(),
        Lens::Orthographic,
        w,
        h,
        0.05,
    )
    .unwrap();
    let mut r = Renderer::new(w, h, BG, cam).unwrap();
    r.draw_mesh(&p, &t, coloring, shading).unwrap();
    r
}

// ---------------------------------------------------------------- coverage

#[test]
fn right_triangle_covers_exactly_its_area() {
    // Legs 20 and 10 px: area 100, and the hypotenuse x + 2y = 20 passes
    // through no pixel centre, so the count is exact.
    let c = coverage(32, 16, &[[[0.0, 0.0], [20.0, 0.0], [0.0, 10.0]]]);
    assert_eq!(c.iter().sum::<u32>(), 100);
    // The same through the public API.
    let (w, h) = (32, 16);
    let mut r = Renderer::new(w, h, BG, pixel_camera(w, h)).unwrap();
    let p = [
        pix(h, 0.0, 0.0, 0.0),
        pix(h, 20.0, 0.0, 0.0),
        pix(h, 0.0, 10.0, 0.0),
    ];
    let s = r
        .draw_mesh(&p, &[[0, 1, 2]], Coloring::Uniform(RED), Shading::Unlit)
        .unwrap();
    assert_eq!(s.pixels, 100);
    assert_eq!((s.drawn, s.culled), (1, 0));
    assert_eq!(count(r.image(), RED.opaque()), 100);
    // Row 0 holds columns 0..=18, row 9 column 0 only.
    assert_eq!(r.image().get(18, 0), Some(RED.opaque()));
    assert_eq!(r.image().get(19, 0), Some(BG));
    assert_eq!(r.image().get(0, 9), Some(RED.opaque()));
    assert_eq!(r.image().get(1, 9), Some(BG));
}

#[test]
fn square_split_on_its_diagonal_covers_each_pixel_once() {
    // The diagonal runs through 10 pixel centres: exactly one triangle
    // takes each of them (45 + 55).
    let a = coverage(16, 16, &[[[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]]]);
    let b = coverage(16, 16, &[[[0.0, 0.0], [10.0, 10.0], [0.0, 10.0]]]);
    let (na, nb) = (a.iter().sum::<u32>(), b.iter().sum::<u32>());
    assert_eq!(na + nb, 100);
    assert!((na, nb) == (45, 55) || (na, nb) == (55, 45), "{na} {nb}");
    for y in 0..16 {
        for x in 0..16 {
            let k = y * 16 + x;
            assert_eq!(a[k] + b[k], u32::from(x < 10 && y < 10), "pixel ({x}, {y})");
        }
    }
    // Public API with two colours: no gap, every pixel one of the two.
    let (w, h) = (16, 16);
    let mut r = Renderer::new(w, h, BG, pixel_camera(w, h)).unwrap();
    let p = [
        pix(h, 0.0, 0.0, 0.0),
        pix(h, 10.0, 0.0, 0.0),
        pix(h, 10.0, 10.0, 0.0),
        pix(h, 0.0, 10.0, 0.0),
    ];
    let tris = [[0, 1, 2], [0, 2, 3]];
    let s = r
        .draw_mesh(
            &p,
            &tris,
            Coloring::PerTriangle(&[RED, BLUE]),
            Shading::Unlit,
        )
        .unwrap();
    assert_eq!(s.pixels, 100, "no pixel written twice");
    assert_eq!(
        count(r.image(), RED.opaque()) + count(r.image(), BLUE.opaque()),
        100
    );
    assert_eq!(non_bg(r.image()), 100);
}

/// A jittered grid triangulation of `[0, n s] x [0, n s]` in pixel
/// coordinates; jitter in half pixels so that many vertices and edges pass
/// exactly through pixel centres.
fn jittered_grid(n: usize, s: f64, jitter: &[(i8, i8)], diag: &[bool]) -> Vec<[[f64; 2]; 3]> {
    let idx = |i: usize, j: usize| j * (n + 1) + i;
    let mut p = vec![[0.0; 2]; (n + 1) * (n + 1)];
    for j in 0..=n {
        for i in 0..=n {
            let (jx, jy) = jitter[idx(i, j) % jitter.len()];
            let mut x = i as f64 * s + 0.5 * f64::from(jx);
            let mut y = j as f64 * s + 0.5 * f64::from(jy);
            if i == 0 || i == n {
                x = i as f64 * s;
            }
            if j == 0 || j == n {
                y = j as f64 * s;
            }
            p[idx(i, j)] = [x, y];
        }
    }
    let mut tris = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (
                p[idx(i, j)],
                p[idx(i + 1, j)],
                p[idx(i + 1, j + 1)],
                p[idx(i, j + 1)],
            );
            if diag[(j * n + i) % diag.len()] {
                tris.push([a, b, c]);
                tris.push([a, c, d]);
            } else {
                tris.push([a, b, d]);
                tris.push([b, c, d]);
            }
        }
    }
    tris
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Any triangulation of a square covers each of its pixels exactly once,
    /// whichever winding each triangle has.
    #[test]
    fn triangulations_cover_each_pixel_exactly_once(
        jitter in prop::collection::vec((-3i8..=3, -3i8..=3), 49),
        diag in prop::collection::vec(any::<bool>(), 36),
        flip in prop::collection::vec(any::<bool>(), 72),
    ) {
        // 6 x 6 cells of 8 px: jitter up to 1.5 px keeps every cell convex.
        let mut tris = jittered_grid(6, 8.0, &jitter, &diag);
        for (t, &f) in tris.iter_mut().zip(&flip) {
            if f {
                t.swap(1, 2);
            }
        }
        let c = coverage(48, 48, &tris);
        for (k, &n) in c.iter().enumerate() {
            prop_assert_eq!(n, 1, "pixel ({}, {})", k % 48, k / 48);
        }
    }

    /// The pixel count of a triangle is its area up to its boundary pixels.
    #[test]
    fn triangle_count_is_close_to_area(
        pts in prop::array::uniform3((0.0f64..60.0, 0.0f64..60.0)),
    ) {
        let t = pts.map(|(x, y)| [x, y]);
        let area = 0.5 * ((t[1][0] - t[0][0]) * (t[2][1] - t[0][1]) - (t[1][1] - t[0][1]) * (t[2][0] - t[0][0])).abs();
        let len = |a: [f64; 2], b: [f64; 2]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
        let perimeter = len(t[0], t[1]) + len(t[1], t[2]) + len(t[2], t[0]);
        let n = f64::from(coverage(64, 64, &[t]).iter().sum::<u32>());
        prop_assert!((n - area).abs() <= 1.5 * perimeter + 4.0, "count {} area {} perimeter {}", n, area, perimeter);
    }
}

#[test]
fn degenerate_and_offscreen_triangles_cover_nothing() {
    assert_eq!(
        coverage(16, 16, &[[[1.0, 1.0], [5.0, 5.0], [9.0, 9.0]]])
            .iter()
            .sum::<u32>(),
        0
    );
    assert_eq!(
        coverage(16, 16, &[[[-30.0, -30.0], [-20.0, -30.0], [-20.0, -5.0]]])
            .iter()
            .sum::<u32>(),
        0
    );
    // Partly outside: clipped, the inside part drawn.
    let c = coverage(16, 16, &[[[-16.0, 0.0], [16.0, 0.0], [16.0, 32.0]]]);
    assert!(c.iter().sum::<u32>() > 50);
}

// ------------------------------------------------------------------ depth

#[test]
fn z_buffer_keeps_the_nearer_triangle_in_either_order() {
    let (w, h) = (32, 32);
    let far = [
        pix(h, 2.0, 2.0, 0.0),
        pix(h, 30.0, 2.0, 0.0),
        pix(h, 2.0, 30.0, 0.0),
    ];
    let near = [
        pix(h, 8.0, 8.0, 1.0),
        pix(h, 30.0, 8.0, 1.0),
        pix(h, 8.0, 30.0, 1.0),
    ];
    let mut p = far.to_vec();
    p.extend(near);
    let far_t = [[0u32, 1, 2]];
    let near_t = [[3u32, 4, 5]];
    let mut images = Vec::new();
    for near_first in [false, true] {
        let mut r = Renderer::new(w, h, BG, pixel_camera(w, h)).unwrap();
        let order: [(&[[u32; 3]], Rgb); 2] = if near_first {
            [(&near_t, BLUE), (&far_t, RED)]
        } else {
            [(&far_t, RED), (&near_t, BLUE)]
        };
        for (t, c) in order {
            r.draw_mesh(&p, t, Coloring::Uniform(c), Shading::Unlit)
                .unwrap();
        }
        // (5, 5): only the far triangle; (17, 17): only the near one
        // (centre sum 35 >= 32); (14, 14) and (17, 14) are in both: the near
        // one wins.
        assert_eq!(r.image().get(5, 5), Some(RED.opaque()));
        assert_eq!(r.image().get(17, 17), Some(BLUE.opaque()));
        assert_eq!(r.image().get(14, 14), Some(BLUE.opaque()));
        assert_eq!(r.image().get(17, 14), Some(BLUE.opaque()));
        assert!((r.depth_at(14, 14).unwrap() - 9.0).abs() < 1e-12);
        assert!((r.depth_at(5, 5).unwrap() - 10.0).abs() < 1e-12);
        assert_eq!(r.depth_at(31, 0), None);
        images.push(r.into_image());
    }
    assert_eq!(images[0], images[1]);
}

// ---------------------------------------------------------------- cameras

#[test]
fn orthographic_camera_maps_a_known_point() {
    let cam = Camera::orthographic(
        Point3::new(0.0, 0.0, 10.0),
        Point3::origin(),
        Vector3::y(),
        5.0,
    )
    .unwrap();
    // 5 px per unit; +x right, +y up.
    let q = cam.project(&Point3::new(1.0, 2.0, 0.0), 100, 50).unwrap();
    assert!(
        (q.x - 55.0).abs() < 1e-12 && (q.y - 15.0).abs() < 1e-12 && (q.depth - 10.0).abs() < 1e-12,
        "{q:?}"
    );
    assert_eq!(cam.forward(), -Vector3::z());
    assert_eq!(cam.right(), Vector3::x());
    assert_eq!(cam.up(), Vector3::y());
    // Behind the eye still projects (orthographic), with negative depth.
    let q = cam.project(&Point3::new(0.0, 0.0, 20.0), 100, 50).unwrap();
    assert!((q.x - 50.0).abs() < 1e-12 && (q.depth + 10.0).abs() < 1e-12);
    assert!(
        cam.project(&Point3::new(f64::NAN, 0.0, 0.0), 100, 50)
            .is_none()
    );
}

#[test]
fn perspective_makes_farther_objects_smaller() {
    let cam = Camera::perspective(
        Point3::origin(),
        Point3::new(0.0, 0.0, -1.0),
        Vector3::y(),
        60f64.to_radians(),
    )
    .unwrap();
    let (w, h) = (200, 200);
    let size = |z: f64| {
        let a = cam.project(&Point3::new(-0.5, 0.0, z), w, h).unwrap();
        let b = cam.project(&Point3::new(0.5, 0.0, z), w, h).unwrap();
        b.x - a.x
    };
    let (s5, s10) = (size(-5.0), size(-10.0));
    assert!((s5 / s10 - 2.0).abs() < 1e-12, "{s5} {s10}");
    // s = (h / 2) / tan(30 deg) px at depth 1.
    assert!((s5 - 100.0 / 30f64.to_radians().tan() / 5.0).abs() < 1e-9);
    // Behind the eye: not projected.
    assert!(cam.project(&Point3::new(0.0, 0.0, 1.0), w, h).is_none());
    // Rendered: a unit square at depth 10 covers a quarter of the pixels of
    // the same square at depth 5.
    let square = |z: f64| {
        let p = [
            Point3::new(-0.5, -0.5, z),
            Point3::new(0.5, -0.5, z),
            Point3::new(0.5, 0.5, z),
            Point3::new(-0.5, 0.5, z),
        ];
        let mut r = Renderer::new(w, h, BG, cam).unwrap();
        r.draw_mesh(
            &p,
            &[[0, 1, 2], [0, 2, 3]],
            Coloring::Uniform(RED),
            Shading::Flat,
        )
        .unwrap()
        .pixels as f64
    };
    // Side s / z px: 34.6 at depth 5, 17.3 at depth 10 (pixel counts 34^2
    // and 18^2 by where the sides fall between pixel centres).
    let (n5, n10) = (square(-5.0), square(-10.0));
    for (n, z) in [(n5, 5.0), (n10, 10.0)] {
        let side = 100.0 / 30f64.to_radians().tan() / z;
        assert!(
            (n - side * side).abs() <= 2.0 * side + 1.0,
            "{n} vs {}",
            side * side
        );
    }
    assert!(n5 > 3.0 * n10, "{n5} {n10}");
}

#[test]
fn framing_fits_the_points_with_the_margin() {
    let (p, _) = sphere(12, 24, 3.0);
    let p: Vec<_> = p
        .iter()
        .map(|q| q + Vector3::new(10.0, -4.0, 7.0))
        .collect();
    for lens in [
        Lens::Orthographic,
        Lens::Perspective {
            fovy: 40f64.to_radians(),
        },
    ] {
        for (w, h) in [(200u32, 100u32), (100, 200), (128, 128)] {
            let cam = Camera::frame(
                &p,
                Vector3::new(1.0, 2.0, -1.0),
                Vector3::z(),
                lens,
                w,
                h,
                0.1,
            )
            .unwrap();
            let qs: Vec<_> = p.iter().map(|q| cam.project(q, w, h).unwrap()).collect();
            let m = f64::from(w.min(h)) * 0.5 * (1.0 - 1.0 / 1.1) - 1e-6;
            assert!(
                qs.iter().all(|q| q.x >= m
                    && q.x <= f64::from(w) - m
                    && q.y >= m
                    && q.y <= f64::from(h) - m),
                "{lens:?} {w}x{h}"
            );
            assert!(qs.iter().all(|q| q.depth > 0.0));
            // It fills the panel: the extent along the smaller side is at
            // least 80 % of what is available (a sphere is round).
            let ext = if w <= h {
                qs.iter().map(|q| q.x).fold(f64::MIN, f64::max)
                    - qs.iter().map(|q| q.x).fold(f64::MAX, f64::min)
            } else {
                qs.iter().map(|q| q.y).fold(f64::MIN, f64::max)
                    - qs.iter().map(|q| q.y).fold(f64::MAX, f64::min)
            };
            assert!(
                ext > 0.8 * f64::from(w.min(h)) / 1.1,
                "{lens:?} {w}x{h}: {ext}"
            );
        }
    }
}

// ---------------------------------------------------------------- shading

#[test]
fn unlit_equals_the_input_colour_exactly() {
    let r = sphere_renderer(Shading::Unlit, Coloring::Uniform(RED), 120, 100);
    let n = non_bg(r.image());
    assert!(n > 2000);
    assert_eq!(count(r.image(), RED.opaque()), n);
}

#[test]
fn flat_and_smooth_shading_differ_on_a_sphere() {
    let flat = sphere_renderer(Shading::Flat, Coloring::Uniform(Rgb::WHITE), 120, 100);
    let smooth = sphere_renderer(Shading::Smooth, Coloring::Uniform(Rgb::WHITE), 120, 100);
    // Same silhouette, different shades.
    assert_eq!(non_bg(flat.image()), non_bg(smooth.image()));
    let differ = flat
        .image()
        .as_bytes()
        .chunks_exact(4)
        .zip(smooth.image().as_bytes().chunks_exact(4))
        .filter(|(a, b)| a != b)
        .count();
    assert!(differ > non_bg(flat.image()) / 2, "{differ}");
    // Flat shading has few distinct shades (one per visible face at most),
    // smooth shading many more.
    let distinct = |img: &Image| {
        let mut v: Vec<_> = img.as_bytes().chunks_exact(4).map(|p| p.to_vec()).collect();
        v.sort();
        v.dedup();
        v.len()
    };
    assert!(distinct(smooth.image()) > distinct(flat.image()));
    // The centre faces the camera: nearly full white in smooth shading; the
    // rim is darker (towards the ambient 30 %).
    let c = smooth.image().get(60, 50).unwrap();
    assert!(c.r >= 245, "{c:?}");
    let row: Vec<_> = (0..120)
        .filter_map(|x| smooth.image().get(x, 50).filter(|p| *p != BG))
        .collect();
    assert!(
        row[0].r < 170 && row[row.len() - 1].r < 170,
        "{:?} {:?}",
        row[0],
        row[row.len() - 1]
    );
    assert!(row.iter().all(|p| p.r >= 76));
}

#[test]
fn per_triangle_colours_are_constant_and_not_interpolated() {
    let (w, h) = (40, 40);
    let mut r = Renderer::new(w, h, BG, pixel_camera(w, h)).unwrap();
    let p = [
        pix(h, 5.0, 5.0, 0.0),
        pix(h, 35.0, 5.0, 0.0),
        pix(h, 35.0, 35.0, 0.0),
        pix(h, 5.0, 35.0, 0.0),
    ];
    let tris = [[0, 1, 2], [0, 2, 3]];
    r.draw_mesh(
        &p,
        &tris,
        Coloring::PerTriangle(&[RED, BLUE]),
        Shading::Unlit,
    )
    .unwrap();
    // Upper right triangle all red, lower left all blue, nothing else.
    for y in 5..35 {
        for x in 5..35 {
            let c = r.image().get(x, y).unwrap();
            if x > y {
                assert_eq!(c, RED.opaque(), "({x}, {y})");
            } else if x < y {
                assert_eq!(c, BLUE.opaque(), "({x}, {y})");
            }
        }
    }
    assert_eq!(non_bg(r.image()), 900);
    // Flat shading of a face seen head-on keeps the colour (k = 0.3 + 0.7).
    let mut r = Renderer::new(w, h, BG, pixel_camera(w, h)).unwrap();
    r.draw_mesh(
        &p,
        &tris,
        Coloring::PerTriangle(&[RED, BLUE]),
        Shading::Flat,
    )
    .unwrap();
    assert_eq!(
        count(r.image(), RED.opaque()) + count(r.image(), BLUE.opaque()),
        900
    );
}

#[test]
fn per_vertex_colours_interpolate_barycentrically() {
    let (w, h) = (64, 64);
    let mut r = Renderer::new(w, h, BG, pixel_camera(w, h)).unwrap();
    let p = [
        pix(h, 2.0, 2.0, 0.0),
        pix(h, 62.0, 2.0, 0.0),
        pix(h, 2.0, 62.0, 0.0),
    ];
    let cols = [
        Rgb::new(255, 0, 0),
        Rgb::new(0, 255, 0),
        Rgb::new(0, 0, 255),
    ];
    r.draw_mesh(&p, &[[0, 1, 2]], Coloring::PerVertex(&cols), Shading::Unlit)
        .unwrap();
    // At pixel centre (x + 0.5, y + 0.5): weights (1 - u - v, u, v) with
    // u = (x + 0.5 - 2) / 60, v = (y + 0.5 - 2) / 60.
    for (x, y) in [(2, 2), (21, 21), (50, 5), (5, 50), (30, 10)] {
        let (u, v) = ((x as f64 - 1.5) / 60.0, (y as f64 - 1.5) / 60.0);
        let c = r.image().get(x, y).unwrap();
        let want = [255.0 * (1.0 - u - v), 255.0 * u, 255.0 * v];
        for (got, want) in [c.r, c.g, c.b].iter().zip(want) {
            assert!(
                (f64::from(*got) - want).abs() <= 0.51,
                "({x}, {y}): {c:?} vs {want:?}"
            );
        }
    }
}

#[test]
fn per_vertex_colours_are_perspective_correct() {
    // A long quad on the floor, going away from the camera: black at the
    // near end, white at the far end. The 3D midpoint must get grey 128,
    // although it projects well above the middle of the quad's image.
    let cam = Camera::perspective(
        Point3::new(0.0, 1.0, 0.0),
        Point3::new(0.0, 0.0, -6.0),
        Vector3::y(),
        60f64.to_radians(),
    )
    .unwrap();
    let p = [
        Point3::new(-1.0, 0.0, -2.0),
        Point3::new(1.0, 0.0, -2.0),
        Point3::new(1.0, 0.0, -10.0),
        Point3::new(-1.0, 0.0, -10.0),
    ];
    let cols = [Rgb::BLACK, Rgb::BLACK, Rgb::WHITE, Rgb::WHITE];
    let (w, h) = (200, 200);
    let mut r = Renderer::new(w, h, BG, cam).unwrap();
    r.draw_mesh(
        &p,
        &[[0, 1, 2], [0, 2, 3]],
        Coloring::PerVertex(&cols),
        Shading::Unlit,
    )
    .unwrap();
    let mid = r.project(&Point3::new(0.0, 0.0, -6.0)).unwrap();
    let near = r.project(&Point3::new(0.0, 0.0, -2.0)).unwrap();
    let far = r.project(&Point3::new(0.0, 0.0, -10.0)).unwrap();
    assert!(
        (mid.y - 0.5 * (near.y + far.y)).abs() > 10.0,
        "the test needs a strong perspective"
    );
    let c = r
        .image()
        .get(mid.x.floor() as i64, mid.y.floor() as i64)
        .unwrap();
    assert!((i32::from(c.r) - 128).abs() <= 4, "{c:?}");
    // Depth is perspective-correct too: the view depth where the ray through
    // the pixel centre meets the floor y = 0.
    for (x, y) in [
        (mid.x.floor(), mid.y.floor()),
        (100.0, 120.0),
        (90.0, 150.0),
    ] {
        let z = r.depth_at(x as i64, y as i64).unwrap();
        let s = 100.0 / 30f64.to_radians().tan();
        let (a, b) = ((x + 0.5 - 100.0) / s, -(y + 0.5 - 100.0) / s);
        let dir = cam.forward() + cam.right() * a + cam.up() * b;
        let want = -cam.eye().y / dir.y;
        // Vertices are snapped to 1/256 px: a tiny relative error remains.
        assert!((z - want).abs() < 2e-4 * want, "({x}, {y}): {z} vs {want}");
    }
}

// -------------------------------------------------------------- wireframe

#[test]
fn wireframe_is_drawn_on_edges_and_hidden_behind_nearer_surfaces() {
    let (w, h) = (40, 40);
    let wire = Rgba::new(255, 255, 0, 255);
    let p = [
        pix(h, 4.0, 4.0, 0.0),
        pix(h, 36.0, 4.0, 0.0),
        pix(h, 36.0, 36.0, 0.0),
        pix(h, 4.0, 36.0, 0.0),
        // A nearer square over the lower half.
        pix(h, 0.0, 22.0, 1.0),
        pix(h, 40.0, 22.0, 1.0),
        pix(h, 40.0, 40.0, 1.0),
        pix(h, 0.0, 40.0, 1.0),
    ];
    let square = [[0, 1, 2], [0, 2, 3]];
    let cover = [[4, 5, 6], [4, 6, 7]];
    let mut r = Renderer::new(w, h, BG, pixel_camera(w, h)).unwrap();
    r.draw_mesh(&p, &square, Coloring::Uniform(RED), Shading::Unlit)
        .unwrap();
    let n = r.draw_wireframe(&p, &square, wire).unwrap();
    assert!(n > 4 * 30);
    // On the surface: the diagonal and the top edge are visible.
    for k in 5..35 {
        assert_eq!(r.image().get(k, k), Some(wire), "diagonal at {k}");
        assert_eq!(r.image().get(k, 4), Some(wire), "top edge at {k}");
    }
    assert_eq!(r.image().get(20, 10), Some(RED.opaque()));
    // Behind a nearer surface: hidden.
    let mut r = Renderer::new(w, h, BG, pixel_camera(w, h)).unwrap();
    r.draw_mesh(&p, &square, Coloring::Uniform(RED), Shading::Unlit)
        .unwrap();
    r.draw_mesh(&p, &cover, Coloring::Uniform(BLUE), Shading::Unlit)
        .unwrap();
    r.draw_wireframe(&p, &square, wire).unwrap();
    for k in 5..20 {
        assert_eq!(r.image().get(k, k), Some(wire), "visible diagonal at {k}");
    }
    for k in 23..35 {
        assert_eq!(
            r.image().get(k, k),
            Some(BLUE.opaque()),
            "hidden diagonal at {k}"
        );
        assert_eq!(
            r.image().get(4, k),
            Some(BLUE.opaque()),
            "hidden left edge at {k}"
        );
    }
    // With no surface drawn, every edge is visible.
    let mut r = Renderer::new(w, h, BG, pixel_camera(w, h)).unwrap();
    r.draw_wireframe(&p, &cover, wire).unwrap();
    assert_eq!(r.image().get(20, 22), Some(wire));
}

#[test]
fn polyline_3d_is_depth_tested() {
    let (w, h) = (40, 40);
    let mut r = Renderer::new(w, h, BG, pixel_camera(w, h)).unwrap();
    let p = [
        pix(h, 0.0, 0.0, 1.0),
        pix(h, 20.0, 0.0, 1.0),
        pix(h, 20.0, 40.0, 1.0),
        pix(h, 0.0, 40.0, 1.0),
    ];
    r.draw_mesh(
        &p,
        &[[0, 1, 2], [0, 2, 3]],
        Coloring::Uniform(BLUE),
        Shading::Unlit,
    )
    .unwrap();
    // A horizontal line at z = 0 (behind the left half) across the image.
    let line = [pix(h, 0.5, 10.5, 0.0), pix(h, 39.5, 10.5, 0.0)];
    let n = r.draw_polyline_3d(&line, false, Rgba::WHITE).unwrap();
    assert_eq!(n, 20);
    assert_eq!(r.image().get(10, 10), Some(BLUE.opaque()));
    assert_eq!(r.image().get(30, 10), Some(Rgba::WHITE));
}

// ------------------------------------------------------------- 2D drawing

#[test]
fn lines_draw_one_pixel_per_major_step() {
    let mut img = Image::new(20, 20, BG).unwrap();
    img.line([0.5, 5.5], [9.5, 5.5], Rgba::WHITE);
    assert_eq!(count(&img, Rgba::WHITE), 10);
    assert!((0..10).all(|x| img.get(x, 5) == Some(Rgba::WHITE)));
    let mut img = Image::new(20, 20, BG).unwrap();
    img.line([0.0, 0.0], [20.0, 10.0], Rgba::WHITE);
    assert_eq!(count(&img, Rgba::WHITE), 20);
    for x in 0..20 {
        let y = ((x as f64 + 0.5) / 2.0).floor() as i64;
        assert_eq!(img.get(x, y), Some(Rgba::WHITE), "column {x}");
    }
    // Steep: one per row; far outside: clipped quickly.
    let mut img = Image::new(20, 20, BG).unwrap();
    img.line([3.2, -1e12], [3.2, 1e12], Rgba::WHITE);
    assert_eq!(count(&img, Rgba::WHITE), 20);
    // Closed polyline of a rectangle: its outline.
    let mut img = Image::new(20, 20, BG).unwrap();
    img.polyline(
        &[[2.5, 2.5], [12.5, 2.5], [12.5, 7.5], [2.5, 7.5]],
        true,
        Rgba::WHITE,
    );
    assert_eq!(count(&img, Rgba::WHITE), 2 * 11 + 2 * 4);
}

#[test]
fn polygons_fill_by_pixel_centres_with_both_rules() {
    let mut img = Image::new(30, 30, BG).unwrap();
    img.fill_polygon(
        &[[2.0, 2.0], [12.0, 2.0], [12.0, 12.0], [2.0, 12.0]],
        FillRule::EvenOdd,
        Rgba::WHITE,
    );
    assert_eq!(count(&img, Rgba::WHITE), 100);
    assert_eq!(img.get(2, 2), Some(Rgba::WHITE));
    assert_eq!(img.get(12, 12), Some(BG));
    // A ring: outer square 20x20, inner 10x10 with the same orientation.
    let outer: &[[f64; 2]] = &[[0.0, 0.0], [20.0, 0.0], [20.0, 20.0], [0.0, 20.0]];
    let inner: &[[f64; 2]] = &[[5.0, 5.0], [15.0, 5.0], [15.0, 15.0], [5.0, 15.0]];
    let mut img = Image::new(30, 30, BG).unwrap();
    img.fill_rings(&[outer, inner], FillRule::EvenOdd, Rgba::WHITE);
    assert_eq!(count(&img, Rgba::WHITE), 300);
    let mut img = Image::new(30, 30, BG).unwrap();
    img.fill_rings(&[outer, inner], FillRule::NonZero, Rgba::WHITE);
    assert_eq!(count(&img, Rgba::WHITE), 400);
    let reversed: Vec<[f64; 2]> = inner.iter().rev().copied().collect();
    let mut img = Image::new(30, 30, BG).unwrap();
    img.fill_rings(&[outer, &reversed], FillRule::NonZero, Rgba::WHITE);
    assert_eq!(count(&img, Rgba::WHITE), 300);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Two polygons sharing a slanted edge tile their union exactly.
    #[test]
    fn polygons_sharing_an_edge_cover_each_pixel_once(a in 0.0f64..40.0, b in 0.0f64..40.0) {
        let left = [[0.0, 0.0], [a, 0.0], [b, 40.0], [0.0, 40.0]];
        let right = [[a, 0.0], [40.0, 0.0], [40.0, 40.0], [b, 40.0]];
        let mut i1 = Image::new(40, 40, BG).unwrap();
        i1.fill_polygon(&left, FillRule::EvenOdd, Rgba::WHITE);
        let mut i2 = Image::new(40, 40, BG).unwrap();
        i2.fill_polygon(&right, FillRule::NonZero, Rgba::WHITE);
        for y in 0..40 {
            for x in 0..40 {
                let n = usize::from(i1.get(x, y) == Some(Rgba::WHITE)) + usize::from(i2.get(x, y) == Some(Rgba::WHITE));
                prop_assert_eq!(n, 1, "pixel ({}, {})", x, y);
            }
        }
    }

    /// Arbitrary (including non-finite) coordinates never panic.
    #[test]
    fn primitives_never_panic(
        pts in prop::collection::vec(
            (prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(-1e300), -50.0f64..100.0],
             prop_oneof![Just(f64::NAN), Just(f64::NEG_INFINITY), Just(1e300), -50.0f64..100.0]),
            0..6),
        scale in 0u32..4,
        text in "[ -~]{0,6}",
    ) {
        let mut img = Image::new(32, 24, BG).unwrap();
        let p: Vec<[f64; 2]> = pts.iter().map(|&(x, y)| [x, y]).collect();
        img.polyline(&p, true, Rgba::WHITE);
        img.fill_polygon(&p, FillRule::NonZero, Rgba::WHITE);
        let q: Vec<Point3<f64>> = pts.iter().map(|&(x, y)| Point3::new(x, y, 0.5 * x)).collect();
        let tris: Vec<[u32; 3]> = (0..q.len().saturating_sub(2)).map(|k| [k as u32, k as u32 + 1, k as u32 + 2]).collect();
        let all_finite = q.iter().all(|v| v.coords.iter().all(|c| c.is_finite()));
        for cam in [pixel_camera(32, 24),
                    Camera::perspective(Point3::new(10.0, 10.0, 80.0), Point3::new(10.0, 10.0, 0.0), Vector3::y(), 1.0).unwrap()] {
            let mut r = Renderer::new(32, 24, BG, cam).unwrap();
            let res = r.draw_mesh(&q, &tris, Coloring::Uniform(RED), Shading::Smooth);
            prop_assert_eq!(res.is_ok(), all_finite || tris.is_empty());
            let res = r.draw_wireframe(&q, &tris, Rgba::WHITE);
            prop_assert_eq!(res.is_ok(), all_finite || tris.is_empty());
            prop_assert_eq!(r.draw_polyline_3d(&q, true, Rgba::WHITE).is_ok(), all_finite);
        }
        let res = img.draw_text(p.first().map_or(0, |v| v[0] as i32), 3, &text, scale, Rgba::WHITE, Anchor::Center);
        prop_assert_eq!(res.is_ok(), scale > 0);
    }
}

#[test]
fn annular_sectors_tile_a_bulls_eye() {
    // Six sectors of a ring, drawn into separate images: no pixel twice,
    // and together they cover about the ring's area.
    let c = [50.0, 50.0];
    let (r0, r1) = (20.0, 40.0);
    let mut covered = vec![0u32; 100 * 100];
    for k in 0..6 {
        let a0 = k as f64 * std::f64::consts::PI / 3.0;
        let poly = annular_sector(c, r0, r1, a0, a0 + std::f64::consts::PI / 3.0);
        assert!(poly.len() > 10);
        let mut img = Image::new(100, 100, BG).unwrap();
        img.fill_polygon(&poly, FillRule::EvenOdd, Rgba::WHITE);
        for (k, px) in img.as_bytes().chunks_exact(4).enumerate() {
            covered[k] += u32::from(px != [BG.r, BG.g, BG.b, BG.a]);
        }
    }
    // Neighbouring sectors share their radial edge exactly (same points),
    // but their arcs are separate polylines: allow no double coverage on
    // radial edges and near-exact area.
    assert!(covered.iter().all(|&n| n <= 1));
    let area = std::f64::consts::PI * (r1 * r1 - r0 * r0);
    let n = covered.iter().sum::<u32>() as f64;
    assert!((n - area).abs() < 0.01 * area, "{n} vs {area}");
    // Pie slice and degenerate input.
    assert_eq!(annular_sector(c, 0.0, 10.0, 0.0, 1.0).last(), Some(&c));
    assert!(annular_sector(c, 5.0, 2.0, 0.0, 1.0).is_empty());
    assert!(arc([f64::NAN, 0.0], 1.0, 0.0, 1.0).is_empty());
}

// -------------------------------------------------------------------- text

/// Every pixel of `img` that differs from [`BG`] lies inside `r`; returns
/// how many differ.
fn ink_inside(img: &Image, r: Rect) -> usize {
    let mut n = 0;
    for y in 0..i64::from(img.height()) {
        for x in 0..i64::from(img.width()) {
            if img.get(x, y) != Some(BG) {
                assert!(r.contains(x, y), "({x}, {y}) outside {r:?}");
                n += 1;
            }
        }
    }
    n
}

#[test]
fn text_draws_only_inside_its_measured_box() {
    for anchor in [Anchor::Left, Anchor::Center, Anchor::Right] {
        for scale in 1..=3 {
            let mut img = Image::new(200, 60, BG).unwrap();
            let text = "Hello, 1.5e3 [x] gjy";
            let r = img
                .draw_text(100, 10, text, scale, Rgba::WHITE, anchor)
                .unwrap();
            assert_eq!(r.width, text_width(text, scale));
            assert_eq!(r.height, text_height(scale));
            assert_eq!(r.height, 12 * scale);
            // Proportional: narrower than 20 em squares, wider than 5.
            assert!(r.width < 20 * 11 * scale && r.width > 5 * 11 * scale);
            let inside = ink_inside(&img, r);
            assert!(inside > 40 * (scale * scale) as usize);
            // The inside of the strokes reaches the ink colour.
            let darkest = (0..60)
                .flat_map(|y| (0..200).map(move |x| (x, y)))
                .filter_map(|(x, y)| img.get(x, y))
                .map(|p| p.b)
                .max();
            assert!(darkest >= Some(250), "{darkest:?}");
            let expect_x = match anchor {
                Anchor::Left => 100,
                Anchor::Center => 100 - (r.width / 2) as i32,
                Anchor::Right => 100 - r.width as i32,
            };
            assert_eq!(r.x, expect_x);
        }
    }
    // Empty text: an empty box, nothing drawn.
    let mut img = Image::new(20, 20, BG).unwrap();
    let r = img
        .draw_text(5, 5, "", 2, Rgba::WHITE, Anchor::Right)
        .unwrap();
    assert!(r.is_empty());
    assert_eq!(text_width("", 2), 0);
    assert_eq!(non_bg(&img), 0);
    // Scale 0 or above the maximum: an error.
    for bad in [0, MAX_TEXT_SCALE + 1] {
        assert!(matches!(
            img.draw_text(5, 5, "x", bad, Rgba::WHITE, Anchor::Left),
            Err(RenderError::InvalidArgument(_))
        ));
    }
}

#[test]
fn a_space_has_width_but_no_ink() {
    let mut img = Image::new(40, 20, BG).unwrap();
    let r = img
        .draw_text(2, 2, "   ", 1, Rgba::WHITE, Anchor::Left)
        .unwrap();
    assert!(r.width > 0);
    assert_eq!(r.width, text_width("   ", 1));
    assert_eq!(non_bg(&img), 0);
    // A space between two letters moves the second one right.
    assert!(text_width("a b", 1) > text_width("ab", 1));
}

#[test]
fn text_edges_are_anti_aliased_and_blended_over_the_background() {
    let mut img = Image::new(120, 30, BG).unwrap();
    img.draw_text(2, 2, "Wave (mm)", 2, Rgba::WHITE, Anchor::Left)
        .unwrap();
    let px: Vec<Rgba> = (0..30)
        .flat_map(|y| (0..120).map(move |x| (x, y)))
        .filter_map(|(x, y)| img.get(x, y))
        .collect();
    // Some pixels are strictly between the background and the ink, on the
    // segment from one to the other.
    let between: Vec<&Rgba> = px
        .iter()
        .filter(|p| **p != BG && **p != Rgba::WHITE)
        .collect();
    assert!(
        between.len() > 20,
        "{} partly covered pixels",
        between.len()
    );
    for p in between {
        assert!(p.r >= BG.r && p.g >= BG.g && p.b >= BG.b, "{p:?}");
        assert_eq!(p.a, 255);
        // Same opacity in every channel (within rounding).
        let t = |c: u8, b: u8| f64::from(c - b) / f64::from(255 - b);
        assert!((t(p.r, BG.r) - t(p.b, BG.b)).abs() < 0.02, "{p:?}");
    }
    // Half-transparent ink never reaches the full ink colour.
    let mut half = Image::new(120, 30, BG).unwrap();
    half.draw_text(
        2,
        2,
        "Wave (mm)",
        2,
        Rgba::new(255, 255, 255, 128),
        Anchor::Left,
    )
    .unwrap();
    assert_eq!(count(&half, Rgba::WHITE), 0);
    assert!(non_bg(&half) > 0);
}

#[test]
fn non_ascii_draws_the_fonts_glyph_else_a_replacement() {
    let draw = |t: &str| {
        let mut img = Image::new(40, 20, BG).unwrap();
        img.draw_text(2, 2, t, 1, Rgba::WHITE, Anchor::Left)
            .unwrap();
        img
    };
    // Noto Sans has these: each is its own glyph, not '?'.
    let q = draw("?");
    for t in ["é", "µ", "±", "°", "²", "α", "Ω"] {
        assert_ne!(draw(t), q, "{t}");
        assert!(non_bg(&draw(t)) > 0, "{t}");
        assert!(text_width(t, 1) > 0);
    }
    // It has no CJK nor emoji, and control characters are not drawn as
    // such: all of these become '?'.
    for t in ["\u{4e2d}", "\u{1f600}", "\t", "\u{7}"] {
        assert_eq!(draw(t), q, "{t:?}");
        assert_eq!(text_width(t, 1), text_width("?", 1));
    }
}

#[test]
fn text_is_deterministic() {
    let draw = || {
        let mut img = Image::new(160, 40, BG).unwrap();
        img.draw_text(
            80,
            3,
            "Thickness ± 0.5 mm, α = 2°",
            1,
            Rgba::WHITE,
            Anchor::Center,
        )
        .unwrap();
        img.draw_text(
            3,
            16,
            "AVAWAY fij",
            2,
            Rgba::new(200, 30, 30, 200),
            Anchor::Left,
        )
        .unwrap();
        img.to_png().unwrap()
    };
    assert_eq!(draw(), draw());
}

proptest! {
    /// The box `draw_text` returns is `text_width x text_height`, anchored
    /// as documented, and every pixel it writes lies inside it (and inside
    /// a clip rectangle when one is given).
    #[test]
    fn text_stays_in_its_box(
        text in "[ -~\u{e9}\u{b5}\u{b1}\u{b0}\u{3b1}-\u{3c9}\u{4e2d}]{0,12}",
        scale in 1u32..=4,
        x in -40i32..200,
        y in -30i32..60,
        anchor in prop_oneof![Just(Anchor::Left), Just(Anchor::Center), Just(Anchor::Right)],
        clip in proptest::option::of((0i32..80, 0i32..40, 0u32..100, 0u32..50)),
    ) {
        let mut img = Image::new(160, 60, BG).unwrap();
        let clip = clip.map(|(cx, cy, cw, ch)| Rect::new(cx, cy, cw, ch));
        let r = img.draw_text_clipped(x, y, &text, scale, Rgba::WHITE, anchor, clip).unwrap();
        let w = text_width(&text, scale);
        prop_assert_eq!(r.width, w);
        prop_assert_eq!(r.height, if text.is_empty() { 0 } else { text_height(scale) });
        prop_assert_eq!(r.y, y);
        let left = match anchor {
            Anchor::Left => x,
            Anchor::Center => x - (w / 2) as i32,
            Anchor::Right => x - w as i32,
        };
        prop_assert_eq!(r.x, left);
        for py in 0..60i64 {
            for px in 0..160i64 {
                if img.get(px, py) != Some(BG) {
                    prop_assert!(r.contains(px, py), "({}, {}) outside {:?}", px, py, r);
                    prop_assert!(clip.is_none_or(|c| c.contains(px, py)));
                }
            }
        }
    }

    /// One more character never makes a string narrower, and one more
    /// visible character makes it wider; widths grow with the scale.
    #[test]
    fn text_width_grows_with_characters_and_scale(
        text in "[ -~\u{b5}\u{3b1}]{0,10}",
        ch in "[!-~]",
        scale in 1u32..=8,
    ) {
        let longer = format!("{text}{ch}");
        prop_assert!(text_width(&longer, scale) > text_width(&text, scale));
        prop_assert!(text_width(&longer, scale + 1) >= text_width(&longer, scale));
        // Scale k text is about k times as wide as scale 1 text.
        let (w1, wk) = (f64::from(text_width(&longer, 1)), f64::from(text_width(&longer, scale)));
        prop_assert!((wk - f64::from(scale) * w1).abs() <= f64::from(scale));
    }
}

// ---------------------------------------------------------------- colours

#[test]
fn colour_bar_is_monotone_in_luminance_for_viridis() {
    let mut img = Image::new(120, 240, Rgba::WHITE).unwrap();
    let scale = ColorScale::new(Colormap::Viridis, 0.0, 2.5);
    let rect = Rect::new(10, 10, 90, 220);
    draw_colorbar(&mut img, rect, &scale, "J", Rgba::BLACK, 1).unwrap();
    // The bar's middle column, bottom to top, inside the outline.
    let x = 10 + 30 / 2;
    let col: Vec<Rgb> = (0..240)
        .rev()
        .filter_map(|y| img.get(x, y))
        .map(|c| c.rgb())
        .filter(|c| *c != Rgb::WHITE && *c != Rgb::BLACK)
        .collect();
    assert!(col.len() > 180, "{}", col.len());
    assert_eq!(col[0], Colormap::Viridis.eval(0.0));
    assert_eq!(col[col.len() - 1], Colormap::Viridis.eval(1.0));
    // Monotone up to the rounding of colorous's 8-bit colours: two rows
    // a fraction of a step apart may differ by one unit in a channel.
    for w in col.windows(2) {
        assert!(
            w[1].luminance() >= w[0].luminance() - 3.0 / 255.0,
            "{:?}",
            w
        );
    }
    assert!(col[col.len() - 1].luminance() > col[0].luminance() + 0.5);
    // Nothing outside the rectangle; labels drawn (black pixels right of the bar).
    for y in 0..240 {
        for x in 0..120 {
            if !rect.contains(x, y) {
                assert_eq!(img.get(x, y), Some(Rgba::WHITE));
            }
        }
    }
    let label_ink = (50..100)
        .flat_map(|x| (10..230).map(move |y| (x, y)))
        .filter(|&(x, y)| img.get(x, y).is_some_and(|c| c.rgb().luminance() < 0.5))
        .count();
    assert!(label_ink > 30, "{label_ink}");
    // Too small: an error, nothing drawn.
    let mut small = Image::new(50, 50, Rgba::WHITE).unwrap();
    assert!(
        draw_colorbar(
            &mut small,
            Rect::new(0, 0, 10, 20),
            &scale,
            "t",
            Rgba::BLACK,
            1
        )
        .is_err()
    );
    assert!(draw_colorbar(&mut small, rect, &scale, "t", Rgba::BLACK, 0).is_err());
}

#[test]
fn categorical_colours_are_distinct_and_wrap() {
    for map in [Colormap::Tableau10, Colormap::Category10] {
        assert!(map.is_categorical());
        let c: Vec<Rgb> = (0..10).map(|i| map.label(i)).collect();
        for i in 0..10 {
            for j in 0..i {
                assert_ne!(c[i], c[j], "{map:?} {i} {j}");
            }
            assert_eq!(map.label(i + 10), c[i]);
            // eval steps through the same colours.
            assert_eq!(map.eval((i as f64 + 0.5) / 10.0), c[i]);
        }
        assert_eq!(map.eval(1.0), c[9]);
    }
    assert!(!Colormap::Viridis.is_categorical());
    assert_ne!(Colormap::Viridis.label(0), Colormap::Viridis.label(1));
}

#[test]
fn colour_scales_clamp_and_grey_out_nan() {
    let s = ColorScale::new(Colormap::Viridis, 1.0, 3.0);
    assert_eq!(s.color(1.0), Colormap::Viridis.eval(0.0));
    assert_eq!(s.color(-100.0), Colormap::Viridis.eval(0.0));
    assert_eq!(s.color(f64::INFINITY), Colormap::Viridis.eval(1.0));
    assert_eq!(s.color(2.0), Colormap::Viridis.eval(0.5));
    assert_eq!(s.color(f64::NAN), NAN_COLOR);
    assert_eq!(
        ColorScale::new(Colormap::Viridis, f64::NAN, 1.0).color(0.5),
        NAN_COLOR
    );
    assert_eq!(
        ColorScale::new(Colormap::Viridis, 2.0, 2.0).position(7.0),
        Some(0.5)
    );
    // Diverging: blue low, near-white middle, red high.
    let d = ColorScale::symmetric(Colormap::BlueRed, &[-0.5, 2.0, f64::NAN]);
    assert_eq!((d.lo, d.hi), (-2.0, 2.0));
    let (lo, mid, hi) = (d.color(-2.0), d.color(0.0), d.color(2.0));
    assert!(lo.b > lo.r + 50 && hi.r > hi.b + 50, "{lo:?} {hi:?}");
    assert!(mid.r > 230 && mid.g > 230 && mid.b > 230, "{mid:?}");
    let f = ColorScale::from_values(Colormap::Magma, &[3.0, f64::NAN, -1.0, 2.0]);
    assert_eq!((f.lo, f.hi), (-1.0, 3.0));
    assert_eq!(ColorScale::from_values(Colormap::Magma, &[]).hi, 1.0);
    assert_eq!(
        s.colors(&[1.0, f64::NAN]),
        vec![Colormap::Viridis.eval(0.0), NAN_COLOR]
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn viridis_luminance_increases_along_the_scale(a in -10.0f64..10.0, b in -10.0f64..10.0) {
        let s = ColorScale::new(Colormap::Viridis, -5.0, 5.0);
        let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
        prop_assert!(s.color(hi).luminance() >= s.color(lo).luminance() - 1e-12);
    }
}

#[test]
fn values_format_short() {
    assert_eq!(format_value(0.0), "0");
    assert_eq!(format_value(0.5), "0.5");
    assert_eq!(format_value(1.0), "1");
    assert_eq!(format_value(12.345), "12.3");
    assert_eq!(format_value(-4.56789), "-4.57");
    assert_eq!(format_value(100.0), "100");
    assert_eq!(format_value(1234.6), "1235");
    assert_eq!(format_value(123456.0), "1.23e5");
    assert_eq!(format_value(0.001234), "1.23e-3");
    assert_eq!(format_value(f64::NAN), "nan");
    assert_eq!(format_value(-0.0001), "-1.00e-4");
}

// -------------------------------------------------------------- histogram

#[test]
fn histogram_counts_and_draws() {
    let mut img = Image::new(200, 120, Rgba::WHITE).unwrap();
    let values = [0.0, 0.1, 0.2, 0.3, 0.9, 1.0, 1.0, 5.0, f64::NAN, -1.0];
    let style = HistogramStyle::default();
    let rect = Rect::new(5, 5, 190, 110);
    let hist = draw_histogram(
        &mut img,
        rect,
        &values,
        4,
        Some((0.0, 1.0)),
        "area distortion",
        &style,
    )
    .unwrap();
    // Bins of 0.25: [0, 0.1, 0.2, -1 clamped], [0.3], [], [0.9, 1, 1, 5 clamped].
    assert_eq!(hist.counts, vec![4, 1, 0, 4]);
    assert_eq!((hist.clamped, hist.ignored), (2, 1));
    // Bars of the two full bins are as tall as each other; the empty bin
    // has none.
    let bar = style.bar.opaque();
    let column = |x: i64| (0..120).filter(|&y| img.get(x, y) == Some(bar)).count();
    let plot_w = 190 - 2;
    let centre = |k: i64| 7 + (2 * k + 1) * plot_w / 8;
    assert!(column(centre(0)) > 40);
    assert_eq!(column(centre(0)), column(centre(3)));
    assert!((column(centre(1)) as f64 - column(centre(0)) as f64 / 4.0).abs() <= 1.0);
    assert_eq!(column(centre(2)), 0);
    for y in 0..120 {
        for x in 0..200 {
            if !rect.contains(x, y) {
                assert_eq!(img.get(x, y), Some(Rgba::WHITE));
            }
        }
    }
    // Automatic range; coloured bars; errors.
    let h = draw_histogram(&mut img, rect, &[2.0, 2.0], 3, None, "", &style).unwrap();
    assert_eq!((h.lo, h.hi, h.counts.iter().sum::<usize>()), (1.5, 2.5, 2));
    let styled = HistogramStyle {
        scale: Some(ColorScale::new(Colormap::Viridis, 0.0, 1.0)),
        ..style
    };
    let mut img2 = Image::new(200, 120, Rgba::WHITE).unwrap();
    draw_histogram(&mut img2, rect, &values, 4, Some((0.0, 1.0)), "", &styled).unwrap();
    assert!(count(&img2, Colormap::Viridis.eval(0.125).opaque()) > 100);
    assert!(draw_histogram(&mut img, rect, &values, 0, None, "", &style).is_err());
    assert!(draw_histogram(&mut img, rect, &values, 3, Some((1.0, 0.0)), "", &style).is_err());
    assert!(
        draw_histogram(
            &mut img,
            Rect::new(0, 0, 12, 12),
            &values,
            3,
            None,
            "",
            &style
        )
        .is_err()
    );
    assert!(draw_histogram(&mut img, rect, &[], 3, None, "empty", &style).is_ok());
}

// --------------------------------------------------------- images and PNG

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    #[test]
    fn png_round_trip_keeps_every_pixel(w in 1u32..20, h in 1u32..20, seed: u64) {
        let mut img = Image::new(w, h, Rgba::TRANSPARENT).unwrap();
        let mut s = seed;
        for y in 0..h {
            for x in 0..w {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let b = (s >> 32).to_le_bytes();
                img.put(i64::from(x), i64::from(y), Rgba::new(b[0], b[1], b[2], b[3]));
            }
        }
        let png = img.to_png().unwrap();
        prop_assert_eq!(Image::from_png(&png).unwrap(), img);
    }
}

#[test]
fn same_scene_gives_identical_png_bytes() {
    let render = || {
        let (p, t) = sphere(16, 32, 1.0);
        let values: Vec<f64> = p.iter().map(|q| q.z).collect();
        let cols = ColorScale::from_values(Colormap::Viridis, &values).colors(&values);
        let cam = Camera::frame(
            &p,
            Vector3::new(1.0, 1.0, -1.0),
            Vector3::z(),
            Lens::Perspective { fovy: 0.6 },
            160,
            120,
            0.1,
        )
        .unwrap();
        let mut r = Renderer::new(160, 120, Rgba::WHITE, cam).unwrap();
        r.draw_mesh(&p, &t, Coloring::PerVertex(&cols), Shading::Smooth)
            .unwrap();
        r.draw_wireframe(&p, &t, Rgba::BLACK).unwrap();
        r.image_mut()
            .draw_text(80, 2, "sphere", 1, Rgba::BLACK, Anchor::Center)
            .unwrap();
        r.into_image().to_png().unwrap()
    };
    let (a, b) = (render(), render());
    assert_eq!(a, b);
    assert!(Image::from_png(&a).is_ok());
}

#[test]
fn blit_composes_panels_with_clipping() {
    let mut fig = Image::new(10, 10, BG).unwrap();
    let panel = Image::new(4, 3, Rgba::WHITE).unwrap();
    fig.blit(&panel, 2, 1);
    assert_eq!(count(&fig, Rgba::WHITE), 12);
    assert_eq!(fig.get(2, 1), Some(Rgba::WHITE));
    assert_eq!(fig.get(5, 3), Some(Rgba::WHITE));
    assert_eq!(fig.get(6, 3), Some(BG));
    let red = Image::new(4, 4, RED.opaque()).unwrap();
    fig.blit(&red, -2, 8);
    assert_eq!(count(&fig, RED.opaque()), 4);
    fig.blit(&red, 100, -100);
    fig.blit(&red, i64::MIN / 2, 0);
    assert_eq!(count(&fig, RED.opaque()), 4);
}

// --------------------------------------------------------------- bad input

#[test]
fn bad_input_gives_errors_not_panics() {
    assert!(matches!(
        Image::new(0, 5, BG),
        Err(RenderError::InvalidSize { .. })
    ));
    assert!(matches!(
        Image::new(5, MAX_SIDE + 1, BG),
        Err(RenderError::InvalidSize { .. })
    ));
    assert!(Image::from_png(b"not a png").is_err());
    assert!(Image::from_png(&[]).is_err());
    let o = Point3::origin();
    assert!(Camera::orthographic(o, o, Vector3::y(), 1.0).is_err());
    assert!(Camera::orthographic(Point3::new(0.0, 0.0, 1.0), o, Vector3::z(), 1.0).is_err());
    assert!(Camera::orthographic(Point3::new(0.0, 0.0, 1.0), o, Vector3::y(), 0.0).is_err());
    assert!(Camera::orthographic(Point3::new(0.0, 0.0, 1.0), o, Vector3::zeros(), 1.0).is_err());
    assert!(Camera::perspective(Point3::new(0.0, 0.0, 1.0), o, Vector3::y(), 4.0).is_err());
    assert!(Camera::perspective(Point3::new(f64::NAN, 0.0, 1.0), o, Vector3::y(), 1.0).is_err());
    assert!(matches!(
        Camera::frame(
            &[],
            Vector3::z(),
            Vector3::y(),
            Lens::Orthographic,
            10,
            10,
            0.1
        ),
        Err(RenderError::Empty(_))
    ));
    let pts = [o, Point3::new(f64::NAN, 0.0, 0.0)];
    assert!(matches!(
        Camera::frame(
            &pts,
            Vector3::z(),
            Vector3::y(),
            Lens::Orthographic,
            10,
            10,
            0.1
        ),
        Err(RenderError::NonFinite { index: 1, .. })
    ));
    assert!(
        Camera::frame(
            &pts[..1],
            Vector3::z(),
            Vector3::y(),
            Lens::Orthographic,
            0,
            10,
            0.1
        )
        .is_err()
    );
    assert!(
        Camera::frame(
            &pts[..1],
            Vector3::z(),
            Vector3::y(),
            Lens::Orthographic,
            10,
            10,
            -1.0
        )
        .is_err()
    );
    // A single point still frames.
    assert!(
        Camera::frame(
            &pts[..1],
            Vector3::z(),
            Vector3::y(),
            Lens::Perspective { fovy: 1.0 },
            10,
            10,
            0.1
        )
        .is_ok()
    );

    let (w, h) = (16, 16);
    let mut r = Renderer::new(w, h, BG, pixel_camera(w, h)).unwrap();
    assert!(Renderer::new(0, 16, BG, pixel_camera(w, h)).is_err());
    let p = [
        pix(h, 1.0, 1.0, 0.0),
        pix(h, 9.0, 1.0, 0.0),
        pix(h, 1.0, 9.0, 0.0),
        Point3::new(f64::NAN, 0.0, 0.0),
    ];
    let c = Coloring::Uniform(RED);
    assert_eq!(
        r.draw_mesh(&p, &[[0, 1, 7]], c, Shading::Flat),
        Err(RenderError::IndexOutOfRange {
            triangle: 0,
            index: 7,
            vertex_count: 4
        })
    );
    assert_eq!(
        r.draw_mesh(&p, &[[0, 1, 2], [0, 1, 3]], c, Shading::Flat),
        Err(RenderError::NonFinite {
            what: "vertex",
            index: 3
        })
    );
    // Unused non-finite vertices are fine.
    assert!(r.draw_mesh(&p, &[[0, 1, 2]], c, Shading::Smooth).is_ok());
    assert!(matches!(
        r.draw_mesh(
            &p,
            &[[0, 1, 2]],
            Coloring::PerVertex(&[RED]),
            Shading::Unlit
        ),
        Err(RenderError::LengthMismatch {
            expected: 4,
            got: 1,
            ..
        })
    ));
    assert!(matches!(
        r.draw_mesh(&p, &[[0, 1, 2]], Coloring::PerTriangle(&[]), Shading::Unlit),
        Err(RenderError::LengthMismatch {
            expected: 1,
            got: 0,
            ..
        })
    ));
    assert!(r.draw_wireframe(&p, &[[0, 1, 9]], Rgba::WHITE).is_err());
    assert!(r.draw_polyline_3d(&p, false, Rgba::WHITE).is_err());
    // An error leaves the image as it was.
    let before = r.image().clone();
    assert!(
        r.draw_mesh(
            &p,
            &[[0, 1, 2], [0, 1, 3]],
            Coloring::Uniform(BLUE),
            Shading::Flat
        )
        .is_err()
    );
    assert_eq!(r.image(), &before);
    // Empty meshes draw nothing.
    assert_eq!(
        r.draw_mesh(&[], &[], c, Shading::Flat),
        Ok(DrawStats::default())
    );
    // NaN / degenerate 2D input: no-ops.
    let mut img = Image::new(8, 8, BG).unwrap();
    img.line([f64::NAN, 0.0], [4.0, 4.0], Rgba::WHITE);
    img.fill_polygon(
        &[[0.0, 0.0], [f64::INFINITY, 0.0], [4.0, 4.0]],
        FillRule::EvenOdd,
        Rgba::WHITE,
    );
    img.fill_polygon(&[[0.0, 0.0], [4.0, 0.0]], FillRule::EvenOdd, Rgba::WHITE);
    img.polyline(&[], false, Rgba::WHITE);
    assert_eq!(non_bg(&img), 0);
    assert!(!img.put(8, 0, Rgba::WHITE));
    assert_eq!(img.get(-1, 0), None);
}

#[test]
fn perspective_culls_triangles_behind_the_eye() {
    let cam = Camera::perspective(
        Point3::origin(),
        Point3::new(0.0, 0.0, -1.0),
        Vector3::y(),
        1.0,
    )
    .unwrap();
    let mut r = Renderer::new(32, 32, BG, cam).unwrap();
    let p = [
        Point3::new(-1.0, -1.0, -3.0),
        Point3::new(1.0, -1.0, -3.0),
        Point3::new(0.0, 1.0, 2.0),
    ];
    let s = r
        .draw_mesh(&p, &[[0, 1, 2]], Coloring::Uniform(RED), Shading::Flat)
        .unwrap();
    assert_eq!((s.drawn, s.culled, s.pixels), (0, 1, 0));
    assert_eq!(non_bg(r.image()), 0);
}
