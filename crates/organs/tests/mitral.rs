//! The mitral pipeline on synthetic valves (issue 5 acceptance): the
//! straight annulus keeps its length, commissures and order come from the
//! geometry alone, `sd` never flips and beats the spring, coaptation,
//! Carpentier segments and tenting behave as on real valves.

use unfold_mesh::TriMesh;
use unfold_mesh::nalgebra::{Point3, Vector3};
use unfold_mesh::shapes::{Pose, ValveParams, ValveShape, mitral_valve};
use unfold_organs::OrganError;
use unfold_organs::mitral::{
    ANTERIOR, AnnulusMode, Config, ContractError, InitMode, LayoutError, LeafletLayout,
    LeafletSide, MitralError, Outcome, POSTERIOR, Pipeline, RelaxMode, ValveInput,
};

/// The published pipeline with `config`.
fn run(input: &ValveInput<'_>, config: &Config) -> Result<Outcome, OrganError> {
    Pipeline::new().config(*config).run(input)
}

/// The published pipeline with `config`, on a series.
fn run_series(inputs: &[ValveInput<'_>], config: &Config) -> Vec<Result<Outcome, OrganError>> {
    Pipeline::new().config(*config).run_series(inputs)
}

/// Splits every `every`-th triangle at its centroid: the leaflet keeps its
/// shape and disk topology but loses its longitude (grid) structure.
fn without_longitudes(mesh: &TriMesh, every: usize) -> TriMesh {
    let mut positions = mesh.positions.clone();
    let mut triangles = Vec::with_capacity(mesh.triangles.len() + 2 * mesh.triangles.len() / every);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if t % every == 3 {
            let [a, b, c] = tri.map(|v| mesh.positions[v as usize]);
            let m = positions.len() as u32;
            positions.push(Point3::from((a.coords + b.coords + c.coords) / 3.0));
            triangles.push([tri[0], tri[1], m]);
            triangles.push([tri[1], tri[2], m]);
            triangles.push([tri[2], tri[0], m]);
        } else {
            triangles.push(*tri);
        }
    }
    TriMesh::new(positions, triangles)
}

/// A valve case: the generator's shape and the leaflets given to the
/// pipeline (possibly remeshed).
struct Case {
    name: &'static str,
    shape: ValveShape,
    anterior: TriMesh,
    posterior: TriMesh,
}

fn case(name: &'static str, p: ValveParams, remesh: bool) -> Case {
    let shape = mitral_valve(&p).unwrap();
    let (anterior, posterior) = if remesh {
        (
            without_longitudes(&shape.anterior, 7),
            without_longitudes(&shape.posterior, 7),
        )
    } else {
        (shape.anterior.clone(), shape.posterior.clone())
    };
    Case {
        name,
        shape,
        anterior,
        posterior,
    }
}

fn open_valve() -> ValveParams {
    ValveParams {
        coaptation_gap: 12.0,
        commissure_gap: 15.0,
        ..ValveParams::default()
    }
}

fn cases() -> Vec<Case> {
    let coarse = ValveParams {
        annulus_segments: 32,
        depth_segments: 6,
        ..ValveParams::default()
    };
    let fine = ValveParams {
        annulus_segments: 160,
        depth_segments: 24,
        pose: Pose::new([20.0, -35.0, 110.0], [5.0, 40.0, -12.0]),
        ..ValveParams::default()
    };
    vec![
        case("closed", ValveParams::default(), false),
        case("closed, no longitudes", ValveParams::default(), true),
        case("open", open_valve(), false),
        case("open, no longitudes", open_valve(), true),
        case("coarse", coarse.clone(), false),
        case("coarse, no longitudes", coarse, true),
        case("fine, posed", fine.clone(), false),
        case("fine, posed, no longitudes", fine, true),
    ]
}

/// The ring as a user might give it: started elsewhere and reversed.
fn scrambled_ring(shape: &ValveShape) -> Vec<Point3<f64>> {
    let n = shape.annulus.len();
    let mut ring: Vec<Point3<f64>> = (0..n).map(|i| shape.annulus[(i + n / 3) % n]).collect();
    ring.reverse();
    ring
}

