//! `mesh.brake`: a simplified railway (TGV-like) disc brake — an annular disc with pad pucks on
//! both faces — meshed with 8-node hexahedra.
//!
//! The disc is a structured annulus of `n_radial × n_theta × n_thick` cells. Each pad is a
//! `pucks_radial × pucks_angular` array of pucks centred at angle `pad_center_deg`; a puck
//! covers `puck_cells × puck_cells` disc face cells, separated by `puck_gap_cells`, and is
//! `puck_height` high in `puck_layers` layers. Pucks use the disc's (r, θ) grid, so each puck
//! node on the friction face coincides with a disc node: the two are distinct nodes (nothing
//! ties them but contact), and each such pair is a node-to-node contact pair. A pair carries
//! the disc's outward normal (±z) and the tributary area of its node, `∫ Nᵢ dA` over the puck's
//! friction-face cells ([`super::contact_faces`], as `mesh.gmsh` does).
//!
//! With `puck_divisions` other than 0 (or `puck_cells`), each puck is meshed on its own grid of
//! `puck_divisions × puck_divisions` cells over the same span (nodes at fractions of the disc's
//! cells): the friction faces no longer match, and the pucks are paired with the disc's
//! friction faces (then the whole faces, in `contact_disc`) by mortar
//! ([`super::mortar_pairs`]): the brake whose unstable modes should not depend on how its pads
//! are meshed.
//!
//! Node sets: `hub` (disc inner cylinder, clamped by default), `pad_backs` (outer faces of
//! the pucks: top of the upper ones, bottom of the lower ones), `pad_backs_upper`,
//! `pad_backs_lower`, `contact_disc`, `contact_pad`. Parts: `disc`, `pad`.
//! The default mesh has about 31,500 DOFs (before clamping), like the paper's model.

use std::collections::BTreeMap;
use std::f64::consts::PI;

use super::contact_faces::FaceIntegrals;
use super::mortar_pairs::mortar_pairs;
use super::structured::annulus;
use crate::artifact::{Artifact, ArtifactType};
use crate::artifact::{ContactPair, ElementKind, Mesh};
use crate::fem::faces::Side;
use crate::fem::mortar::Settings;
use crate::stage::{HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError};
use crate::table::Table;

crate::stage_params! {
    /// Geometry and resolution of the brake, in SI units: the parameters of `mesh.brake`.
    pub struct BrakeGeometry {
        /// disc inner radius (clamped hub)
        #[unit = "m"]
        #[min = 0.0]
        r_inner: f64 = 0.18,
        /// disc outer radius
        #[unit = "m"]
        #[min = 0.0]
        r_outer: f64 = 0.32,
        /// disc thickness
        #[unit = "m"]
        #[min = 0.0]
        thickness: f64 = 0.045,
        /// disc cells along the radius
        #[min = 1]
        n_radial: usize = 12,
        /// disc cells around the circumference
        #[min = 1]
        n_theta: usize = 180,
        /// disc cells through the thickness
        #[min = 1]
        n_thick: usize = 3,
        /// angular position of the pads (degrees)
        pad_center_deg: f64 = 90.0,
        /// pucks per pad along the radius
        #[min = 1]
        pucks_radial: usize = 3,
        /// pucks per pad around the circumference
        #[min = 1]
        pucks_angular: usize = 3,
        /// disc face cells covered by a puck, per direction
        #[min = 1]
        puck_cells: usize = 3,
        /// disc cells between pucks
        #[min = 0]
        puck_gap_cells: usize = 1,
        /// height of a puck
        #[unit = "m"]
        #[min = 0.0]
        puck_height: f64 = 0.02,
        /// puck cells through its height
        #[min = 1]
        puck_layers: usize = 3,
        /// cells across a puck's own mesh, per direction: 0 meshes it on the disc's grid (its friction face coincident with the disc's, paired node to node); another count meshes it independently, paired by mortar
        #[min = 0]
        puck_divisions: usize = 0,
    }
}

/// The declared defaults.
impl Default for BrakeGeometry {
    fn default() -> Self {
        Params::defaults(&MeshBrake, &[])
            .read::<MeshBrake>()
            .expect("the declared defaults read")
    }
}

