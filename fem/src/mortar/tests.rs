// Index loops follow the index notation of the formulas.
#![allow(clippy::needless_range_loop)]

use super::*;
use crate::artifact::mesh::sub;
use crate::faces::area_vectors;

/// splitmix64: a fixed stream of numbers in [0, 1) without a dependency.
struct Random(u64);

impl Random {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// How the interior of a patch is moved in its parameter square.
#[derive(Clone, Copy)]
enum Perturb {
    None,
    /// Interior grid lines moved (faces stay rectangles in the parameters).
    Lines(u64),
    /// Interior corner nodes moved each on its own (quadrilaterals then stop being
    /// parallelograms).
    Nodes(u64),
}

/// Node coordinates shared by the surfaces of a test.
#[derive(Default)]
struct Builder {
    coords: Vec<[f64; 3]>,
}

impl Builder {
    /// A patch of `cells` cells of the parameter square [0, 1]², mapped by `map`, as faces of
    /// `kind` (triangles: two per cell). `up`: the faces turn counter-clockwise in the
    /// parameters (normal along map_s × map_t); otherwise the other way. Mid-edge nodes sit at
    /// the middles of their edges in the parameters.
    fn patch(
        &mut self,
        kind: FaceKind,
        cells: [usize; 2],
        map: impl Fn([f64; 2]) -> [f64; 3],
        up: bool,
        perturb: Perturb,
    ) -> Vec<(FaceKind, Vec<u32>)> {
        let quadratic = kind.n_nodes() > kind.n_corners();
        let step = if quadratic { 2 } else { 1 };
        let dims = [step * cells[0] + 1, step * cells[1] + 1];
        // Corner parameters, perturbed, then every lattice point from its corners.
        let mut lines: Vec<Vec<f64>> = (0..2)
            .map(|d| (0..=cells[d]).map(|i| i as f64 / cells[d] as f64).collect())
            .collect();
        if let Perturb::Lines(seed) = perturb {
            let mut random = Random(seed);
            for d in 0..2 {
                for i in 1..cells[d] {
                    lines[d][i] += (random.next() - 0.5) * 0.6 / cells[d] as f64;
                }
            }
        }
        let mut corner = vec![[0.0; 2]; (cells[0] + 1) * (cells[1] + 1)];
        let mut random = Random(match perturb {
            Perturb::Nodes(seed) => seed,
            _ => 0,
        });
        for j in 0..=cells[1] {
            for i in 0..=cells[0] {
                let mut at = [lines[0][i], lines[1][j]];
                let interior = i > 0 && i < cells[0] && j > 0 && j < cells[1];
                if matches!(perturb, Perturb::Nodes(_)) && interior {
                    at[0] += (random.next() - 0.5) * 0.6 / cells[0] as f64;
                    at[1] += (random.next() - 0.5) * 0.6 / cells[1] as f64;
                }
                corner[j * (cells[0] + 1) + i] = at;
            }
        }
        let first = self.coords.len() as u32;
        for q in 0..dims[1] {
            for p in 0..dims[0] {
                let (i0, i1) = (p / step, p.div_ceil(step));
                let (j0, j1) = (q / step, q.div_ceil(step));
                // The middle of a lattice edge or of a cell's diagonal (0,0)–(1,1).
                let a = corner[j0 * (cells[0] + 1) + i0];
                let b = corner[j1 * (cells[0] + 1) + i1];
                self.coords
                    .push(map([0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])]));
            }
        }
        let node = |p: usize, q: usize| first + (q * dims[0] + p) as u32;
        let mut faces = Vec::new();
        for j in 0..cells[1] {
            for i in 0..cells[0] {
                let [p, q] = [step * i, step * j];
                let [p1, q1] = [p + step, q + step];
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
                    if quadratic {
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
}

/// The plane map of the square [0, size]² at height z.
fn plane(size: f64, z: f64) -> impl Fn([f64; 2]) -> [f64; 3] {
    move |[s, t]| [size * s, size * t, z]
}

/// ∫ N_a dA by node over flat faces (the consistent load of a unit pressure).
fn consistent_loads(coords: &[[f64; 3]], faces: &[(FaceKind, Vec<u32>)]) -> Vec<(u32, f64)> {
    let mut loads = Vec::new();
    for (kind, nodes) in faces {
        let x: Vec<[f64; 3]> = nodes.iter().map(|&n| coords[n as usize]).collect();
        let (nodal, total) = area_vectors(*kind, &x);
        let unit = total.map(|c| c / norm(total));
        for (&n, vector) in nodes.iter().zip(&nodal) {
            loads.push((n, dot(*vector, unit)));
        }
    }
    merge(loads)
}

fn area(coords: &[[f64; 3]], faces: &[(FaceKind, Vec<u32>)]) -> f64 {
    consistent_loads(coords, faces).iter().map(|l| l.1).sum()
}

/// Loads by node.
type Loads = Vec<(u32, f64)>;

/// Σ_j w_j S_jk and Σ_j w_j P_jl by node: what a unit pressure on the rows loads each side with.
fn transmitted(interface: &Interface) -> (Loads, Loads) {
    let mut slave = Vec::new();
    let mut master = Vec::new();
    for row in &interface.rows {
        slave.extend(row.slave.iter().map(|&(n, s)| (n, row.weight * s)));
        master.extend(row.master.iter().map(|&(n, p)| (n, row.weight * p)));
    }
    (merge(slave), merge(master))
}

fn settings() -> Settings {
    Settings {
        search_distance: 0.05,
        ..Settings::default()
    }
}

fn build(
    builder: &Builder,
    slave: &[(FaceKind, Vec<u32>)],
    master: &[(FaceKind, Vec<u32>)],
) -> Result<Interface, MortarError> {
    interface(
        &builder.coords,
        &Surface {
            name: "pad",
            faces: slave.to_vec(),
        },
        &Surface {
            name: "disc",
            faces: master.to_vec(),
        },
        &settings(),
    )
}

/// Checks 2(a)–(c) on a flat interface whose sides cover each other (z = 0, size 1):
/// Σ w = area, consistent loads on both sides, affine fields reproduced.
fn check_flat(
    builder: &Builder,
    slave: &[(FaceKind, Vec<u32>)],
    master: &[(FaceKind, Vec<u32>)],
    label: &str,
) {
    let tolerance = 1e-12;
    let interface = build(builder, slave, master).unwrap_or_else(|e| panic!("{label}: {e}"));
    let coords = &builder.coords;
    let slave_area = area(coords, slave);
    let weights: f64 = interface.rows.iter().map(|r| r.weight).sum();
    assert!(
        (weights - slave_area).abs() < tolerance * slave_area,
        "{label}: Σ w = {weights}"
    );
    assert!((interface.coverage - 1.0).abs() < tolerance, "{label}");
    assert!(interface.dropped.is_empty(), "{label}");
    let (slave_loads, master_loads) = transmitted(&interface);
    for (loads, expected, side) in [
        (slave_loads, consistent_loads(coords, slave), "slave"),
        (master_loads, consistent_loads(coords, master), "master"),
    ] {
        let expected: Vec<(u32, f64)> = expected.into_iter().filter(|l| l.1 != 0.0).collect();
        let loads: Vec<(u32, f64)> = loads.into_iter().filter(|l| l.1.abs() > 1e-15).collect();
        let mut by_node = std::collections::BTreeMap::new();
        for (n, value) in &expected {
            by_node.insert(*n, (*value, 0.0));
        }
        for (n, value) in &loads {
            by_node.entry(*n).or_insert((0.0, 0.0)).1 = *value;
        }
        for (n, (want, got)) in by_node {
            assert!(
                (want - got).abs() < tolerance * slave_area,
                "{label}: {side} node {n}: transmitted {got}, consistent {want}"
            );
        }
    }
    // An affine field f(x) = A x + b: Σ_l P_jl f_l = Σ_k S_jk f_k on coincident planes.
    let A = [[0.3, -1.2, 0.7], [2.0, 0.1, -0.4], [-0.6, 0.9, 1.5]];
    let b = [0.2, -0.3, 0.5];
    let field = |x: [f64; 3]| -> [f64; 3] {
        std::array::from_fn(|i| (0..3).map(|k| A[i][k] * x[k]).sum::<f64>() + b[i])
    };
    for row in &interface.rows {
        let mut difference = [0.0; 3];
        for &(n, p) in &row.master {
            let f = field(coords[n as usize]);
            (0..3).for_each(|i| difference[i] += p * f[i]);
        }
        for &(n, s) in &row.slave {
            let f = field(coords[n as usize]);
            (0..3).for_each(|i| difference[i] -= s * f[i]);
        }
        assert!(
            norm(difference) < tolerance,
            "{label}: node {}: {difference:?}",
            row.node
        );
        assert!(row.gap.abs() < tolerance, "{label}: gap {}", row.gap);
    }
}

const KINDS: [FaceKind; 4] = [
    FaceKind::Tri3,
    FaceKind::Tri6,
    FaceKind::Quad4,
    FaceKind::Quad8,
];

#[test]
fn coincident_meshes_give_node_to_node_rows_with_the_consistent_nodal_areas() {
    // Linear faces: S = P = I (each slave node against its coincident master node). Quadratic
    // faces: S = P, a corner's row its own node, a mid-edge node's row 5/3 of itself and −1/3
    // of each corner of its edge. Tolerance 1e-12.
    for kind in KINDS {
        let mut builder = Builder::default();
        let slave = builder.patch(kind, [3, 3], plane(1.0, 0.0), true, Perturb::None);
        let offset = builder.coords.len() as u32;
        let master = builder.patch(kind, [3, 3], plane(1.0, 0.0), false, Perturb::None);
        let interface = build(&builder, &slave, &master).unwrap();
        let loads = consistent_loads(&builder.coords, &slave);
        let mut weights = 0.0;
        for row in &interface.rows {
            weights += row.weight;
            assert!((row.coverage - 1.0).abs() < 1e-12, "{kind}");
            assert!(row.weight > 0.0, "{kind}: node {}", row.node);
            // The same row on both sides, through the coincident node numbering.
            assert_eq!(
                row.slave.len(),
                row.master.len(),
                "{kind}: node {}",
                row.node
            );
            for (&(k, s), &(l, p)) in row.slave.iter().zip(&row.master) {
                assert_eq!(l, k + offset, "{kind}");
                assert!(
                    (s - p).abs() < 1e-12,
                    "{kind}: node {}: {s} vs {p}",
                    row.node
                );
            }
            let own = row.slave.iter().find(|e| e.0 == row.node).unwrap().1;
            let is_corner = slave
                .iter()
                .any(|(kind, nodes)| nodes[..kind.n_corners()].contains(&row.node));
            if kind.n_nodes() == kind.n_corners() {
                assert_eq!(row.slave, vec![(row.node, 1.0)], "{kind}");
                let consistent = loads.iter().find(|l| l.0 == row.node).unwrap().1;
                assert!((row.weight - consistent).abs() < 1e-12, "{kind}");
            } else if is_corner {
                assert_eq!(row.slave.len(), 1, "{kind}: {:?}", row.slave);
                assert!((own - 1.0).abs() < 1e-12, "{kind}");
            } else {
                assert_eq!(row.slave.len(), 3, "{kind}: {:?}", row.slave);
                assert!((own - 5.0 / 3.0).abs() < 1e-12, "{kind}: {:?}", row.slave);
            }
        }
        assert!((weights - 1.0).abs() < 1e-12, "{kind}: Σ w = {weights}");
        assert!(interface.largest_gap < 1e-15 && interface.largest_penetration < 1e-15);
    }
}

#[test]
fn quadratic_faces_take_a_positive_biorthogonal_basis() {
    // On a flat face of each quadratic kind (a parallelogram for quad8): ∫ N̂_j > 0 with the
    // documented shares of the area, ∫ Φ_j N̂_k = δ_jk ∫ N̂_j and Σ_j Φ_j = 1 (1e-13).
    for (kind, corner_share, mid_share) in [
        (FaceKind::Tri6, 2.0 / 15.0, 1.0 / 5.0),
        (FaceKind::Quad8, 1.0 / 20.0, 1.0 / 5.0),
        (FaceKind::Tri3, 1.0 / 3.0, 0.0),
        (FaceKind::Quad4, 1.0 / 4.0, 0.0),
    ] {
        let mut builder = Builder::default();
        let map = |[s, t]: [f64; 2]| [0.3 * s + 0.1 * t, 0.05 * s + 0.2 * t, 0.1];
        let faces = builder.patch(kind, [1, 1], map, true, Perturb::None);
        let face = Face::new(kind, &builder.coords, &faces[0].1);
        let plane = Plane::of(&face).unwrap();
        let polygon = plane.polygon(&face);
        let face_area = geometry::signed_area(&polygon);
        let n = kind.n_nodes();
        let guess = Guess::new(&face, &plane).unwrap();
        let mut points = Vec::new();
        for_each_point(&polygon, |q, w| {
            points.push((w, project_along(&face, &plane, &guess, q).unwrap()))
        });
        let mut diagonal = [0.0; MAX_NODES];
        let mut mass = [[0.0; MAX_NODES]; MAX_NODES];
        for &(w, values) in &points {
            let hat = dual::transform(kind, &values);
            for i in 0..n {
                diagonal[i] += w * hat[i];
                (0..n).for_each(|j| mass[i][j] += w * hat[i] * hat[j]);
            }
        }
        for j in 0..n {
            let share = if j < kind.n_corners() {
                corner_share
            } else {
                mid_share
            };
            assert!(diagonal[j] > 0.0, "{kind}");
            assert!(
                (diagonal[j] / face_area - share).abs() < 1e-13,
                "{kind} node {j}"
            );
        }
        let X = dual::dual_coefficients(n, &diagonal, &mass).unwrap();
        let mut biorthogonal = [[0.0; MAX_NODES]; MAX_NODES];
        for &(w, values) in &points {
            let hat = dual::transform(kind, &values);
            let phi = dual::evaluate(n, &X, &hat);
            assert!((phi[..n].iter().sum::<f64>() - 1.0).abs() < 1e-13, "{kind}");
            for j in 0..n {
                (0..n).for_each(|k| biorthogonal[j][k] += w * phi[j] * hat[k]);
            }
        }
        for j in 0..n {
            for k in 0..n {
                let expected = if j == k { diagonal[j] } else { 0.0 };
                assert!(
                    (biorthogonal[j][k] - expected).abs() < 1e-13 * face_area,
                    "{kind}: ∫ Φ_{j} N̂_{k}"
                );
            }
        }
    }
}

/// The non-matching pairs of test 2, each used both ways round.
type Meshing = (FaceKind, [usize; 2]);
const NON_MATCHING: [(Meshing, Meshing); 5] = [
    ((FaceKind::Quad4, [3, 3]), (FaceKind::Quad4, [4, 4])),
    ((FaceKind::Tri3, [3, 2]), (FaceKind::Quad4, [4, 3])),
    ((FaceKind::Tri6, [2, 3]), (FaceKind::Quad8, [3, 2])),
    ((FaceKind::Quad8, [3, 2]), (FaceKind::Tri6, [2, 3])),
    ((FaceKind::Quad4, [3, 3]), (FaceKind::Tri6, [2, 2])),
];

#[test]
fn non_matching_flat_interfaces_transmit_consistent_loads_and_affine_fields_both_ways_round() {
    // Σ w = area, Σ_j w_j S_jk = ∫ N_k on the slave and Σ_j w_j P_jl = ∫ N_l on the master,
    // Σ P f = Σ S f for affine f: all to 1e-12 of the area (size 1).
    for ((kind_a, cells_a), (kind_b, cells_b)) in NON_MATCHING {
        for swapped in [false, true] {
            let mut builder = Builder::default();
            let a = builder.patch(kind_a, cells_a, plane(1.0, 0.0), !swapped, Perturb::None);
            let b = builder.patch(kind_b, cells_b, plane(1.0, 0.0), swapped, Perturb::None);
            let (slave, master) = if swapped { (&b, &a) } else { (&a, &b) };
            let label = format!("{} vs {}", slave[0].0, master[0].0);
            check_flat(&builder, slave, master, &label);
        }
    }
}

/// A rigid motion: rotation about the axis (1, 2, 3)/√14 by 0.7 rad, then a shift.
fn tilt(x: [f64; 3]) -> [f64; 3] {
    let axis = [1.0, 2.0, 3.0].map(|c: f64| c / 14f64.sqrt());
    let (sin, cos) = 0.7f64.sin_cos();
    let along = dot(axis, x);
    let across = crate::artifact::mesh::cross(axis, x);
    std::array::from_fn(|i| {
        x[i] * cos + across[i] * sin + axis[i] * along * (1.0 - cos) + [0.1, -0.2, 0.3][i]
    })
}

#[test]
fn parallel_surfaces_a_distance_apart_have_that_weighted_gap_everywhere_even_tilted() {
    // Every weighted gap equals h to 1e-13 m (faces of size 0.1 m).
    let h = 2e-3;
    for ((kind_a, cells_a), (kind_b, cells_b)) in NON_MATCHING {
        for tilted in [false, true] {
            let mut builder = Builder::default();
            let moved = |z: f64| {
                move |p: [f64; 2]| {
                    let x = plane(0.1, z)(p);
                    if tilted { tilt(x) } else { x }
                }
            };
            let slave = builder.patch(kind_a, cells_a, moved(0.0), true, Perturb::None);
            let master = builder.patch(kind_b, cells_b, moved(h), false, Perturb::None);
            let interface = build(&builder, &slave, &master).unwrap();
            assert!(!interface.rows.is_empty());
            for row in &interface.rows {
                assert!(
                    (row.gap - h).abs() < 1e-13,
                    "{kind_a} vs {kind_b}, tilted {tilted}: node {} gap {}",
                    row.node,
                    row.gap
                );
            }
            assert!((interface.largest_gap - h).abs() < 1e-13);
            assert_eq!(interface.largest_penetration, 0.0);
            assert!((interface.coverage - 1.0).abs() < 1e-12);
            assert!((interface.mean_cosine + 1.0).abs() < 1e-12);
        }
    }
}

#[test]
fn randomly_perturbed_meshes_transmit_consistent_loads_and_affine_fields() {
    // Triangles with each interior node moved, quadrilaterals with their interior grid lines
    // moved (so that they stay parallelograms, on which the rule is exact): 1e-12 of the area.
    for seed in 1..=4u64 {
        for (kind_a, cells_a, kind_b, cells_b) in [
            (FaceKind::Tri3, [6, 5], FaceKind::Quad4, [5, 7]),
            (FaceKind::Quad4, [7, 6], FaceKind::Tri3, [4, 6]),
            (FaceKind::Tri6, [4, 3], FaceKind::Quad8, [3, 5]),
            (FaceKind::Quad8, [5, 4], FaceKind::Tri6, [3, 3]),
            (FaceKind::Tri3, [5, 5], FaceKind::Tri6, [4, 3]),
        ] {
            let perturb = |kind: FaceKind, offset: u64| {
                if kind.n_corners() == 3 {
                    Perturb::Nodes(seed * 10 + offset)
                } else {
                    Perturb::Lines(seed * 10 + offset)
                }
            };
            let mut builder = Builder::default();
            let slave = builder.patch(kind_a, cells_a, plane(1.0, 0.0), true, perturb(kind_a, 1));
            let master = builder.patch(kind_b, cells_b, plane(1.0, 0.0), false, perturb(kind_b, 2));
            check_flat(
                &builder,
                &slave,
                &master,
                &format!("seed {seed}: {kind_a} vs {kind_b}"),
            );
        }
    }
}

#[test]
fn weighted_gaps_between_coaxial_cylinders_converge_to_the_true_gap() {
    // Slave: quad8 on r = 0.1 m (outward normal); master: tri6 on r = 0.101 m (normal inward),
    // meshed differently, 0.6 rad × 0.05 m. The largest error in g_j falls as h² (measured
    // 3.5e-6, 8.3e-7, 2.1e-7, 5.2e-8 m over four halvings; fitted log–log slope ≥ 1.9) and is
    // below 1e-4 of the gap at the finest; coverage 1 to 1e-12.
    let (inner, outer) = (0.1, 0.101);
    let cylinder = |radius: f64| {
        move |[s, t]: [f64; 2]| {
            let theta = 0.6 * s;
            [radius * theta.cos(), radius * theta.sin(), 0.05 * t]
        }
    };
    let mut errors = Vec::new();
    let refinements = [1usize, 2, 4, 8];
    for &k in &refinements {
        let mut builder = Builder::default();
        let slave = builder.patch(
            FaceKind::Quad8,
            [3 * k, 2 * k],
            cylinder(inner),
            true,
            Perturb::None,
        );
        let master = builder.patch(
            FaceKind::Tri6,
            [4 * k, 3 * k],
            cylinder(outer),
            false,
            Perturb::None,
        );
        let interface = build(&builder, &slave, &master).unwrap();
        assert!(
            (interface.coverage - 1.0).abs() < 1e-12,
            "{}",
            interface.coverage
        );
        assert!(interface.dropped.is_empty() && interface.partial_faces == 0);
        let error = interface
            .rows
            .iter()
            .map(|row| (row.gap - (outer - inner)).abs())
            .fold(0.0, f64::max);
        errors.push(error);
    }
    let rates: Vec<f64> = errors.windows(2).map(|e| (e[0] / e[1]).log2()).collect();
    eprintln!("cylinder gap errors {errors:?}, rates {rates:?}");
    let (n, mut sx, mut sy, mut sxx, mut sxy) = (errors.len() as f64, 0.0, 0.0, 0.0, 0.0);
    for (&k, &e) in refinements.iter().zip(&errors) {
        let (x, y) = ((k as f64).ln(), e.ln());
        (sx, sy, sxx, sxy) = (sx + x, sy + y, sxx + x * x, sxy + x * y);
    }
    let slope = -(n * sxy - sx * sy) / (n * sxx - sx * sx);
    assert!(slope >= 1.9, "slope {slope}: {errors:?}");
    assert!(
        errors[errors.len() - 1] < 1e-4 * (outer - inner),
        "{errors:?}"
    );
}

/// A unit quad4 slave face whose master quad4 faces cover x ≥ `from` only: the rows it gives.
fn over_the_edge(from: f64) -> (Builder, Interface) {
    let mut builder = Builder::default();
    let slave = builder.patch(
        FaceKind::Quad4,
        [1, 1],
        plane(1.0, 0.0),
        true,
        Perturb::None,
    );
    let master_map = |[s, t]: [f64; 2]| [from + 1.5 * s, -1.0 + 3.0 * t, 0.0];
    let master = builder.patch(FaceKind::Quad4, [2, 3], master_map, false, Perturb::None);
    let interface = build(&builder, &slave, &master).unwrap();
    (builder, interface)
}

#[test]
fn a_slave_face_half_over_the_master_edge_takes_the_dual_basis_of_its_covered_half() {
    // Coverage 0.5: weights ∫_covered N_j = 3/16 (x = 1) and 1/16 (x = 0), coverage 3/4 and
    // 1/4; each row one slave node, its master weights reproducing the node's position (the
    // patch test on the covered half), to 1e-14.
    let (builder, interface) = over_the_edge(0.5);
    assert!((interface.coverage - 0.5).abs() < 1e-14);
    assert!((interface.covered_area - 0.5).abs() < 1e-14);
    assert_eq!(interface.partial_faces, 1);
    assert!((interface.face_coverage[0] - 0.5).abs() < 1e-14);
    assert_eq!(interface.rows.len(), 4);
    for row in &interface.rows {
        let x = builder.coords[row.node as usize];
        let (weight, coverage) = if x[0] > 0.5 {
            (3.0 / 16.0, 0.75)
        } else {
            (1.0 / 16.0, 0.25)
        };
        assert!((row.weight - weight).abs() < 1e-14, "{x:?}: {}", row.weight);
        assert!((row.coverage - coverage).abs() < 1e-14);
        assert_eq!(row.slave, [(row.node, 1.0)]);
        let master_point = weighted_position(&builder.coords, &row.master);
        for axis in 0..3 {
            assert!(
                (master_point[axis] - x[axis]).abs() < 1e-14,
                "{x:?}: {master_point:?}"
            );
        }
        assert!(row.gap.abs() < 1e-14);
    }
    let weights: f64 = interface.rows.iter().map(|r| r.weight).sum();
    assert!((weights - 0.5).abs() < 1e-14);
}

#[test]
fn a_slave_face_barely_over_the_master_edge_takes_the_lumped_standard_basis() {
    // Coverage 1/4, below the dual's 1/2: weights ∫_covered N_j = 7/64 (x = 1) and 1/64
    // (x = 0); each row one slave node, its gap zero (the faces are coplanar); its master point
    // the N_j-weighted mean of the covered quarter, x̄ = ∫ x N_j / ∫ N_j (1e-14).
    let (builder, interface) = over_the_edge(0.75);
    assert!((interface.coverage - 0.25).abs() < 1e-14);
    assert_eq!(interface.rows.len(), 4);
    for row in &interface.rows {
        let x = builder.coords[row.node as usize];
        // ∫_{3/4}^1 x·x dx / ∫ x dx and ∫ x(1 − x) dx / ∫ (1 − x) dx.
        let (weight, mean_x) = if x[0] > 0.5 {
            (7.0 / 64.0, (37.0 / 192.0) / (7.0 / 32.0))
        } else {
            (1.0 / 64.0, (5.0 / 192.0) / (1.0 / 32.0))
        };
        assert!((row.weight - weight).abs() < 1e-14, "{x:?}: {}", row.weight);
        assert_eq!(row.slave, [(row.node, 1.0)]);
        let master_point = weighted_position(&builder.coords, &row.master);
        assert!(
            (master_point[0] - mean_x).abs() < 1e-14,
            "{x:?}: {master_point:?}"
        );
        assert!(row.gap.abs() < 1e-14);
    }
}

/// Σ w x of the weighted nodes.
fn weighted_position(coords: &[[f64; 3]], weights: &[(u32, f64)]) -> [f64; 3] {
    let mut point = [0.0; 3];
    for &(node, weight) in weights {
        for axis in 0..3 {
            point[axis] += weight * coords[node as usize][axis];
        }
    }
    point
}

#[test]
fn a_master_narrower_than_the_slave_receives_its_whole_consistent_load() {
    // Slave quad4 4×4 on the unit square; master tri3 over 0.3 ≤ x ≤ 0.8, its edges across
    // slave faces (partly covered). Σ w = covered area 0.5 and Σ_j w_j P_jl =
    // ∫ N_l dA on every master node, to 1e-12; every row weight positive.
    let mut builder = Builder::default();
    let slave = builder.patch(
        FaceKind::Quad4,
        [4, 4],
        plane(1.0, 0.0),
        true,
        Perturb::None,
    );
    let narrow = |[s, t]: [f64; 2]| [0.3 + 0.5 * s, t, 0.0];
    let master = builder.patch(FaceKind::Tri3, [3, 5], narrow, false, Perturb::Nodes(5));
    let interface = build(&builder, &slave, &master).unwrap();
    assert!((interface.covered_area - 0.5).abs() < 1e-12);
    assert_eq!(interface.partial_faces, 8);
    assert!(interface.dropped.is_empty());
    let weights: f64 = interface.rows.iter().map(|r| r.weight).sum();
    assert!((weights - 0.5).abs() < 1e-12, "{weights}");
    assert!(
        interface
            .rows
            .iter()
            .all(|r| r.weight > 0.0 && r.coverage > 0.0)
    );
    let (_, master_loads) = transmitted(&interface);
    let expected = consistent_loads(&builder.coords, &master);
    assert_eq!(master_loads.len(), expected.len());
    for ((node, got), (same, want)) in master_loads.iter().zip(&expected) {
        assert_eq!(node, same);
        assert!(
            (got - want).abs() < 1e-12,
            "master node {node}: {got} vs {want}"
        );
    }
}

#[test]
fn surfaces_that_cannot_be_paired_say_why() {
    let mut builder = Builder::default();
    let slave = builder.patch(
        FaceKind::Quad4,
        [2, 2],
        plane(1.0, 0.0),
        true,
        Perturb::None,
    );
    let master = builder.patch(
        FaceKind::Quad4,
        [2, 2],
        plane(1.0, 0.0),
        false,
        Perturb::None,
    );
    let far = builder.patch(
        FaceKind::Quad4,
        [2, 2],
        plane(1.0, 0.5),
        false,
        Perturb::None,
    );
    let aside = builder.patch(
        FaceKind::Tri3,
        [2, 2],
        |[s, t]| [3.0 + s, t, 0.0],
        false,
        Perturb::None,
    );
    let same_way = builder.patch(
        FaceKind::Quad4,
        [3, 3],
        plane(1.0, 1e-3),
        true,
        Perturb::None,
    );

    let message = |result: Result<Interface, MortarError>| result.unwrap_err().to_string();
    let error = message(build(&builder, &slave, &far));
    assert_eq!(
        error,
        "`pad` projects nowhere on `disc`: none of its 4 faces overlaps a master face within \
         the search distance 0.05 m"
    );
    assert!(message(build(&builder, &slave, &aside)).contains("projects nowhere"));
    assert_eq!(
        message(build(&builder, &[], &master)),
        "surface `pad` has no faces"
    );
    assert_eq!(
        message(build(&builder, &slave, &[])),
        "surface `disc` has no faces"
    );
    let error = message(build(&builder, &slave, &same_way));
    assert!(
        error.starts_with(
            "the normals of `pad` and `disc` do not oppose: their mean cosine is +1.000 over"
        ),
        "{error}"
    );

    // A face whose corners lie on one line, and faces that do not fit their kind.
    let mut degenerate = slave.clone();
    let flat = builder.coords.len() as u32;
    builder
        .coords
        .extend([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0]]);
    degenerate.push((FaceKind::Tri3, vec![flat, flat + 1, flat + 2]));
    degenerate.push((FaceKind::Tri3, vec![flat, flat, flat + 2]));
    let error = message(build(&builder, &degenerate, &master));
    assert_eq!(
        error,
        format!(
            "surface `pad`: 2 degenerate faces (zero area), the first with nodes [{}, {}, {}]",
            flat,
            flat + 1,
            flat + 2
        )
    );
    let invalid = vec![
        (FaceKind::Quad4, vec![0, 1, 2]),
        (FaceKind::Tri3, vec![0, 1, 1_000_000]),
    ];
    let error = message(build(&builder, &slave, &invalid));
    assert!(
        error.starts_with("surface `disc`: 2 faces with the wrong number"),
        "{error}"
    );

    let mut nan = Builder::default();
    let slave = nan.patch(
        FaceKind::Quad4,
        [2, 2],
        plane(1.0, 0.0),
        true,
        Perturb::None,
    );
    let master = nan.patch(
        FaceKind::Quad4,
        [2, 2],
        plane(1.0, 0.0),
        false,
        Perturb::None,
    );
    nan.coords[0][0] = f64::NAN;
    assert!(message(build(&nan, &slave, &master)).contains("1 degenerate faces"));
}

#[test]
fn the_interface_is_bit_identical_on_one_and_two_threads() {
    let mut builder = Builder::default();
    let slave = builder.patch(
        FaceKind::Quad4,
        [24, 20],
        plane(1.0, 0.0),
        true,
        Perturb::Lines(7),
    );
    let master = builder.patch(
        FaceKind::Tri6,
        [13, 17],
        plane(1.0, 1e-4),
        false,
        Perturb::Nodes(8),
    );
    let run = |threads: usize, par: Par| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let settings = Settings { par, ..settings() };
        let interface = pool
            .install(|| {
                interface(
                    &builder.coords,
                    &Surface {
                        name: "pad",
                        faces: slave.clone(),
                    },
                    &Surface {
                        name: "disc",
                        faces: master.clone(),
                    },
                    &settings,
                )
            })
            .unwrap();
        // Debug prints the shortest decimal that reads back to the same bits.
        format!("{interface:?}")
    };
    let one = run(1, Par::rayon(0));
    assert_eq!(one, run(2, Par::rayon(0)));
    assert_eq!(one, run(2, Par::Seq));
}

#[test]
fn points_project_onto_faces_of_each_kind_at_their_parameters_and_distance() {
    // A point d along the normal above x(ξ₀) projects back to ξ₀ (1e-10) at distance d
    // (1e-12 m), with weights N(ξ₀) summing to 1; quadratic faces curved (mid-edge nodes
    // lifted by 0.02 m).
    for kind in KINDS {
        let mut builder = Builder::default();
        let bulge = |[s, t]: [f64; 2]| {
            [
                0.3 * s + 0.05 * t,
                0.02 * s + 0.25 * t,
                0.08 * (s * (1.0 - s) + t * (1.0 - t)),
            ]
        };
        let faces = builder.patch(kind, [1, 1], bulge, true, Perturb::None);
        let surface = Surface {
            name: "disc",
            faces: faces.clone(),
        };
        let projector = Projector::new(&builder.coords, &surface, 0.1).unwrap();
        let xi0: [f64; 2] = if kind.n_corners() == 3 {
            [0.2, 0.3]
        } else {
            [0.3, -0.4]
        };
        let face = Face::new(faces[0].0, &builder.coords, &faces[0].1);
        let on = face.point(xi0);
        let normal = face.unit_normal(xi0).unwrap();
        for d in [0.0, 0.01, -0.004] {
            let point: [f64; 3] = std::array::from_fn(|i| on[i] + d * normal[i]);
            let projection = projector.project(point).unwrap();
            assert_eq!(projection.face, 0, "{kind}");
            assert!(
                (projection.xi[0] - xi0[0]).abs() < 1e-10
                    && (projection.xi[1] - xi0[1]).abs() < 1e-10,
                "{kind} {d}: {:?}",
                projection.xi
            );
            assert!((projection.distance - d.abs()).abs() < 1e-12, "{kind} {d}");
            let sum: f64 = projection.weights.iter().map(|w| w.1).sum();
            assert!((sum - 1.0).abs() < 1e-14, "{kind}");
            assert!(dot(projection.normal, normal) > 1.0 - 1e-12);
        }
        // Beyond the search distance: nothing, but `nearest` still finds it, 0.2 m away.
        let away: [f64; 3] = std::array::from_fn(|i| on[i] + 0.2 * normal[i]);
        assert!(projector.project(away).is_none(), "{kind}");
        let nearest = projector.nearest(away).unwrap();
        assert!((nearest.distance - 0.2).abs() < 1e-12, "{kind}");
        assert!((nearest.xi[0] - xi0[0]).abs() < 1e-10, "{kind}");
        assert!(project_point(&builder.coords, &surface, on, 0.1).is_some());
    }
    // On a mesh of many faces, a node's projection lands on the face under it.
    let mut builder = Builder::default();
    let faces = builder.patch(
        FaceKind::Tri3,
        [5, 4],
        plane(1.0, 0.0),
        true,
        Perturb::Nodes(3),
    );
    let surface = Surface {
        name: "disc",
        faces,
    };
    let projection = project_point(&builder.coords, &surface, [0.53, 0.41, 0.002], 0.01).unwrap();
    let mut x = [0.0; 3];
    for &(node, weight) in &projection.weights {
        (0..3).for_each(|i| x[i] += weight * builder.coords[node as usize][i]);
    }
    assert!(norm(sub(x, [0.53, 0.41, 0.0])) < 1e-14 && (projection.distance - 0.002).abs() < 1e-15);
    assert!(projection.weights.iter().all(|w| w.1 >= -1e-15));
}

#[test]
fn general_quadrilaterals_transmit_loads_within_the_rules_error() {
    // Quadrilaterals that are not parallelograms map the plane to ξ rationally, so the degree-5
    // rule is no longer exact on them: their side's loads agree with the consistent loads to
    // ~1e-7 (5 × 5 unit patch, nodal loads ~0.04; asserted 1e-6), the other side's and Σ w
    // still to round-off (1e-12).
    for (kind_a, kind_b) in [
        (FaceKind::Quad4, FaceKind::Tri3),
        (FaceKind::Tri3, FaceKind::Quad4),
        (FaceKind::Quad8, FaceKind::Tri6),
    ] {
        let mut builder = Builder::default();
        let slave = builder.patch(kind_a, [5, 5], plane(1.0, 0.0), true, Perturb::Nodes(3));
        let master = builder.patch(kind_b, [4, 6], plane(1.0, 0.0), false, Perturb::Nodes(4));
        let interface = build(&builder, &slave, &master).unwrap();
        let (slave_loads, master_loads) = transmitted(&interface);
        let largest_error = |loads: &[(u32, f64)], faces: &[(FaceKind, Vec<u32>)]| {
            let expected = consistent_loads(&builder.coords, faces);
            assert_eq!(loads.len(), expected.len());
            loads
                .iter()
                .zip(&expected)
                .map(|(a, b)| (a.1 - b.1).abs())
                .fold(0.0, f64::max)
        };
        let errors = [
            largest_error(&slave_loads, &slave),
            largest_error(&master_loads, &master),
        ];
        let quadrilateral = [kind_a.n_corners() == 4, kind_b.n_corners() == 4];
        for (error, quadrilateral) in errors.into_iter().zip(quadrilateral) {
            let tolerance = if quadrilateral { 1e-6 } else { 1e-12 };
            assert!(error < tolerance, "{kind_a} vs {kind_b}: {errors:?}");
        }
        let weights: f64 = interface.rows.iter().map(|r| r.weight).sum();
        assert!((weights - 1.0).abs() < 1e-12);
    }
}