fn run_case(c: &Case, config: &Config) -> Outcome {
    let ring = scrambled_ring(&c.shape);
    run(
        &ValveInput {
            anterior: &c.anterior,
            posterior: &c.posterior,
            annulus: &ring,
        },
        config,
    )
    .unwrap_or_else(|e| panic!("{}: {e}", c.name))
}

fn perimeter(ring: &[Point3<f64>]) -> f64 {
    (0..ring.len())
        .map(|i| (ring[(i + 1) % ring.len()] - ring[i]).norm())
        .sum()
}

#[test]
fn the_straight_annulus_keeps_its_length_and_the_order_comes_from_the_geometry() {
    for c in cases() {
        let config = Config {
            annulus_mode: AnnulusMode::Straight,
            ..Config::default()
        };
        let out = run_case(&c, &config);
        let length = perimeter(&c.shape.annulus);
        let r = &out.report;
        let rel = (r.u_extent_mm - length).abs() / length;
        println!(
            "{}: u extent {:.9} mm, 3D length {:.9} mm (relative difference {rel:.1e}); init {:?}",
            c.name, r.u_extent_mm, length, r.init
        );
        assert!(rel < 1e-9, "{}: {rel}", c.name);
        assert!((r.annulus_length_mm - length).abs() < 1e-9 * length);
        // The ring comes back clockwise from the atrium, from the
        // anterolateral commissure, as the generator made it.
        let ring = &out.valve.ring;
        assert_eq!(ring.len(), c.shape.annulus.len(), "{}", c.name);
        for (a, b) in ring.iter().zip(&c.shape.annulus) {
            assert!((a - b).norm() < 1e-12, "{}", c.name);
        }
        assert_eq!(out.valve.posteromedial, c.shape.commissures[1]);
        let expect = if c.name.contains("no longitudes") {
            ["tutte", "tutte"]
        } else {
            ["longitudes", "longitudes"]
        };
        assert_eq!(r.init, expect, "{}", c.name);
    }
}

#[test]
fn sd_never_flips_and_keeps_the_annulus_where_it_was_laid_out() {
    for c in cases() {
        let sd = run_case(&c, &Config::default());
        assert_eq!(sd.report.flipped_triangles, 0, "{}", c.name);
        assert!(
            sd.report.relax_reports.iter().all(|r| r.converged),
            "{}",
            c.name
        );
        // The annulus stays where it was laid out.
        for k in [ANTERIOR, POSTERIOR] {
            let leaflet = &sd.valve.leaflets[k];
            for (&v, &s) in leaflet.annulus.iter().zip(&leaflet.annulus_s) {
                let want = sd.annulus.at(s);
                let got = sd.uv[k][v as usize];
                assert!((got[0] - want[0]).abs() < 1e-9 && (got[1] - want[1]).abs() < 1e-9);
            }
        }
    }
}

#[test]
fn sd_is_flip_free_where_the_spring_flips() {
    // The fine, posed valve remeshed without longitudes (so from a Tutte
    // start): five spring steps flip triangles; sd from the same start
    // flips none.
    let c = cases()
        .into_iter()
        .find(|c| c.name == "fine, posed, no longitudes")
        .unwrap();
    let spring = run_case(
        &c,
        &Config {
            relax: RelaxMode::Spring,
            ..Config::default()
        },
    );
    let sd = run_case(&c, &Config::default());
    println!(
        "{}: spring flips {}, sd flips {}",
        c.name, spring.report.flipped_triangles, sd.report.flipped_triangles
    );
    assert_eq!(spring.report.init, ["tutte", "tutte"]);
    assert!(spring.report.flipped_triangles > 0);
    assert_eq!(sd.report.flipped_triangles, 0);
}

/// Vertices farther than `r` mm from both commissures.
fn away_from_commissures(out: &Outcome, k: usize, r: f64) -> Vec<usize> {
    let [al, pm] = [out.valve.ring[0], out.valve.ring[out.valve.posteromedial]];
    out.valve.leaflets[k]
        .mesh
        .positions
        .iter()
        .enumerate()
        .filter(|(_, p)| (*p - al).norm() > r && (*p - pm).norm() > r)
        .map(|(i, _)| i)
        .collect()
}

