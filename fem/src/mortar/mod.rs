//! Mortar operators between two independently meshed surfaces: for each slave node, the slave
//! and master nodes it faces and their weights, from which contact takes weighted gaps and
//! slips and a tie its constraints. Pure geometry: nothing here knows a stage or a model.
//!
//! # Operators
//!
//! Slave surface S (the pad's contact faces, shape functions N_k), master surface M (the
//! disc's, N_l), π the projection of S onto M and a multiplier basis Φ_j on S, one function per
//! slave node:
//!
//! ```text
//! D_jk = ∫_S Φ_j N_k dA        M_jl = ∫_S Φ_j (N_l ∘ π) dA
//! ```
//!
//! Faces are oriented so that the right-hand rule on their corner cycle gives the outward
//! normal of their body: where the surfaces touch, the slave and master normals oppose.
//!
//! # Segments
//!
//! The integrals run over segments (Puso & Laursen 2004; Popp et al. 2010). For each slave
//! face, the auxiliary plane passes through its centre x₀ with its unit normal there, n₀. The
//! corners of the slave face and of each candidate master face are projected into the plane
//! along n₀; the master polygon, whose normal opposes, is reversed to turn the same way, and
//! clipped by the slave polygon (Sutherland–Hodgman; both convex). Each overlap is cut into
//! triangles from its vertices' centroid, with Radon's 7-point rule of degree 5 on each. A point
//! p of the plane maps back to ξ_s on the slave face and ξ_m on the master face with
//! x(ξ) − p ∥ n₀ (Newton on ξ; one step on flat faces of affine maps), and
//!
//! ```text
//! D_jk += w Φ_j(ξ_s) N_k(ξ_s)      M_jl += w Φ_j(ξ_s) N_l(ξ_m)
//! ```
//!
//! with w the rule's weight times the triangle's area: the measure is the plane's area, exact on
//! flat faces (the plane is the face) and within O(h²) of the surface's on curved ones.
//! Quadratic faces are clipped by their corners and integrate with their quadratic shape
//! functions. Only pairs whose normals oppose at their centres, −n₀ · n_m ≥
//! [`Settings::min_opposition`] (1/2: within 60°), are integrated; overlaps whose projected
//! area is below 10⁻¹² of the slave face's are ignored. [`Interface::slave_area`] is measured
//! the same way (each slave face's corner polygon in its own plane).
//!
//! # Multiplier basis
//!
//! Dual (Wohlmuth 2000): on a slave face, Φ = A N̂ with
//!
//! ```text
//! A = D̂ M̂⁻¹,   D̂ = diag(∫ N̂_j dA),   M̂ = [∫ N̂_i N̂_j dA]
//! ⇒ ∫ Φ_j N̂_k dA = δ_jk ∫ N̂_j dA,   Σ_j Φ_j = 1
//! ```
//!
//! Linear faces (tri3, quad4) take N̂ = N, so D is diagonal: D_jj = ∫ N_j dA. On quadratic faces
//! ∫ N_j is zero (tri6) or negative (quad8: −A/12) at the corners, which no positive multiplier
//! weight can come from, so the shape functions are first transformed (Popp, Gitterle, Gee &
//! Wall 2012), N̂ = T N with
//!
//! ```text
//! N̂_c = N_c + α (N_m + N_m')   (m, m' the mid-edge nodes of the two edges at corner c)
//! N̂_m = (1 − 2α) N_m,          α = 1/5
//! ```
//!
//! which keeps Σ N̂ = 1 and, on a flat face of straight edges of area A, gives ∫ N̂ = 2αA/3 at
//! tri6 corners, (2α/3 − 1/12) A at quad8 corners and (1 − 2α) A/3 at mid-edge nodes: all
//! positive for 1/8 < α < 1/2; α = 1/5 gives 2A/15, A/20 and A/5. D is reported against the
//! original N_k: D_jk = (T⁻¹)_kj ∫ N̂_j on a fully covered face, so a corner's row is its own
//! node and a mid-edge node's row reads 1/(1 − 2α) = 5/3 of itself and −α/(1 − 2α) = −1/3 of
//! each corner of its edge (as transforming the slave DOFs would).
//!
//! Each segment keeps the moments of its points, G = Σ w N Nᵀ (slave × slave) and
//! H = Σ w N N_mᵀ (slave × master); with Φ = Q N, Q = A T, its shares are D = Q G and M = Q H,
//! and the face's M̂ = T (Σ G) Tᵀ, D̂ = diag(T Σ w N). A therefore comes from the very points
//! of the segments, and biorthogonality holds to round-off whatever the rule's degree.
//!
//! # Partial coverage
//!
//! A slave face that the master covers only in part (its segments' area below 1 − 10⁻⁹ of its
//! own), where a pad overhangs the disc's edge, keeps D diagonal, so that every row of a linear
//! face stays one slave node against master nodes (Cichosz & Bischoff 2011, dual multipliers
//! at boundaries):
//!
//! - covered at least half, it takes the dual basis of its covered part: A = D̂ M̂⁻¹ with D̂
//!   and M̂ integrated over the segments only, which the moments above already are. The basis
//!   is biorthogonal on the covered part, Σ_j Φ_j = 1 there, and the covered part passes the
//!   patch test as a whole face does;
//! - covered less, M̂ of the covered sliver is too ill-conditioned to invert safely: the face
//!   takes the standard basis Φ = N̂ with D lumped onto its diagonal, D_jj = ∫_covered N̂_j.
//!   The master side's loads stay consistent (Σ_j Φ_j = 1), normal gaps on a flat interface
//!   stay exact, but a row's master point is the N̂_j-weighted mean of its covered support,
//!   not the node: an affine tangential motion shows a small slip there.
//!
//! A slave node's row weight is the covered integral of its multiplier and its coverage the
//! fraction of the whole one:
//!
//! ```text
//! w_j = Σ_k D_jk = ∫_covered Φ_j dA        coverage_j = w_j / D̄_j,   D̄_j = ∫_S Φ_j dA
//! ```
//!
//! (D̄_j = D_jj of a fully covered linear face.) Nodes whose coverage is below
//! [`Settings::min_coverage`] give no row and are listed in [`Interface::dropped`]; their share
//! of the covered area is then not transmitted.
//!
//! # Rows
//!
//! Each kept slave node j gives one row, normalised so that each side's weights sum to 1:
//!
//! ```text
//! S_jk = D_jk / w_j      P_jl = M_jl / Σ_l M_jl   (Σ_l M_jl = w_j since Σ_l N_l = 1)
//! g_j  = n_j · (Σ_l P_jl x_l − Σ_k S_jk x_k)      (weighted gap, > 0 when apart)
//! ```
//!
//! with n_j the slave nodal normal, the normalised sum over the slave faces at j of the face's
//! area times its unit normal at the node: it points from the slave towards the master. Slips
//! use the same rows on displacements. A row's multiplier λ_j (a pressure) acts as the force
//! w_j λ_j, spread as S_jk on the slave nodes and −P_jl on the master nodes. A uniform pressure
//! p therefore loads slave node k with p Σ_j w_j S_jk = p ∫_covered N_k dA and master node l with
//! p ∫_covered N_l dA: the consistent loads of both sides. Entries whose normalised magnitude is
//! below [`Settings::drop_below`] (the round-off of biorthogonality) are dropped and the rest
//! renormalised. Coincident meshes give S = P: the identity for linear faces (node to node),
//! the rows above for quadratic ones.
//!
//! # Search
//!
//! Candidate master faces of a slave face are those whose bounding boxes overlap its own
//! inflated by [`Settings::search_distance`], found on a uniform grid of cells of the mean
//! master face size: a slave face visits a few cells whatever the surface's size.
//!
//! # Ties by collocation
//!
//! [`Projector`] projects a point onto a surface: the closest point x(ξ*) of the nearest face
//! (Gauss–Newton on ½ |x(ξ) − p|²), with the weights N_l(ξ*) that tie a slave node to the
//! master face's nodes, u_s = Σ_l N_l(ξ*) u_l.
//!
//! # Determinism
//!
//! Slave faces are integrated independently (in parallel under [`Settings::par`]) and gathered
//! in face order; every sum runs in a fixed order, so rows are bit-identical whatever the
//! number of threads.

