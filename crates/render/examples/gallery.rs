//! Renders a few example figures with unfold-render and times a large mesh.
//!
//! ```sh
//! cargo run --release -p unfold-render --example gallery -- /tmp/render_examples
//! ```
//!
//! Writes `sphere.png` (a sphere coloured by height, perspective, smooth
//! shading, with a colour bar, a histogram and a title), `disk_map.png` (a
//! flat disk map, unlit, with its wireframe, a u = 0 marker and a scale bar),
//! `bullseye.png` (17 AHA segments as filled annular sectors with numbers)
//! and `shading.png` (unlit / flat / smooth / per-cell labels side by side).

use std::f64::consts::{PI, TAU};
use std::time::Instant;

use unfold_render::nalgebra::{Point3, Vector3};
use unfold_render::{
    Anchor, Camera, ColorScale, Coloring, Colormap, FillRule, HistogramStyle, Image, Lens, Rect,
    RenderError, Renderer, Rgb, Rgba, Shading, annular_sector, arc, draw_colorbar, draw_histogram,
};

type Mesh = (Vec<Point3<f64>>, Vec<[u32; 3]>);

/// A UV sphere of radius `r`.
fn sphere(nlat: usize, nlon: usize, r: f64) -> Mesh {
    let mut p = vec![Point3::new(0.0, 0.0, r)];
    for i in 1..nlat {
        let th = PI * i as f64 / nlat as f64;
        for j in 0..nlon {
            let ph = TAU * j as f64 / nlon as f64;
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

/// A disk of radius `r` in the plane z = 0: `rings` rings of `seg` vertices.
fn disk(rings: usize, seg: usize, r: f64) -> Mesh {
    let mut p = vec![Point3::origin()];
    for i in 1..=rings {
        let rr = r * i as f64 / rings as f64;
        for j in 0..seg {
            let a = TAU * (j as f64 + 0.5 * (i % 2) as f64) / seg as f64;
            p.push(Point3::new(rr * a.cos(), rr * a.sin(), 0.0));
        }
    }
    let id = |i: usize, j: usize| (1 + (i - 1) * seg + j % seg) as u32;
    let mut t = Vec::new();
    for j in 0..seg {
        t.push([0, id(1, j), id(1, j + 1)]);
    }
    for i in 1..rings {
        for j in 0..seg {
            if i % 2 == 1 {
                t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            } else {
                t.push([id(i, j), id(i + 1, j), id(i, j + 1)]);
                t.push([id(i, j + 1), id(i + 1, j), id(i + 1, j + 1)]);
            }
        }
    }
    (p, t)
}

/// A torus with radii `big`, `small`.
fn torus(nu: usize, nv: usize, big: f64, small: f64) -> Mesh {
    let mut p = Vec::new();
    for i in 0..nu {
        let u = TAU * i as f64 / nu as f64;
        for j in 0..nv {
            let v = TAU * j as f64 / nv as f64;
            let rr = big + small * v.cos();
            p.push(Point3::new(rr * u.cos(), rr * u.sin(), small * v.sin()));
        }
    }
    let id = |i: usize, j: usize| ((i % nu) * nv + j % nv) as u32;
    let mut t = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    (p, t)
}

const INK: Rgba = Rgba::BLACK;
const PAPER: Rgba = Rgba::WHITE;

fn sphere_figure() -> Result<Image, RenderError> {
    let (p, t) = sphere(40, 80, 30.0);
    // Height plus a bump, so the histogram is not flat.
    let values: Vec<f64> = p.iter().map(|q| q.z + 8.0 * (0.2 * q.x).sin()).collect();
    let scale = ColorScale::from_values(Colormap::Viridis, &values);
    let colors = scale.colors(&values);
    let (w, h) = (420, 420);
    let cam = Camera::frame(
        &p,
        Vector3::new(-1.0, -0.6, -0.5),
        Vector3::z(),
        Lens::Perspective {
            fovy: 35f64.to_radians(),
        },
        w,
        h,
        0.08,
    )?;
    let mut r = Renderer::new(w, h, PAPER, cam)?;
    r.draw_mesh(&p, &t, Coloring::PerVertex(&colors), Shading::Smooth)?;
    // The equator highlighted, depth-tested (its back half is hidden).
    let equator: Vec<Point3<f64>> = (0..200)
        .map(|k| {
            let a = TAU * k as f64 / 200.0;
            Point3::new(30.0 * a.cos(), 30.0 * a.sin(), 0.0)
        })
        .collect();
    r.draw_polyline_3d(&equator, true, Rgba::new(230, 30, 30, 255))?;
    let mut fig = Image::new(720, 480, PAPER)?;
    fig.blit(r.image(), 10, 40);
    fig.draw_text(360, 10, "Sphere: height (mm)", 2, INK, Anchor::Center)?;
    draw_colorbar(
        &mut fig,
        Rect::new(450, 50, 110, 260),
        &scale,
        "z (mm)",
        INK,
        1,
    )?;
    let style = HistogramStyle {
        scale: Some(scale),
        ..HistogramStyle::default()
    };
    draw_histogram(
        &mut fig,
        Rect::new(450, 330, 260, 140),
        &values,
        24,
        None,
        "vertex values",
        &style,
    )?;
    Ok(fig)
}

fn disk_figure() -> Result<Image, RenderError> {
    let (p, t) = disk(12, 48, 1.0);
    // A distortion-like value: log area ratio, positive inside, negative out.
    let values: Vec<f64> = t
        .iter()
        .map(|tri| {
            let c =
                (p[tri[0] as usize].coords + p[tri[1] as usize].coords + p[tri[2] as usize].coords)
                    / 3.0;
            0.6 * (1.0 - 2.0 * c.norm_squared()) + 0.15 * (3.0 * c.y.atan2(c.x)).sin()
        })
        .collect();
    let scale = ColorScale::symmetric(Colormap::BlueRed, &values);
    let colors = scale.colors(&values);
    let (w, h) = (400, 400);
    let cam = Camera::frame(
        &p,
        -Vector3::z(),
        Vector3::y(),
        Lens::Orthographic,
        w,
        h,
        0.06,
    )?;
    let mut r = Renderer::new(w, h, PAPER, cam)?;
    r.draw_mesh(&p, &t, Coloring::PerTriangle(&colors), Shading::Unlit)?;
    r.draw_wireframe(&p, &t, Rgba::new(40, 40, 40, 255))?;
    // The u = 0 marker along +x, drawn in pixel space over everything.
    let c = r
        .project(&Point3::origin())
        .ok_or(RenderError::Empty("centre"))?;
    let e = r
        .project(&Point3::new(1.0, 0.0, 0.0))
        .ok_or(RenderError::Empty("edge"))?;
    let img = r.image_mut();
    for d in [-1.0, 0.0, 1.0] {
        img.line(
            [c.x, c.y + d],
            [e.x + 8.0, e.y + d],
            Rgba::new(0, 150, 0, 255),
        );
    }
    img.draw_text(
        (e.x - 4.0) as i32,
        (e.y - 12.0) as i32,
        "u=0",
        1,
        Rgba::new(0, 120, 0, 255),
        Anchor::Right,
    )?;
    // Scale bar: 0.5 units.
    let px_per_unit = e.x - c.x;
    let (x0, y0) = (20.0, f64::from(h) - 16.0);
    img.line([x0, y0], [x0 + 0.5 * px_per_unit, y0], INK);
    img.line([x0, y0 - 4.0], [x0, y0 + 4.0], INK);
    img.line(
        [x0 + 0.5 * px_per_unit, y0 - 4.0],
        [x0 + 0.5 * px_per_unit, y0 + 4.0],
        INK,
    );
    img.draw_text(
        (x0 + 0.25 * px_per_unit) as i32,
        (y0 - 14.0) as i32,
        "10 mm",
        1,
        INK,
        Anchor::Center,
    )?;
    let mut fig = Image::new(560, 450, PAPER)?;
    fig.blit(r.image(), 0, 40);
    fig.draw_text(280, 12, "Disk map: log area ratio", 2, INK, Anchor::Center)?;
    draw_colorbar(
        &mut fig,
        Rect::new(420, 60, 130, 300),
        &scale,
        "log(A'/A)",
        INK,
        1,
    )?;
    Ok(fig)
}

fn bullseye_figure() -> Result<Image, RenderError> {
    let (w, h) = (640u32, 470u32);
    let mut img = Image::new(w, h, PAPER)?;
    img.draw_text(
        (w / 2) as i32,
        10,
        "AHA 17 segments: thickness (mm)",
        2,
        INK,
        Anchor::Center,
    )?;
    let c = [270.0, 255.0];
    let radii = [0.0, 50.0, 100.0, 150.0, 200.0];
    let scale = ColorScale::new(Colormap::Magma, 4.0, 14.0);
    // Rings from the outside: basal (1-6), mid (7-12), apical (13-16), apex
    // (17), counter-clockwise on screen with anterior up and septal left; basal and mid
    // segments span 60 degrees starting at 60 degrees (1 at the top).
    let mut borders: Vec<Vec<[f64; 2]>> = Vec::new();
    let mut segment = 1;
    for (ring, (n, start)) in [(6usize, 60.0f64), (6, 60.0), (4, 45.0)]
        .into_iter()
        .enumerate()
    {
        let (r0, r1) = (radii[3 - ring], radii[4 - ring]);
        for k in 0..n {
            let a0 = (start + 360.0 * k as f64 / n as f64).to_radians();
            let a1 = (start + 360.0 * (k + 1) as f64 / n as f64).to_radians();
            let value = 5.0 + 9.0 * ((segment as f64 * 0.7).sin() * 0.5 + 0.5);
            let poly = annular_sector(c, r0, r1, a0, a1);
            img.fill_polygon(&poly, FillRule::EvenOdd, scale.color(value).opaque());
            borders.push(poly);
            let am = 0.5 * (a0 + a1);
            let rm = 0.5 * (r0 + r1);
            let label_ink = if scale.color(value).luminance() > 0.5 {
                INK
            } else {
                PAPER
            };
            img.draw_text(
                (c[0] + rm * am.cos()) as i32,
                (c[1] - rm * am.sin() - 8.0) as i32,
                &segment.to_string(),
                2,
                label_ink,
                Anchor::Center,
            )?;
            segment += 1;
        }
    }
    // The apex: a disk.
    let apex = arc(c, radii[1], 0.0, TAU);
    let value = 6.0;
    img.fill_polygon(&apex, FillRule::NonZero, scale.color(value).opaque());
    img.draw_text(
        c[0] as i32,
        (c[1] - 8.0) as i32,
        "17",
        2,
        PAPER,
        Anchor::Center,
    )?;
    borders.push(apex);
    for b in &borders {
        img.polyline(b, true, INK);
    }
    img.draw_text(
        c[0] as i32,
        (c[1] - radii[4] - 14.0) as i32,
        "anterior",
        1,
        INK,
        Anchor::Center,
    )?;
    img.draw_text(
        (c[0] - radii[4] - 6.0) as i32,
        (c[1] - 4.0) as i32,
        "septal",
        1,
        INK,
        Anchor::Right,
    )?;
    draw_colorbar(&mut img, Rect::new(510, 90, 120, 300), &scale, "mm", INK, 1)?;
    Ok(img)
}

fn shading_figure() -> Result<Image, RenderError> {
    let (p, t) = torus(48, 24, 2.0, 0.7);
    let base = Rgb::new(200, 170, 120);
    // Per-cell labels: 8 sectors around the torus.
    let labels: Vec<Rgb> = (0..t.len())
        .map(|k| Colormap::Tableau10.label(k / (2 * 24 * 6)))
        .collect();
    let (w, h) = (260, 220);
    let cam = Camera::frame(
        &p,
        Vector3::new(0.3, 1.0, -0.8),
        Vector3::z(),
        Lens::Orthographic,
        w,
        h,
        0.05,
    )?;
    let panels: [(&str, Coloring<'_>, Shading); 4] = [
        ("unlit", Coloring::Uniform(base), Shading::Unlit),
        ("flat", Coloring::Uniform(base), Shading::Flat),
        ("smooth", Coloring::Uniform(base), Shading::Smooth),
        ("cell labels", Coloring::PerTriangle(&labels), Shading::Flat),
    ];
    let mut fig = Image::new(2 * w + 30, 2 * h + 70, PAPER)?;
    fig.draw_text(
        fig.width() as i32 / 2,
        8,
        "Shading modes",
        2,
        INK,
        Anchor::Center,
    )?;
    for (k, (name, coloring, shading)) in panels.into_iter().enumerate() {
        let mut r = Renderer::new(w, h, PAPER, cam)?;
        r.draw_mesh(&p, &t, coloring, shading)?;
        if k == 3 {
            r.draw_wireframe(&p, &t, Rgba::new(60, 60, 60, 255))?;
        }
        let (x, y) = (
            10 + (k as u32 % 2) * (w + 10),
            40 + (k as u32 / 2) * (h + 12),
        );
        let img = r.image_mut();
        img.stroke_rect(img.rect(), Rgba::new(200, 200, 200, 255));
        img.draw_text((w / 2) as i32, 4, name, 1, INK, Anchor::Center)?;
        fig.blit(r.image(), i64::from(x), i64::from(y));
    }
    Ok(fig)
}

fn time_large_mesh() -> Result<(), RenderError> {
    let (p, t) = sphere(224, 224, 1.0);
    let values: Vec<f64> = p.iter().map(|q| q.z).collect();
    let colors = ColorScale::from_values(Colormap::Viridis, &values).colors(&values);
    let cam = Camera::frame(
        &p,
        Vector3::new(1.0, 0.5, -0.3),
        Vector3::z(),
        Lens::Perspective { fovy: 0.6 },
        800,
        600,
        0.05,
    )?;
    for shading in [Shading::Unlit, Shading::Flat, Shading::Smooth] {
        let t0 = Instant::now();
        let mut r = Renderer::new(800, 600, PAPER, cam)?;
        let stats = r.draw_mesh(&p, &t, Coloring::PerVertex(&colors), shading)?;
        let t1 = Instant::now();
        let png = r.image().to_png()?;
        let t2 = Instant::now();
        println!(
            "{} triangles, {shading:?}: draw {:.1} ms ({} drawn, {} px), png {:.1} ms ({} bytes)",
            t.len(),
            (t1 - t0).as_secs_f64() * 1e3,
            stats.drawn,
            stats.pixels,
            (t2 - t1).as_secs_f64() * 1e3,
            png.len()
        );
    }
    let t0 = Instant::now();
    let mut r = Renderer::new(800, 600, PAPER, cam)?;
    r.draw_mesh(&p, &t, Coloring::PerVertex(&colors), Shading::Smooth)?;
    r.draw_wireframe(&p, &t, INK)?;
    println!(
        "smooth + wireframe: {:.1} ms",
        t0.elapsed().as_secs_f64() * 1e3
    );
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "/tmp/render_examples".into());
    std::fs::create_dir_all(&dir)?;
    for (name, fig) in [
        ("sphere.png", sphere_figure()?),
        ("disk_map.png", disk_figure()?),
        ("bullseye.png", bullseye_figure()?),
        ("shading.png", shading_figure()?),
    ] {
        let path = format!("{dir}/{name}");
        std::fs::write(&path, fig.to_png()?)?;
        println!("wrote {path} ({}x{})", fig.width(), fig.height());
    }
    time_large_mesh()?;
    Ok(())
}