#[test]
fn coaptation_runs_along_a_closed_valve_and_vanishes_on_an_open_one() {
    let closed = run_case(
        &case("closed", ValveParams::default(), false),
        &Config::default(),
    );
    let open = run_case(&case("open", open_valve(), false), &Config::default());
    let count = |out: &Outcome| {
        [ANTERIOR, POSTERIOR]
            .iter()
            .map(|&k| {
                away_from_commissures(out, k, 5.0)
                    .into_iter()
                    .filter(|&v| out.maps[k].coaptation[v] == 2)
                    .count()
            })
            .sum::<usize>()
    };
    let (c, o) = (count(&closed), count(&open));
    println!(
        "coaptation zone away from the commissures: closed {c} vertices, open {o}; \
         whole zone closed {} open {}",
        closed.report.coaptation_vertices.within, open.report.coaptation_vertices.within
    );
    assert!(c > 50, "{c}");
    assert_eq!(o, 0);
    // On the closed valve the zone lies in the lower part of the 2D map.
    for k in [ANTERIOR, POSTERIOR] {
        let uv = &closed.uv[k];
        let top = uv.iter().map(|q| q[1]).fold(f64::NEG_INFINITY, f64::max);
        let bottom = uv.iter().map(|q| q[1]).fold(f64::INFINITY, f64::min);
        for v in away_from_commissures(&closed, k, 5.0) {
            if closed.maps[k].coaptation[v] == 2 {
                assert!(uv[v][1] < 0.5 * (top + bottom), "leaflet {k} vertex {v}");
            }
        }
    }
}

#[test]
fn every_carpentier_segment_is_found() {
    for c in cases() {
        let out = run_case(&c, &Config::default());
        let counts = out.report.carpentier_vertices;
        assert!(counts.iter().all(|&n| n > 0), "{}: {counts:?}", c.name);
        // A1 and P1 lie at the anterolateral commissure, A3 and P3 at the
        // posteromedial one.
        let [al, pm] = [out.valve.ring[0], out.valve.ring[out.valve.posteromedial]];
        for (k, near_al, near_pm) in [(ANTERIOR, 1, 3), (POSTERIOR, 4, 6)] {
            let mesh = &out.valve.leaflets[k].mesh;
            let mean = |label: i32, q: Point3<f64>| {
                let d: Vec<f64> = mesh
                    .positions
                    .iter()
                    .zip(&out.maps[k].carpentier)
                    .filter(|&(_, &l)| l == label)
                    .map(|(p, _)| (p - q).norm())
                    .collect();
                d.iter().sum::<f64>() / d.len() as f64
            };
            assert!(mean(near_al, al) < mean(near_pm, al), "{}", c.name);
            assert!(mean(near_pm, pm) < mean(near_al, pm), "{}", c.name);
        }
    }
}