impl BrakeGeometry {
    /// The coarse brake of the quick study and the tests: 2,484 DOFs.
    pub fn coarse() -> Self {
        BrakeGeometry {
            n_radial: 4,
            n_theta: 48,
            n_thick: 2,
            pucks_radial: 1,
            pucks_angular: 2,
            puck_cells: 2,
            puck_layers: 2,
            ..BrakeGeometry::default()
        }
    }

    /// The smallest brake of the tests (a few hundred DOFs, one puck a pad): small enough for
    /// dense reference solves of its linearised problem.
    pub fn small() -> Self {
        BrakeGeometry {
            n_radial: 3,
            n_theta: 24,
            n_thick: 1,
            pucks_radial: 1,
            pucks_angular: 1,
            puck_cells: 2,
            puck_layers: 1,
            ..BrakeGeometry::coarse()
        }
    }

    fn check(&self) -> Result<(), String> {
        if !(self.r_inner > 0.0 && self.r_outer > self.r_inner) {
            return Err(format!(
                "radii must satisfy 0 < r_inner < r_outer, got {} and {}",
                self.r_inner, self.r_outer
            ));
        }
        if !(self.thickness > 0.0 && self.puck_height > 0.0) {
            return Err("thickness and puck_height must be positive".into());
        }
        if self.n_theta < 8 {
            return Err(format!(
                "n_theta = {} is too coarse for a full turn (at least 8)",
                self.n_theta
            ));
        }
        let radial_span = self.pad_span(self.pucks_radial);
        if radial_span > self.n_radial {
            return Err(format!(
                "the pucks need {radial_span} radial cells but the disc has n_radial = {}",
                self.n_radial
            ));
        }
        let angular_span = self.pad_span(self.pucks_angular);
        if angular_span > self.n_theta / 2 {
            return Err(format!(
                "the pucks need {angular_span} angular cells, more than half of n_theta = {}",
                self.n_theta
            ));
        }
        Ok(())
    }

    /// Cells covered by `count` pucks and the gaps between them.
    /// Cells across a puck's mesh, per direction.
    fn divisions(&self) -> usize {
        if self.conforming() {
            self.puck_cells
        } else {
            self.puck_divisions
        }
    }

    fn pad_span(&self, count: usize) -> usize {
        count * self.puck_cells + count.saturating_sub(1) * self.puck_gap_cells
    }

    /// Index of the disc's node at radial `i`, angular `j` (wrapping) and thickness `k`.
    fn disc_node(&self, i: usize, j: usize, k: usize) -> u32 {
        ((k * self.n_theta + j % self.n_theta) * (self.n_radial + 1) + i) as u32
    }

    /// Position of the grid point at radial `i`, angular `j`, height `z`: the same formula as
    /// the annulus, so coincident nodes are bit-identical.
    fn position(&self, i: usize, j: usize, z: f64) -> [f64; 3] {
        self.position_between(i as f64, (j % self.n_theta) as f64, z)
    }

    /// [`Self::position`] at fractional grid coordinates (θ not wrapped).
    fn position_between(&self, i: f64, j: f64, z: f64) -> [f64; 3] {
        let r = self.r_inner + (self.r_outer - self.r_inner) * i / self.n_radial as f64;
        let theta = 2.0 * PI * j / self.n_theta as f64;
        [r * theta.cos(), r * theta.sin(), z]
    }

    /// Whether the pucks are meshed on the disc's grid (coincident friction faces).
    pub fn conforming(&self) -> bool {
        self.puck_divisions == 0 || self.puck_divisions == self.puck_cells
    }
}

/// One face of the disc that pads press on.
struct FrictionFace {
    upper: bool,
    /// Heights of the friction face and of the pucks' backs.
    friction_z: f64,
    back_z: f64,
    /// The disc's layer of nodes on this face.
    disc_layer: usize,
}