// Index loops follow the index notation of the formulas (D = Q G, M̂ = T G Tᵀ).
#![allow(clippy::needless_range_loop)]

mod dual;
mod geometry;
mod project;
mod search;

#[cfg(test)]
mod tests;

use faer::Par;
use rayon::prelude::*;

use crate::artifact::mesh::{dot, norm};
use crate::element::topology::FaceKind;
use geometry::{BoundingBox, Face, Guess, MAX_NODES, Plane, clip, for_each_point, project_along};
use search::Grid;

pub use project::{Projection, Projector, project_point};

/// One side of the interface: its name (for messages) and its faces, each a shape and its
/// nodes (indices into the coordinates) in the face's order.
#[derive(Debug, Clone)]
pub struct Surface<'a> {
    pub name: &'a str,
    pub faces: Vec<(FaceKind, Vec<u32>)>,
}

/// How [`interface`] pairs, integrates and keeps; the default suits a brake (a 1 mm search).
#[derive(Debug, Clone, Copy)]
pub struct Settings {
    /// How far apart (m) a slave and a master face may be and still be paired: the slave
    /// faces' bounding boxes are inflated by it.
    pub search_distance: f64,
    /// The smallest covered fraction w_j / D̄_j of a node's multiplier that gives a row.
    pub min_coverage: f64,
    /// Normalised row entries of smaller magnitude are dropped (the round-off of
    /// biorthogonality), the rest renormalised.
    pub drop_below: f64,
    /// Pairs are integrated where −n_s · n_m ≥ this at the faces' centres (0.5: normals within
    /// 60° of opposite), which keeps faces seen edge-on (a rim, a chamfer) out of the segments.
    pub min_opposition: f64,
    /// Parallelism over slave faces and nodes; the rows are the same either way.
    pub par: Par,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            search_distance: 1e-3,
            min_coverage: 1e-3,
            drop_below: 1e-13,
            min_opposition: 0.5,
            par: Par::rayon(0),
        }
    }
}