#[test]
fn tenting_is_positive_where_a_leaflet_prolapses() {
    let shape = mitral_valve(&ValveParams::default()).unwrap();
    let base = run_case(
        &Case {
            name: "closed",
            anterior: shape.anterior.clone(),
            posterior: shape.posterior.clone(),
            shape: shape.clone(),
        },
        &Config::default(),
    );
    // Lift the middle third of the posterior leaflet's body through the
    // annulus plane (a smooth bump along the atrium direction).
    let up: Vector3<f64> = shape.atrium_direction;
    let mut posterior = shape.posterior.clone();
    let cols = shape.posterior_longitudes.len();
    let mut lifted = Vec::new();
    for (i, col) in shape.posterior_longitudes.iter().enumerate() {
        let x = i as f64 / (cols - 1) as f64;
        if !(0.35..=0.65).contains(&x) {
            continue;
        }
        let depth = col.len() - 1;
        for (r, &v) in col.iter().enumerate().skip(1) {
            let t = r as f64 / depth as f64;
            let w = (std::f64::consts::PI * t).sin();
            posterior.positions[v as usize] += up * (20.0 * w);
            if (0.3..=0.7).contains(&t) {
                lifted.push(v as usize);
            }
        }
    }
    let prolapse = run_case(
        &Case {
            name: "prolapse",
            anterior: shape.anterior.clone(),
            posterior,
            shape: shape.clone(),
        },
        &Config::default(),
    );
    let before = &base.maps[POSTERIOR].tenting_mm;
    let after = &prolapse.maps[POSTERIOR].tenting_mm;
    let lo = lifted
        .iter()
        .map(|&v| before[v])
        .fold(f64::INFINITY, f64::min);
    let hi = lifted
        .iter()
        .map(|&v| before[v])
        .fold(f64::NEG_INFINITY, f64::max);
    println!(
        "lifted {} vertices, tenting before in [{lo:.2}, {hi:.2}] mm",
        lifted.len()
    );
    assert!(
        (prolapse.valve.atrium - base.valve.atrium).norm() < 1e-6,
        "{:?} {:?}",
        prolapse.valve.atrium,
        base.valve.atrium
    );
    for &v in &lifted {
        assert!(
            before[v] < 0.0,
            "vertex {v} starts below the plane: {}",
            before[v]
        );
        assert!(after[v] > 0.0, "vertex {v} prolapses: {}", after[v]);
    }
    assert!(
        prolapse.report.area_above_plane_mm2 > base.report.area_above_plane_mm2 + 10.0,
        "{} vs {}",
        prolapse.report.area_above_plane_mm2,
        base.report.area_above_plane_mm2
    );
    assert_eq!(prolapse.report.flipped_triangles, 0);
}

#[test]
fn the_outputs_carry_every_map() {
    let out = run_case(
        &case("closed", ValveParams::default(), false),
        &Config::default(),
    );
    let n = out.valve.leaflets[0].mesh.positions.len() + out.valve.leaflets[1].mesh.positions.len();
    for mesh in [&out.valve3d, &out.valve2d] {
        assert_eq!(mesh.positions.len(), n);
        for name in [
            "leaflet",
            "u_gradient",
            "u_interval",
            "checker",
            "carpentier",
            "length_energy",
            "coaptation",
            "tenting_mm",
            "uv",
        ] {
            assert_eq!(
                mesh.point_data.get(name).map(|f| f.tuples()),
                Some(n),
                "point array {name}"
            );
        }
        for name in ["area_energy", "angle_energy"] {
            assert_eq!(
                mesh.cell_data.get(name).map(|f| f.tuples()),
                Some(mesh.triangles.len()),
                "cell array {name}"
            );
        }
    }
    assert!(out.valve2d.positions.iter().all(|p| p.z == 0.0));
    let json = serde_json::to_value(&out.report).unwrap();
    for key in [
        "annulus_length_mm",
        "u_extent_mm",
        "saddle_horn_height_mm",
        "area_above_plane_mm2",
        "flipped_triangles",
        "relax",
        "seconds",
    ] {
        assert!(json.get(key).is_some(), "{key}");
    }
    for key in ["anterior", "posterior"] {
        assert!(json["leaflet_area_mm2"][key].as_f64().unwrap() > 0.0);
    }
    for stage in ["initial", "final"] {
        for e in ["area", "angle", "length"] {
            assert!(json["distortion"][stage][e].as_f64().unwrap() >= 2.0 - 1e-12);
        }
    }
}

/// The acceptance comparison in both plane modes (the landmark plane is the
/// default): lower angle, no higher length and area energy than 5 spring
/// steps, on every synthetic valve. In straight mode, where the annulus is
/// forced flat (all heights 0), sd still has the lower angle energy on
/// every valve, but on the coarse 32 x 6 valve gives up a little area
/// energy (2.1112 vs 2.1099) and, without longitudes, length energy
/// (2.0589 vs 2.0547, against a spring layout with flipped triangles):
/// symmetric Dirichlet trades them for angle there.
#[test]
fn sd_beats_the_spring_in_both_plane_modes() {
    for mode in [
        AnnulusMode::LeastSquares,
        AnnulusMode::Landmark,
        AnnulusMode::Straight,
    ] {
        for c in cases() {
            let config = Config {
                annulus_mode: mode,
                ..Config::default()
            };
            let sd = run_case(&c, &config);
            let spring = run_case(
                &c,
                &Config {
                    relax: RelaxMode::Spring,
                    ..config
                },
            );
            let (a, b) = (
                &sd.report.distortion.r#final,
                &spring.report.distortion.r#final,
            );
            println!(
                "{mode:?} {}: sd {:.4}/{:.4}/{:.4} spring {:.4}/{:.4}/{:.4}",
                c.name, a.area, a.angle, a.length, b.area, b.angle, b.length
            );
            assert_eq!(sd.report.flipped_triangles, 0);
            assert!(a.angle < b.angle, "{mode:?} {}", c.name);
            if mode != AnnulusMode::Straight {
                assert!(a.length <= b.length, "{mode:?} {}", c.name);
                assert!(a.area <= b.area, "{mode:?} {}", c.name);
            }
        }
    }
}

