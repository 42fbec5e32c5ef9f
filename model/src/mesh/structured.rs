//! Structured hexahedral meshes: a rectangular block, an annulus (a disc with a hole) and two
//! blocks stacked in contact. Building blocks for `mesh.brake` and for verification cases
//! (cantilevers, plates, bars in series).

use std::collections::BTreeMap;

use crate::artifact::mesh::ContactPair;
use crate::artifact::{ElementKind, Elements, Mesh};

/// A block [0, lx] × [0, ly] × [0, lz] with nx × ny × nz hexahedra, all in part `part`.
/// Node sets: `x0`, `x1`, `y0`, `y1`, `z0`, `z1` (the six faces).
pub fn block(lengths: [f64; 3], counts: [usize; 3], part: &str) -> Mesh {
    let [nx, ny, nz] = counts;
    let node = |i: usize, j: usize, k: usize| ((k * (ny + 1) + j) * (nx + 1) + i) as u32;
    let mut nodes = Vec::with_capacity((nx + 1) * (ny + 1) * (nz + 1));
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                nodes.push([
                    lengths[0] * i as f64 / nx as f64,
                    lengths[1] * j as f64 / ny as f64,
                    lengths[2] * k as f64 / nz as f64,
                ]);
            }
        }
    }
    let mut hexes = Vec::with_capacity(nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                hexes.push(hex(&|di, dj, dk| node(i + di, j + dj, k + dk)));
            }
        }
    }
    let mut node_sets = BTreeMap::new();
    let mut face = |name: &str, on_face: &dyn Fn(usize, usize, usize) -> bool| {
        let mut set = Vec::new();
        for k in 0..=nz {
            for j in 0..=ny {
                for i in 0..=nx {
                    if on_face(i, j, k) {
                        set.push(node(i, j, k));
                    }
                }
            }
        }
        set.sort_unstable();
        node_sets.insert(name.to_string(), set);
    };
    face("x0", &|i, _, _| i == 0);
    face("x1", &|i, _, _| i == nx);
    face("y0", &|_, j, _| j == 0);
    face("y1", &|_, j, _| j == ny);
    face("z0", &|_, _, k| k == 0);
    face("z1", &|_, _, k| k == nz);
    Mesh {
        nodes,
        elements: hexahedra(&hexes, 0),
        parts: vec![part.into()],
        node_sets,
        contact_pairs: Vec::new(),
    }
}

/// An annulus r ∈ [r_inner, r_outer], z ∈ [z0, z0 + thickness], full turn, with
/// n_r × n_theta × n_z hexahedra in part `part`.
/// Node sets: `inner`, `outer` (cylindrical faces), `bottom`, `top` (flat faces).
pub fn annulus(
    r_inner: f64,
    r_outer: f64,
    z0: f64,
    thickness: f64,
    counts: [usize; 3],
    part: &str,
) -> Mesh {
    let [n_r, n_theta, n_z] = counts;
    let node = |i: usize, j: usize, k: usize| ((k * n_theta + j % n_theta) * (n_r + 1) + i) as u32;
    let mut nodes = Vec::with_capacity((n_r + 1) * n_theta * (n_z + 1));
    for k in 0..=n_z {
        for j in 0..n_theta {
            let theta = 2.0 * std::f64::consts::PI * j as f64 / n_theta as f64;
            for i in 0..=n_r {
                let r = r_inner + (r_outer - r_inner) * i as f64 / n_r as f64;
                nodes.push([
                    r * theta.cos(),
                    r * theta.sin(),
                    z0 + thickness * k as f64 / n_z as f64,
                ]);
            }
        }
    }
    let mut hexes = Vec::with_capacity(n_r * n_theta * n_z);
    for k in 0..n_z {
        for j in 0..n_theta {
            for i in 0..n_r {
                // (ξ, η, ζ) along (r, θ, z): right-handed, so det J > 0.
                hexes.push(hex(&|di, dj, dk| node(i + di, j + dj, k + dk)));
            }
        }
    }
    let mut node_sets = BTreeMap::new();
    let mut set = |name: &str, on_face: &dyn Fn(usize, usize) -> bool| {
        let mut nodes = Vec::new();
        for k in 0..=n_z {
            for j in 0..n_theta {
                for i in 0..=n_r {
                    if on_face(i, k) {
                        nodes.push(node(i, j, k));
                    }
                }
            }
        }
        nodes.sort_unstable();
        node_sets.insert(name.to_string(), nodes);
    };
    set("inner", &|i, _| i == 0);
    set("outer", &|i, _| i == n_r);
    set("bottom", &|_, k| k == 0);
    set("top", &|_, k| k == n_z);
    Mesh {
        nodes,
        elements: hexahedra(&hexes, 0),
        parts: vec![part.into()],
        node_sets,
        contact_pairs: Vec::new(),
    }
}

/// 8-node hexahedra, all in part `part`.
pub fn hexahedra(hexes: &[[u32; 8]], part: u32) -> Elements {
    let mut elements = Elements::new();
    for hex in hexes {
        elements.push(ElementKind::Hex8, part, hex);
    }
    elements
}