/// The constraint of one slave node: `Σ_l P_jl x_l − Σ_k S_jk x_k` along `normal`.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub node: u32,
    /// The slave nodal normal n_j (unit, from the slave towards the master).
    pub normal: [f64; 3],
    /// w_j (m²): the covered integral of the node's multiplier.
    pub weight: f64,
    /// w_j / D̄_j: 1 where the master covers all the node's faces.
    pub coverage: f64,
    /// The weighted gap g_j (m) at the given coordinates: > 0 apart, < 0 penetrating.
    pub gap: f64,
    /// S_jk by slave node, sorted; they sum to 1.
    pub slave: Vec<(u32, f64)>,
    /// P_jl by master node, sorted; they sum to 1.
    pub master: Vec<(u32, f64)>,
}

/// The operators of an interface and what a person checks them by.
#[derive(Debug, Clone, PartialEq)]
pub struct Interface {
    /// One row per slave node with enough coverage, by node.
    pub rows: Vec<Row>,
    /// Σ of the slave faces' areas in their auxiliary planes (m²; the true area when flat).
    pub slave_area: f64,
    /// Σ of the segments' areas (m²).
    pub covered_area: f64,
    /// covered_area / slave_area.
    pub coverage: f64,
    /// max(0, max_j g_j) (m).
    pub largest_gap: f64,
    /// max(0, max_j −g_j) (m).
    pub largest_penetration: f64,
    /// The covered fraction of each slave face, in face order.
    pub face_coverage: Vec<f64>,
    /// Slave faces covered in part (0 < fraction < 1): the dual basis of their covered part,
    /// or, covered less than half, the lumped standard basis.
    pub partial_faces: usize,
    /// The number of segments (slave face, master face overlaps) integrated.
    pub segments: usize,
    /// The mean cosine between slave and master normals over overlapping face pairs, by area
    /// (−1 for parallel opposed surfaces).
    pub mean_cosine: f64,
    /// Slave nodes with some coverage but less than [`Settings::min_coverage`]: no row.
    pub dropped: Vec<u32>,
}