/// Builds the brake mesh. See the module documentation for the layout and the named sets.
pub fn brake(geometry: &BrakeGeometry) -> Result<Mesh, String> {
    geometry.check()?;
    let g = geometry;
    let mut mesh = annulus(
        g.r_inner,
        g.r_outer,
        0.0,
        g.thickness,
        [g.n_radial, g.n_theta, g.n_thick],
        "disc",
    );
    mesh.parts.push("pad".into());
    let first_radial = (g.n_radial - g.pad_span(g.pucks_radial)) / 2;
    let cell_deg = 360.0 / g.n_theta as f64;
    let center_cell = (g.pad_center_deg.rem_euclid(360.0) / cell_deg).round() as usize;
    let first_angular = center_cell + g.n_theta - g.pad_span(g.pucks_angular) / 2;

    let mut sets: BTreeMap<&str, Vec<u32>> = BTreeMap::new();
    for upper in [true, false] {
        let face = if upper {
            FrictionFace {
                upper,
                friction_z: g.thickness,
                back_z: g.thickness + g.puck_height,
                disc_layer: g.n_thick,
            }
        } else {
            FrictionFace {
                upper,
                friction_z: 0.0,
                back_z: -g.puck_height,
                disc_layer: 0,
            }
        };
        for puck_r in 0..g.pucks_radial {
            for puck_a in 0..g.pucks_angular {
                let i0 = first_radial + puck_r * (g.puck_cells + g.puck_gap_cells);
                let j0 = first_angular + puck_a * (g.puck_cells + g.puck_gap_cells);
                add_puck(&mut mesh, &mut sets, g, &face, (i0, j0));
            }
        }
    }
    if !g.conforming() {
        // The pucks' own meshes meet the disc's friction faces anywhere on them.
        let faces = sets.entry("contact_disc").or_default();
        for k in [0, g.n_thick] {
            for j in 0..g.n_theta {
                faces.extend((0..=g.n_radial).map(|i| g.disc_node(i, j, k)));
            }
        }
    }
    let hub = mesh
        .node_sets
        .remove("inner")
        .expect("annulus names its inner face");
    mesh.node_sets.clear();
    mesh.node_sets.insert("hub".into(), hub);
    for (name, mut nodes) in sets {
        nodes.sort_unstable();
        mesh.node_sets.insert(name.into(), nodes);
    }
    if !g.conforming() {
        let side = |name: &'static str| Side::new(name, mesh.node_sets[name].iter().copied());
        let (pairs, _) = mortar_pairs(
            &mesh,
            &side("contact_disc"),
            &side("contact_pad"),
            Settings::default().search_distance,
        )?;
        mesh.contact_pairs = pairs;
    }
    Ok(mesh)
}

/// Adds the puck whose first friction-face cell is at grid `(i0, j0)`: its nodes and
/// hexahedra, its contact pairs with the disc, and its nodes to the named sets.
fn add_puck(
    mesh: &mut Mesh,
    sets: &mut BTreeMap<&str, Vec<u32>>,
    g: &BrakeGeometry,
    face: &FrictionFace,
    (i0, j0): (usize, usize),
) {
    let FrictionFace {
        upper,
        friction_z,
        back_z,
        disc_layer,
    } = *face;
    let divisions = g.divisions();
    let n_side = divisions + 1;
    let base = mesh.nodes.len() as u32;
    // Layer 0 is always the friction face; layers go away from the disc.
    let puck_node =
        |di: usize, dj: usize, layer: usize| base + ((layer * n_side + dj) * n_side + di) as u32;
    // A puck's own grid line d, in the disc's grid coordinates.
    let own = |first: usize, d: usize| first as f64 + (d * g.puck_cells) as f64 / divisions as f64;
    for layer in 0..=g.puck_layers {
        let z = friction_z + (back_z - friction_z) * layer as f64 / g.puck_layers as f64;
        for dj in 0..n_side {
            for di in 0..n_side {
                mesh.nodes.push(if g.conforming() {
                    g.position(i0 + di, j0 + dj, z)
                } else {
                    g.position_between(own(i0, di), own(j0, dj), z)
                });
            }
        }
    }
    for layer in 0..g.puck_layers {
        for dj in 0..divisions {
            for di in 0..divisions {
                // Upper pucks grow along +z and lower ones along −z: swap the bottom and top
                // faces of the lower ones to keep det J > 0.
                let (below, above) = if upper {
                    (layer, layer + 1)
                } else {
                    (layer + 1, layer)
                };
                let corner =
                    |ddi: usize, ddj: usize, level: usize| puck_node(di + ddi, dj + ddj, level);
                mesh.elements.push(
                    ElementKind::Hex8,
                    1,
                    &[
                        corner(0, 0, below),
                        corner(1, 0, below),
                        corner(1, 1, below),
                        corner(0, 1, below),
                        corner(0, 0, above),
                        corner(1, 0, above),
                        corner(1, 1, above),
                        corner(0, 1, above),
                    ],
                );
            }
        }
    }
    let back_set = if upper {
        "pad_backs_upper"
    } else {
        "pad_backs_lower"
    };
    for dj in 0..n_side {
        for di in 0..n_side {
            sets.entry("contact_pad")
                .or_default()
                .push(puck_node(di, dj, 0));
            let back = puck_node(di, dj, g.puck_layers);
            sets.entry(back_set).or_default().push(back);
            sets.entry("pad_backs").or_default().push(back);
        }
    }
    if !g.conforming() {
        return;
    }
    // Tributary areas of the disc's friction-face nodes (its outward normal ±z is exact: the
    // face is plane).
    let mut integrals = FaceIntegrals::default();
    for dj in 0..g.puck_cells {
        for di in 0..g.puck_cells {
            // Radial then angular: counter-clockwise seen from +z.
            let mut corners = [(di, dj), (di + 1, dj), (di + 1, dj + 1), (di, dj + 1)];
            if !upper {
                corners.reverse();
            }
            integrals.add(
                corners.map(|(a, b)| g.disc_node(i0 + a, j0 + b, disc_layer)),
                &corners.map(|(a, b)| g.position(i0 + a, j0 + b, friction_z)),
            );
        }
    }
    let normal = if upper {
        [0.0, 0.0, 1.0]
    } else {
        [0.0, 0.0, -1.0]
    };
    for dj in 0..n_side {
        for di in 0..n_side {
            let disc = g.disc_node(i0 + di, j0 + dj, disc_layer);
            mesh.contact_pairs.push(ContactPair::node_to_node(
                disc,
                puck_node(di, dj, 0),
                normal,
                integrals.area_sums[&disc],
            ));
            sets.entry("contact_disc").or_default().push(disc);
        }
    }
}

