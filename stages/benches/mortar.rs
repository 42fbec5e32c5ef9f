//! Mortar operators of a brake-disc-sized interface: 20,000 slave faces on a flat annulus
//! (0.15–0.32 m in radius) against a differently meshed master annulus 0.1 mm away, quad4
//! against quad4 and tri6 against quad8: rows, segments and the median time of five builds on
//! one thread and on all threads. Run with `cargo bench -p squeal-stages --bench mortar`.

use std::time::Instant;

use squeal_stages::fem::element::topology::FaceKind;
use squeal_stages::fem::mortar::{Settings, Surface, interface};

/// A flat annulus at height `z` of `cells` (radial, circumferential) cells, closed around, as
/// faces of `kind` (two triangles per cell), turned by `phase` (rad). `up`: normals along +z.
fn annulus(
    coords: &mut Vec<[f64; 3]>,
    kind: FaceKind,
    [n_r, n_theta]: [usize; 2],
    z: f64,
    phase: f64,
    up: bool,
) -> Vec<(FaceKind, Vec<u32>)> {
    let (inner, outer) = (0.15, 0.32);
    let step = if kind.n_nodes() > kind.n_corners() {
        2
    } else {
        1
    };
    let (dims_r, dims_theta) = (step * n_r + 1, step * n_theta);
    let first = coords.len() as u32;
    for q in 0..dims_theta {
        for p in 0..dims_r {
            let r = inner + (outer - inner) * p as f64 / (dims_r - 1) as f64;
            let theta = phase + std::f64::consts::TAU * q as f64 / dims_theta as f64;
            coords.push([r * theta.cos(), r * theta.sin(), z]);
        }
    }
    let node = |p: usize, q: usize| first + ((q % dims_theta) * dims_r + p) as u32;
    let mut faces = Vec::new();
    for j in 0..n_theta {
        for i in 0..n_r {
            let (p, q) = (step * i, step * j);
            let (p1, q1) = (p + step, q + step);
            let cycles: Vec<Vec<(usize, usize)>> = if kind.n_corners() == 4 {
                vec![vec![(p, q), (p1, q), (p1, q1), (p, q1)]]
            } else {
                vec![
                    vec![(p, q), (p1, q), (p1, q1)],
                    vec![(p, q), (p1, q1), (p, q1)],
                ]
            };
            for mut cycle in cycles {
                if !up {
                    cycle.reverse();
                }
                let mut nodes: Vec<u32> = cycle.iter().map(|&(a, b)| node(a, b)).collect();
                if step == 2 {
                    for k in 0..cycle.len() {
                        let (a, b) = (cycle[k], cycle[(k + 1) % cycle.len()]);
                        nodes.push(node((a.0 + b.0) / 2, (a.1 + b.1) / 2));
                    }
                }
                faces.push((kind, nodes));
            }
        }
    }
    faces
}

fn main() {
    let threads = rayon::current_num_threads();
    println!(
        "{:<16} {:>8} {:>8} {:>8} {:>9} {:>9} {:>11} {:>11}",
        "slave vs master",
        "slave",
        "master",
        "rows",
        "segments",
        "coverage",
        "1 thread s",
        format!("{threads} threads s")
    );
    for (slave_kind, slave_cells, master_kind, master_cells) in [
        (FaceKind::Quad4, [40, 500], FaceKind::Quad4, [47, 431]),
        (FaceKind::Tri6, [20, 500], FaceKind::Quad8, [27, 450]),
    ] {
        let mut coords = Vec::new();
        // The pad side (slave) faces up, at the disc's surface; the disc (master) faces down.
        let slave_faces = annulus(&mut coords, slave_kind, slave_cells, 0.0, 0.0, true);
        let master_faces = annulus(&mut coords, master_kind, master_cells, 1e-4, 0.003, false);
        let slave = Surface {
            name: "pad",
            faces: slave_faces,
        };
        let master = Surface {
            name: "disc",
            faces: master_faces,
        };
        let settings = Settings {
            search_distance: 1e-3,
            ..Settings::default()
        };
        let median = |threads: usize| -> (f64, usize, usize, f64) {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("thread pool");
            let mut times = Vec::new();
            let mut last = None;
            for _ in 0..5 {
                let started = Instant::now();
                let built = pool
                    .install(|| interface(&coords, &slave, &master, &settings))
                    .expect("an interface");
                times.push(started.elapsed().as_secs_f64());
                last = Some(built);
            }
            times.sort_by(f64::total_cmp);
            let built = last.expect("five runs");
            (times[2], built.rows.len(), built.segments, built.coverage)
        };
        let (one, rows, segments, coverage) = median(1);
        let (all, ..) = median(threads);
        println!(
            "{:<16} {:>8} {:>8} {:>8} {:>9} {:>9.6} {:>11.3} {:>11.3}",
            format!("{slave_kind} vs {master_kind}"),
            slave.faces.len(),
            master.faces.len(),
            rows,
            segments,
            coverage,
            one,
            all
        );
    }
}