/// Why an interface cannot be built: one line naming the surfaces and a count.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MortarError {
    #[error("surface `{surface}` has no faces")]
    EmptySurface { surface: String },
    #[error(
        "surface `{surface}`: {count} faces with the wrong number of nodes or a node out of \
         range (of {n_nodes} nodes), the first a {kind} with nodes {nodes:?}"
    )]
    InvalidFaces {
        surface: String,
        count: usize,
        kind: FaceKind,
        nodes: Vec<u32>,
        n_nodes: usize,
    },
    #[error(
        "surface `{surface}`: {count} degenerate faces (zero area), the first with nodes {nodes:?}"
    )]
    DegenerateFaces {
        surface: String,
        count: usize,
        nodes: Vec<u32>,
    },
    #[error("invalid mortar settings: {0}")]
    Settings(String),
    #[error(
        "the normals of `{slave}` and `{master}` do not oppose: their mean cosine is \
         {mean_cosine:+.3} over {pairs} overlapping face pairs (outward normals must face each \
         other)"
    )]
    NormalsDoNotOppose {
        slave: String,
        master: String,
        mean_cosine: f64,
        pairs: usize,
    },
    #[error(
        "`{slave}` projects nowhere on `{master}`: none of its {faces} faces overlaps a master \
         face within the search distance {search_distance} m"
    )]
    ProjectsNowhere {
        slave: String,
        master: String,
        faces: usize,
        search_distance: f64,
    },
    #[error(
        "{count} faces of `{slave}` do not project onto `{master}` (Newton fails: distorted \
         faces?), the first with nodes {nodes:?}"
    )]
    Projection {
        slave: String,
        master: String,
        count: usize,
        nodes: Vec<u32>,
    },
}

/// A surface's faces, checked, with what the integration needs of each.
struct Prepared<'a> {
    nodes: Vec<&'a [u32]>,
    faces: Vec<Face>,
    /// The auxiliary plane of each face (normal: the unit normal at the centre).
    planes: Vec<Plane>,
    /// Bounding boxes inflated by the margin given.
    boxes: Vec<BoundingBox>,
}

fn prepare<'a>(
    coords: &[[f64; 3]],
    surface: &'a Surface,
    margin: f64,
) -> Result<Prepared<'a>, MortarError> {
    if surface.faces.is_empty() {
        return Err(MortarError::EmptySurface {
            surface: surface.name.to_string(),
        });
    }
    let invalid: Vec<&(FaceKind, Vec<u32>)> = surface
        .faces
        .iter()
        .filter(|(kind, nodes)| {
            nodes.len() != kind.n_nodes() || nodes.iter().any(|&n| n as usize >= coords.len())
        })
        .collect();
    if let Some((kind, nodes)) = invalid.first() {
        return Err(MortarError::InvalidFaces {
            surface: surface.name.to_string(),
            count: invalid.len(),
            kind: *kind,
            nodes: nodes.clone(),
            n_nodes: coords.len(),
        });
    }
    let mut prepared = Prepared {
        nodes: Vec::with_capacity(surface.faces.len()),
        faces: Vec::with_capacity(surface.faces.len()),
        planes: Vec::with_capacity(surface.faces.len()),
        boxes: Vec::with_capacity(surface.faces.len()),
    };
    let mut degenerate: Vec<&[u32]> = Vec::new();
    for (kind, nodes) in &surface.faces {
        let face = Face::new(*kind, coords, nodes);
        let diameter = face.diameter();
        let plane = Plane::of(&face).filter(|plane| {
            geometry::signed_area(&plane.polygon(&face)) > 1e-12 * diameter * diameter
        });
        match plane {
            Some(plane) => {
                prepared.nodes.push(nodes);
                prepared.boxes.push(face.bounding_box(margin));
                prepared.faces.push(face);
                prepared.planes.push(plane);
            }
            None => degenerate.push(nodes),
        }
    }
    if let Some(nodes) = degenerate.first() {
        return Err(MortarError::DegenerateFaces {
            surface: surface.name.to_string(),
            count: degenerate.len(),
            nodes: nodes.to_vec(),
        });
    }
    Ok(prepared)
}