/// The `mesh.brake` stage.
pub struct MeshBrake;

impl HasParams for MeshBrake {
    type Params = BrakeGeometry;
}

impl Stage for MeshBrake {
    fn kind(&self) -> &'static str {
        "mesh.brake"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Parametric disc brake: annular disc with pad pucks on both faces, paired node to node, or by mortar when the pucks are meshed on their own"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        Vec::new()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        vec![
            PortSpec::one(
                "mesh",
                ArtifactType::Mesh,
                "nodes, hexahedra, parts, node sets, contact pairs",
            ),
            PortSpec::one(
                "summary",
                ArtifactType::Table,
                "counts of nodes, elements, DOFs and contact pairs",
            ),
        ]
    }
    fn run(&self, params: &Params, _inputs: &Inputs) -> Result<Outputs, StageError> {
        let geometry = params.read::<Self>()?;
        let mesh = brake(&geometry).map_err(StageError::new)?;
        let summary = Table::new()
            .with(
                "quantity",
                ["nodes", "hexahedra", "dofs", "contact_pairs"]
                    .map(String::from)
                    .to_vec(),
            )
            .with(
                "count",
                vec![
                    mesh.n_nodes() as i64,
                    mesh.elements.len() as i64,
                    mesh.n_dofs() as i64,
                    mesh.contact_pairs.len() as i64,
                ],
            );
        Ok(Outputs::from([
            ("mesh".to_string(), Artifact::Mesh(Box::new(mesh))),
            ("summary".to_string(), Artifact::Table(summary)),
        ]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn coarse() -> BrakeGeometry {
        BrakeGeometry::coarse()
    }

    #[test]
    fn default_mesh_has_about_thirty_thousand_dofs() {
        let mesh = brake(&BrakeGeometry::default()).unwrap();
        assert!(
            (30_000..33_000).contains(&mesh.n_dofs()),
            "{} DOFs",
            mesh.n_dofs()
        );
        assert_eq!(mesh.contact_pairs.len(), 2 * 9 * 16);
        assert!(brake(&coarse()).unwrap().n_dofs() < 3_000);
    }

    #[test]
    fn contact_pairs_are_coincident_distinct_and_cover_the_pucks() {
        let g = coarse();
        let mesh = brake(&g).unwrap();
        for pair in &mesh.contact_pairs {
            assert!(pair.is_node_to_node());
            assert_ne!(pair.disc[0].0, pair.pad_node());
            let (a, b) = (
                pair.disc_position(&mesh.nodes),
                pair.pad_position(&mesh.nodes),
            );
            assert_eq!(a, b);
            let expected_z = if pair.normal[2] > 0.0 {
                g.thickness
            } else {
                0.0
            };
            assert_eq!(a[2], expected_z);
        }
        // Tributary areas add up to the puck faces: 2 pads × 2 pucks × 2×2 cells.
        let cell = |i: usize| {
            let r0 = g.r_inner + (g.r_outer - g.r_inner) * i as f64 / g.n_radial as f64;
            let r1 = g.r_inner + (g.r_outer - g.r_inner) * (i + 1) as f64 / g.n_radial as f64;
            0.5 * (2.0 * PI / g.n_theta as f64).sin() * (r1 * r1 - r0 * r0)
        };
        let first_radial = (g.n_radial - 2) / 2;
        let puck_face = 2.0 * (cell(first_radial) + cell(first_radial + 1));
        let total: f64 = mesh.contact_pairs.iter().map(|pair| pair.area).sum();
        assert!(
            (total - 4.0 * puck_face).abs() < 1e-12,
            "{total} vs {}",
            4.0 * puck_face
        );
    }

    #[test]
    fn every_element_has_positive_volume_and_sets_are_named() {
        let mesh = brake(&coarse()).unwrap();
        let volume = |hex: &[u32]| {
            let p = |idx: usize| mesh.nodes[hex[idx] as usize];
            let (a, b, d, e) = (p(0), p(1), p(3), p(4));
            let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let v = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
            let w = [e[0] - a[0], e[1] - a[1], e[2] - a[2]];
            u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
                + u[2] * (v[0] * w[1] - v[1] * w[0])
        };
        assert!(
            mesh.elements
                .iter()
                .all(|element| volume(element.nodes) > 0.0)
        );
        for name in [
            "hub",
            "pad_backs",
            "pad_backs_upper",
            "pad_backs_lower",
            "contact_disc",
            "contact_pad",
        ] {
            assert!(!mesh.node_sets[name].is_empty(), "{name}");
        }
        assert_eq!(mesh.parts, ["disc", "pad"]);
        let pad_elements = mesh
            .elements
            .parts()
            .iter()
            .filter(|part| **part == 1)
            .count();
        assert_eq!(pad_elements, 2 * 2 * 4 * 2);
    }

    /// Pucks meshed finer and coarser than the disc: every pad node paired by mortar, the
    /// pairs' areas adding up to the pucks' friction faces, no pad node on a disc node.
    #[test]
    fn pucks_meshed_on_their_own_are_paired_by_mortar_over_their_whole_faces() {
        for divisions in [1, 3, 5] {
            let g = BrakeGeometry {
                puck_divisions: divisions,
                ..coarse()
            };
            let mesh = brake(&g).unwrap();
            let pad_nodes = 2 * 2 * (divisions + 1) * (divisions + 1);
            assert_eq!(mesh.node_sets["contact_pad"].len(), pad_nodes);
            assert_eq!(mesh.contact_pairs.len(), pad_nodes, "{divisions} divisions");
            // The pairs cover the pucks' friction faces whole (polygons of chords, which
            // differ from the conforming pucks' where their chords do).
            let side = |name: &'static str| Side::new(name, mesh.node_sets[name].iter().copied());
            let (_, coverage) =
                mortar_pairs(&mesh, &side("contact_disc"), &side("contact_pad"), 1e-3).unwrap();
            assert!((coverage.covered - 1.0).abs() < 1e-12, "{coverage:?}");
            let pad_area: f64 = mesh.contact_pairs.iter().map(|pair| pair.area).sum();
            assert!((pad_area - coverage.slave_area).abs() < 1e-12 * pad_area);
            for pair in &mesh.contact_pairs {
                let gap = crate::artifact::mesh::dot(
                    pair.normal,
                    crate::artifact::mesh::sub(
                        pair.pad_position(&mesh.nodes),
                        pair.disc_position(&mesh.nodes),
                    ),
                );
                assert!(gap.abs() < 1e-15, "{pair:?}: gap {gap}");
            }
            let pad_elements = mesh.elements.parts().iter().filter(|p| **p == 1).count();
            assert_eq!(pad_elements, 2 * 2 * divisions * divisions * 2);
        }
    }

    #[test]
    fn pucks_that_do_not_fit_are_an_error() {
        let geometry = BrakeGeometry {
            n_radial: 4,
            pucks_radial: 3,
            ..coarse()
        };
        assert_eq!(
            brake(&geometry).unwrap_err(),
            "the pucks need 8 radial cells but the disc has n_radial = 4"
        );
    }
}