/// A series runs its steps in parallel and shares Hessian layouts between
/// steps of the same connectivity, yet every step comes out exactly as a
/// single run of it, in order; a bad step fails alone.
#[test]
fn a_series_gives_each_step_exactly_its_single_run() {
    let shapes: Vec<ValveShape> = [1.0, 4.0, 7.0]
        .iter()
        .map(|&gap| {
            mitral_valve(&ValveParams {
                coaptation_gap: gap,
                ..ValveParams::default()
            })
            .unwrap()
        })
        .collect();
    let far: Vec<Point3<f64>> = shapes[0]
        .annulus
        .iter()
        .map(|p| p + Vector3::new(0.0, 0.0, 50.0))
        .collect();
    let mut inputs: Vec<ValveInput<'_>> = shapes
        .iter()
        .map(|s| ValveInput {
            anterior: &s.anterior,
            posterior: &s.posterior,
            annulus: &s.annulus,
        })
        .collect();
    // A ring the leaflets do not touch.
    inputs.push(ValveInput {
        anterior: &shapes[0].anterior,
        posterior: &shapes[0].posterior,
        annulus: &far,
    });
    let config = Config::default();
    let series = run_series(&inputs, &config);
    assert_eq!(series.len(), inputs.len());
    for (input, got) in inputs.iter().zip(&series).take(3) {
        let single = run(input, &config).unwrap();
        let got = got.as_ref().unwrap();
        for k in [ANTERIOR, POSTERIOR] {
            assert_eq!(got.uv[k], single.uv[k]);
        }
        assert_eq!(got.report.distortion, single.report.distortion);
        assert_eq!(
            got.report.relax_reports[0].iterations,
            single.report.relax_reports[0].iterations
        );
    }
    let e = series[3].as_ref().unwrap_err();
    let single = run(&inputs[3], &config).unwrap_err();
    assert_eq!(e, &single);
    assert_eq!(e.to_string(), single.to_string());
    assert!(
        matches!(
            e,
            OrganError::Mitral(MitralError::Contract(ContractError::LeafletOffRing {
                leaflet: LeafletSide::Anterior,
                ..
            }))
        ),
        "{e:?}"
    );
}

#[test]
fn longitudes_asked_for_but_missing_name_the_leaflet() {
    let shape = mitral_valve(&ValveParams {
        annulus_segments: 32,
        depth_segments: 6,
        ..ValveParams::default()
    })
    .unwrap();
    let posterior = without_longitudes(&shape.posterior, 7);
    let input = ValveInput {
        anterior: &shape.anterior,
        posterior: &posterior,
        annulus: &shape.annulus,
    };
    let longitudes = Pipeline::new().initializer(LeafletLayout {
        mode: InitMode::Longitudes,
    });
    let e = longitudes.run(&input).unwrap_err();
    assert_eq!(
        e,
        OrganError::Mitral(MitralError::Layout(LayoutError::NoLongitudes {
            leaflet: LeafletSide::Posterior
        }))
    );
    assert_eq!(
        e.to_string(),
        "the posterior leaflet has no longitudes (one vertex chain per annulus vertex down to \
         the free edge); use --init tutte or auto"
    );
    // Auto falls back to Tutte there.
    let auto = Pipeline::new().initializer(LeafletLayout {
        mode: InitMode::Auto,
    });
    assert_eq!(
        auto.run(&input).unwrap().report.init,
        ["longitudes", "tutte"]
    );
}