/// What one slave face contributes.
#[derive(Default)]
struct FaceOutput {
    /// D_jk over the face (n × n, by rows).
    slave: Vec<f64>,
    /// M_jl over each master face overlapping it (n × n_m, by rows).
    masters: Vec<(u32, Vec<f64>)>,
    /// ∫ Φ_j over the whole face.
    whole: Vec<f64>,
    /// The face's area times its unit normal at each node.
    normals: Vec<[f64; 3]>,
    area: f64,
    covered: f64,
    /// Σ overlap area × cosine and Σ overlap area over the overlapping pairs, and their number.
    cosine: f64,
    overlap: f64,
    pairs: usize,
    segments: usize,
}

/// Overlaps below this fraction of the slave face's area are ignored: clipping along shared
/// edges leaves slivers of round-off.
const SLIVER: f64 = 1e-12;

/// A slave face is fully covered when its segments fill it to this relative tolerance.
const FULL: f64 = 1e-9;

/// A slave face whose covered fraction is at least this takes the dual basis of its covered
/// part; a face covered less takes the lumped standard basis (module docs, Partial coverage).
const DUAL_COVERAGE: f64 = 0.5;

fn integrate_face(
    slave: &Prepared,
    face_idx: usize,
    master: &Prepared,
    grid: &Grid,
    &Settings {
        search_distance,
        min_opposition,
        ..
    }: &Settings,
) -> Result<FaceOutput, ()> {
    let face = &slave.faces[face_idx];
    let plane = &slave.planes[face_idx];
    let n = face.n_nodes();
    let polygon = plane.polygon(face);
    let area = geometry::signed_area(&polygon);
    let tolerance = 1e-12 * face.diameter();
    let mut output = FaceOutput {
        area,
        ..FaceOutput::default()
    };

    // Segments: the overlaps with the candidate master faces of opposed normal.
    let query = face.bounding_box(search_distance);
    let mut candidates = Vec::new();
    grid.candidates(&query, &mut candidates);
    let mut segments: Vec<(u32, Vec<[f64; 2]>)> = Vec::new();
    for &m in &candidates {
        let m_idx = m as usize;
        if !query.overlaps(&master.boxes[m_idx]) {
            continue;
        }
        let mut subject = plane.polygon(&master.faces[m_idx]);
        let projected = geometry::signed_area(&subject);
        if !(projected.abs() > SLIVER * area) {
            continue;
        }
        if projected < 0.0 {
            subject.reverse();
        }
        let piece = clip(&subject, &polygon, tolerance);
        if piece.len() < 3 {
            continue;
        }
        let piece_area = geometry::signed_area(&piece);
        if !(piece_area > SLIVER * area) {
            continue;
        }
        let cosine = dot(plane.normal, master.planes[m_idx].normal);
        output.cosine += piece_area * cosine;
        output.overlap += piece_area;
        output.pairs += 1;
        if -cosine >= min_opposition {
            output.covered += piece_area;
            segments.push((m, piece));
        }
    }
    output.segments = segments.len();
    let full = output.covered >= (1.0 - FULL) * area;

    // Moments of each segment: G = Σ w N Nᵀ (slave × slave), H = Σ w N N_mᵀ (slave × master),
    // over its points (w the weight, N and N_m the shape functions at the point's projections).
    let slave_guess = Guess::new(face, plane).ok_or(())?;
    let mut G_face = [[0.0; MAX_NODES]; MAX_NODES];
    let mut d_face = [0.0; MAX_NODES];
    let mut moments: Vec<(Vec<f64>, Vec<f64>)> = Vec::with_capacity(segments.len());
    let mut failed = false;
    for (m, piece) in &segments {
        let master_face = &master.faces[*m as usize];
        let n_m = master_face.n_nodes();
        let master_guess = Guess::new(master_face, plane).ok_or(())?;
        let mut G = vec![0.0; n * n];
        let mut H = vec![0.0; n * n_m];
        for_each_point(piece, |q, weight| {
            match (
                project_along(face, plane, &slave_guess, q),
                project_along(master_face, plane, &master_guess, q),
            ) {
                (Some(values), Some(master_values)) => {
                    for j in 0..n {
                        let weighted = weight * values[j];
                        d_face[j] += weighted;
                        for k in 0..n {
                            G[j * n + k] += weighted * values[k];
                        }
                        for l in 0..n_m {
                            H[j * n_m + l] += weighted * master_values[l];
                        }
                    }
                }
                _ => failed = true,
            }
        });
        for j in 0..n {
            for k in 0..n {
                G_face[j][k] += G[j * n + k];
            }
        }
        moments.push((G, H));
    }
    if failed {
        return Err(());
    }

    // The multiplier basis Φ = Q N, Q = Xᵀ T (A = Xᵀ): dual on the covered part of a face
    // covered enough (X = M̂⁻¹ D̂ with D̂ = T ∫N, M̂ = T G Tᵀ on the segments' own points),
    // standard (X = I, D lumped below) on a face covered less.
    let T = dual::matrix(face.kind);
    let dual = output.covered >= DUAL_COVERAGE * area;
    let mut covered = [0.0; MAX_NODES];
    let Q = if dual {
        let mut mass = [[0.0; MAX_NODES]; MAX_NODES];
        for i in 0..n {
            for j in 0..n {
                let mut sum = 0.0;
                for a in 0..n {
                    for b in 0..n {
                        sum += T[i][a] * G_face[a][b] * T[j][b];
                    }
                }
                mass[i][j] = sum;
            }
            covered[i] = (0..n).map(|a| T[i][a] * d_face[a]).sum();
        }
        let X = dual::dual_coefficients(n, &covered, &mass).ok_or(())?;
        let mut Q = [[0.0; MAX_NODES]; MAX_NODES];
        for j in 0..n {
            for k in 0..n {
                Q[j][k] = (0..n).map(|i| X[i][j] * T[i][k]).sum();
            }
        }
        Q
    } else {
        T
    };
    // D̄_j = ∫ N̂_j over the whole face, which a node's coverage is measured against.
    let whole = if full {
        covered
    } else {
        let mut whole = [0.0; MAX_NODES];
        for_each_point(&polygon, |q, weight| {
            match project_along(face, plane, &slave_guess, q) {
                Some(values) => {
                    let transformed = dual::transform(face.kind, &values);
                    for i in 0..n {
                        whole[i] += weight * transformed[i];
                    }
                }
                None => failed = true,
            }
        });
        whole
    };
    if failed {
        return Err(());
    }
    output.whole = whole[..n].to_vec();

    // D = Q G and M = Q H, by segment.
    let times_Q = |moment: &[f64], width: usize| -> Vec<f64> {
        let mut product = vec![0.0; n * width];
        for j in 0..n {
            for k in 0..n {
                let q = Q[j][k];
                if q != 0.0 {
                    for l in 0..width {
                        product[j * width + l] += q * moment[k * width + l];
                    }
                }
            }
        }
        product
    };
    output.slave = vec![0.0; n * n];
    for ((m, _), (G, H)) in segments.iter().zip(&moments) {
        let D = times_Q(G, n);
        for (total, value) in output.slave.iter_mut().zip(&D) {
            *total += value;
        }
        let n_m = master.faces[*m as usize].n_nodes();
        output.masters.push((*m, times_Q(H, n_m)));
    }
    if !dual {
        // Lumped: each row of D onto its own node, which keeps one slave node per row.
        for j in 0..n {
            let sum: f64 = output.slave[j * n..(j + 1) * n].iter().sum();
            output.slave[j * n..(j + 1) * n].fill(0.0);
            output.slave[j * n + j] = sum;
        }
    }
    output.normals = (0..n)
        .map(|a| {
            let normal = face
                .unit_normal(geometry::node_xi(face.kind, a))
                .unwrap_or(plane.normal);
            normal.map(|c| c * area)
        })
        .collect();
    Ok(output)
}