/// The eight nodes of the cell at offsets (di, dj, dk) ∈ {0, 1}³ in hexahedron order.
fn hex(node: &dyn Fn(usize, usize, usize) -> u32) -> [u32; 8] {
    [
        node(0, 0, 0),
        node(1, 0, 0),
        node(1, 1, 0),
        node(0, 1, 0),
        node(0, 0, 1),
        node(1, 0, 1),
        node(1, 1, 1),
        node(0, 1, 1),
    ]
}

/// A disc block (base `base`) under a pad block (back `pad_backs`), both `width` square,
/// stacked along z with node-to-node pairs on the shared face, one metre off the axis
/// (for a sliding direction).
pub fn stacked_blocks(width: f64, l_disc: f64, l_pad: f64) -> Mesh {
    let mut disc = block([width, width, l_disc], [2, 2, 3], "disc");
    let pad = block([width, width, l_pad], [2, 2, 2], "pad");
    // Move the pair away from the rotation axis (for a sliding direction) and stack them.
    let offset = 1.0;
    for node in &mut disc.nodes {
        node[0] += offset;
    }
    let n_disc = disc.nodes.len() as u32;
    disc.nodes.extend(
        pad.nodes
            .iter()
            .map(|p| [p[0] + offset, p[1], p[2] + l_disc]),
    );
    disc.elements.extend_shifted(&pad.elements, n_disc, 1);
    disc.parts.push("pad".into());
    let top = disc.node_sets["z1"].clone();
    let pad_bottom: Vec<u32> = pad.node_sets["z0"]
        .iter()
        .map(|node| node + n_disc)
        .collect();
    let cell = width / 2.0;
    for (&disc_node, &pad_node) in top.iter().zip(&pad_bottom) {
        let x = disc.nodes[disc_node as usize];
        let corners = |c: f64| {
            if (c - offset).abs() < 1e-12
                || (c - offset - width).abs() < 1e-12
                || c.abs() < 1e-12
                || (c - width).abs() < 1e-12
            {
                0.5
            } else {
                1.0
            }
        };
        let area = cell * cell * corners(x[0]) * corners(x[1]);
        disc.contact_pairs.push(ContactPair::node_to_node(
            disc_node,
            pad_node,
            [0.0, 0.0, 1.0],
            area,
        ));
    }
    let pad_top: Vec<u32> = pad.node_sets["z1"]
        .iter()
        .map(|node| node + n_disc)
        .collect();
    let disc_bottom = disc.node_sets["z0"].clone();
    disc.node_sets = BTreeMap::from([
        ("base".to_string(), disc_bottom),
        ("pad_backs".to_string(), pad_top),
    ]);
    disc
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Volume of a hexahedron with planar faces, by splitting it into six tetrahedra.
    fn hex_volume(mesh: &Mesh, hex: &[u32]) -> f64 {
        let p = |idx: usize| mesh.nodes[hex[idx] as usize];
        let tet = |a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]| {
            let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let w = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
            (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
                + u[2] * (v[0] * w[1] - v[1] * w[0]))
                / 6.0
        };
        [
            [0, 1, 2, 6],
            [0, 2, 3, 6],
            [0, 3, 7, 6],
            [0, 7, 4, 6],
            [0, 4, 5, 6],
            [0, 5, 1, 6],
        ]
        .iter()
        .map(|&[a, b, c, d]| tet(p(a), p(b), p(c), p(d)))
        .sum()
    }

    #[test]
    fn block_cells_are_positive_and_fill_the_box() {
        let mesh = block([2.0, 0.5, 0.25], [8, 2, 1], "steel");
        assert_eq!(mesh.nodes.len(), 9 * 3 * 2);
        let volumes: Vec<f64> = mesh
            .elements
            .iter()
            .map(|element| hex_volume(&mesh, element.nodes))
            .collect();
        assert!(volumes.iter().all(|volume| *volume > 0.0));
        assert!((volumes.iter().sum::<f64>() - 0.25).abs() < 1e-12);
        assert_eq!(mesh.node_sets["x0"].len(), 3 * 2);
    }

    #[test]
    fn annulus_cells_are_positive_and_close_the_turn() {
        let mesh = annulus(0.1, 0.3, 0.0, 0.02, [4, 32, 2], "disc");
        assert_eq!(mesh.nodes.len(), 5 * 32 * 3);
        assert!(
            mesh.elements
                .iter()
                .all(|element| hex_volume(&mesh, element.nodes) > 0.0)
        );
        // Chords underestimate the circle: area of the polygonal annulus.
        let polygon = 0.5
            * 32.0
            * (2.0 * std::f64::consts::PI / 32.0).sin()
            * (0.3f64.powi(2) - 0.1f64.powi(2));
        let volume: f64 = mesh
            .elements
            .iter()
            .map(|element| hex_volume(&mesh, element.nodes))
            .sum();
        assert!((volume - polygon * 0.02).abs() < 1e-12 * volume.max(1.0));
        assert_eq!(mesh.node_sets["inner"].len(), 32 * 3);
    }
}