/// Sums the entries of each node (in the order given, so the sums do not depend on threads),
/// sorted by node.
fn merge(mut entries: Vec<(u32, f64)>) -> Vec<(u32, f64)> {
    entries.sort_by_key(|&(node, _)| node);
    let mut merged: Vec<(u32, f64)> = Vec::with_capacity(entries.len());
    for (node, value) in entries {
        match merged.last_mut() {
            Some((last, sum)) if *last == node => *sum += value,
            _ => merged.push((node, value)),
        }
    }
    merged
}

/// Entries divided by their sum, small ones dropped and the rest renormalised.
fn normalised(entries: &[(u32, f64)], total: f64, drop_below: f64) -> Vec<(u32, f64)> {
    let kept: Vec<(u32, f64)> = entries
        .iter()
        .map(|&(node, value)| (node, value / total))
        .filter(|&(_, value)| value.abs() >= drop_below)
        .collect();
    let sum: f64 = kept.iter().map(|&(_, value)| value).sum();
    kept.into_iter()
        .map(|(node, value)| (node, value / sum))
        .collect()
}

/// The mortar operators of `slave` against `master`, node coordinates `coords` (m).
pub fn interface(
    coords: &[[f64; 3]],
    slave: &Surface,
    master: &Surface,
    settings: &Settings,
) -> Result<Interface, MortarError> {
    for (name, value, low, high) in [
        (
            "search distance",
            settings.search_distance,
            0.0,
            f64::INFINITY,
        ),
        ("minimum coverage", settings.min_coverage, 0.0, 1.0),
        ("drop threshold", settings.drop_below, 0.0, 0.5),
        ("minimum opposition", settings.min_opposition, 0.0, 1.0),
    ] {
        if !(value >= low && value <= high && value.is_finite()) {
            return Err(MortarError::Settings(format!(
                "the {name} must be a finite number in [{low}, {high}], not {value}"
            )));
        }
    }
    let slave_faces = prepare(coords, slave, 0.0)?;
    let master_faces = prepare(coords, master, 0.0)?;
    let grid = Grid::new(&master_faces.boxes);

    let integrate = |f: usize| integrate_face(&slave_faces, f, &master_faces, &grid, settings);
    let outputs: Vec<Result<FaceOutput, ()>> = match settings.par {
        Par::Seq => (0..slave_faces.faces.len()).map(integrate).collect(),
        _ => (0..slave_faces.faces.len())
            .into_par_iter()
            .map(integrate)
            .collect(),
    };
    let failures: Vec<usize> = (0..outputs.len())
        .filter(|&f| outputs[f].is_err())
        .collect();
    if let Some(&first) = failures.first() {
        return Err(MortarError::Projection {
            slave: slave.name.to_string(),
            master: master.name.to_string(),
            count: failures.len(),
            nodes: slave_faces.nodes[first].to_vec(),
        });
    }
    let outputs: Vec<FaceOutput> = outputs.into_iter().flatten().collect();

    let (mut cosine, mut overlap, mut pairs) = (0.0, 0.0, 0);
    for output in &outputs {
        cosine += output.cosine;
        overlap += output.overlap;
        pairs += output.pairs;
    }
    let mean_cosine = if overlap > 0.0 { cosine / overlap } else { 0.0 };
    if pairs > 0 && mean_cosine > 0.0 {
        return Err(MortarError::NormalsDoNotOppose {
            slave: slave.name.to_string(),
            master: master.name.to_string(),
            mean_cosine,
            pairs,
        });
    }
    let covered_area: f64 = outputs.iter().map(|output| output.covered).sum();
    if !(covered_area > 0.0) {
        return Err(MortarError::ProjectsNowhere {
            slave: slave.name.to_string(),
            master: master.name.to_string(),
            faces: slave.faces.len(),
            search_distance: settings.search_distance,
        });
    }

    // Gather by slave node: each node reads its faces in face order, so the sums are the same
    // whichever thread gathers it.
    let mut slave_nodes: Vec<u32> = slave_faces
        .nodes
        .iter()
        .flat_map(|n| n.iter().copied())
        .collect();
    slave_nodes.sort_unstable();
    slave_nodes.dedup();
    let mut slot_of = vec![u32::MAX; coords.len()];
    for (slot, &node) in slave_nodes.iter().enumerate() {
        slot_of[node as usize] = slot as u32;
    }
    // (face, local node) of each slot, by slot, in face order.
    let mut start = vec![0usize; slave_nodes.len() + 1];
    for nodes in &slave_faces.nodes {
        for &node in nodes.iter() {
            start[slot_of[node as usize] as usize + 1] += 1;
        }
    }
    for slot in 0..slave_nodes.len() {
        start[slot + 1] += start[slot];
    }
    let mut fill = start.clone();
    let mut incidence = vec![(0u32, 0u8); start[slave_nodes.len()]];
    for (f, nodes) in slave_faces.nodes.iter().enumerate() {
        for (j, &node) in nodes.iter().enumerate() {
            let slot = slot_of[node as usize] as usize;
            incidence[fill[slot]] = (f as u32, j as u8);
            fill[slot] += 1;
        }
    }
    let gather = |slot: usize| -> Option<Result<Row, u32>> {
        let node = slave_nodes[slot];
        let mut whole = 0.0;
        let mut normal = [0.0; 3];
        let mut slave_row = Vec::new();
        let mut master_row = Vec::new();
        for &(f, j) in &incidence[start[slot]..start[slot + 1]] {
            let (output, j) = (&outputs[f as usize], j as usize);
            let nodes = slave_faces.nodes[f as usize];
            let n = nodes.len();
            whole += output.whole[j];
            for axis in 0..3 {
                normal[axis] += output.normals[j][axis];
            }
            for (k, &other) in nodes.iter().enumerate() {
                let value = output.slave[j * n + k];
                if value != 0.0 {
                    slave_row.push((other, value));
                }
            }
            for (m, block) in &output.masters {
                let master_nodes = master_faces.nodes[*m as usize];
                let n_m = master_nodes.len();
                for (l, &other) in master_nodes.iter().enumerate() {
                    let value = block[j * n_m + l];
                    if value != 0.0 {
                        master_row.push((other, value));
                    }
                }
            }
        }
        let slave_row = merge(slave_row);
        let master_row = merge(master_row);
        if slave_row.is_empty() && master_row.is_empty() {
            return None;
        }
        let weight: f64 = slave_row.iter().map(|&(_, value)| value).sum();
        let master_sum: f64 = master_row.iter().map(|&(_, value)| value).sum();
        let coverage = weight / whole;
        if !(coverage >= settings.min_coverage && master_sum > 0.0) {
            return Some(Err(node));
        }
        let length = norm(normal);
        let normal = normal.map(|c| c / length);
        let slave_row = normalised(&slave_row, weight, settings.drop_below);
        let master_row = normalised(&master_row, master_sum, settings.drop_below);
        let mut difference = [0.0; 3];
        for &(other, value) in &master_row {
            for axis in 0..3 {
                difference[axis] += value * coords[other as usize][axis];
            }
        }
        for &(other, value) in &slave_row {
            for axis in 0..3 {
                difference[axis] -= value * coords[other as usize][axis];
            }
        }
        Some(Ok(Row {
            node,
            normal,
            weight,
            coverage,
            gap: dot(normal, difference),
            slave: slave_row,
            master: master_row,
        }))
    };
    let gathered: Vec<Option<Result<Row, u32>>> = match settings.par {
        Par::Seq => (0..slave_nodes.len()).map(gather).collect(),
        _ => (0..slave_nodes.len()).into_par_iter().map(gather).collect(),
    };
    let mut rows = Vec::new();
    let mut dropped = Vec::new();
    for result in gathered.into_iter().flatten() {
        match result {
            Ok(row) => rows.push(row),
            Err(node) => dropped.push(node),
        }
    }

    let slave_area: f64 = outputs.iter().map(|output| output.area).sum();
    let largest_gap = rows.iter().map(|row| row.gap).fold(0.0, f64::max);
    let largest_penetration = rows.iter().map(|row| -row.gap).fold(0.0, f64::max);
    Ok(Interface {
        rows,
        slave_area,
        covered_area,
        coverage: covered_area / slave_area,
        largest_gap,
        largest_penetration,
        face_coverage: outputs.iter().map(|o| o.covered / o.area).collect(),
        partial_faces: outputs
            .iter()
            .filter(|o| o.covered > 0.0 && o.covered < (1.0 - FULL) * o.area)
            .count(),
        segments: outputs.iter().map(|o| o.segments).sum(),
        mean_cosine,
        dropped,
    })
}
