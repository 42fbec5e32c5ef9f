//! The pressure on the pad backs and the floating bodies it pushes.
//!
//! - [`pressure_load`]: consistent nodal forces of a pressure p on the boundary faces whose
//!   nodes all lie in a node set, faces of any shape: node a receives
//!   f_a = −p ∫ N_a (x_u × x_v) du dv, the traction −p n pushing into the body (n the outward
//!   normal), by rules exact on straight-edged faces ([`crate::fem::faces`]): Σ_a f_a = −p ×
//!   (area vector) to roundoff. On a flat bilinear face each node receives p × area / 4 only
//!   for a parallelogram (a general quadrilateral shifts load toward its larger corners).
//! - [`floating_bodies`]: the connected components of the elements (nodes shared) and, for
//!   each, the rigid motions its clamps leave free. A rigid motion is u(x) = t + θ × (x − c)
//!   (c the body's centroid); each clamped (node, axis) is a linear condition on (t, θ), and
//!   the free motions are the null space of those conditions, found by an SVD of their 6 × 6
//!   Gram matrix. A pad puck guided in-plane at its flat back (`pad_backs:xy`) keeps three:
//!   the translation along the normal and two tilts about in-plane axes through its back.
//!   Each free motion is a column of R over the free DOFs, scaled to a largest component of 1
//!   (so its amplitude is a displacement in metres). K R = 0 is checked, and per body as many
//!   DOFs as it has free motions are chosen to pin (greedy, best conditioned rows of R), so
//!   that R restricted to the pinned DOFs is invertible.
//! - The pieces the solve takes from them: the pressure checked to push floating bodies, every
//!   one of them and nothing clamped; K with the pinned DOFs' rows and columns cut to their
//!   diagonal; each body's free motions checked to move its contact pairs along their normals.

use faer::Mat;

use crate::artifact::mesh::{cross, dot, sub};
use crate::artifact::{CscMatrix, Model};
use crate::fem::faces::{Side, area_vectors, faces_within};
use crate::stage::StageError;

/// The node set the pressure acts on.
pub const PRESSURE_SET: &str = "pad_backs";

/// A pressure (Pa) on the boundary faces of a node set.
#[derive(Debug, Clone, PartialEq)]
pub struct PressureOn {
    pub set: String,
    pub pressure: f64,
}

/// The pressure load on a node set's faces.
#[derive(Debug, Clone, PartialEq)]
pub struct PressureLoad {
    /// Consistent nodal forces over the free DOFs (N).
    pub forces: Vec<f64>,
    /// Loaded area (m²) of the faces pushed toward −z (upper pads) and +z (lower pads).
    pub area: [f64; 2],
    /// |z resultant| (N) of the same two groups of faces.
    pub force: [f64; 2],
    /// Magnitude of the resultant that falls on clamped DOFs (N), lost to the supports.
    pub on_clamped: f64,
    /// Number of loaded faces.
    pub n_faces: usize,
}

/// Nodal forces of the pressure `pressure` (Pa) on the boundary faces of the node set `set`.
pub fn pressure_load(model: &Model, pressure: f64, set: &str) -> Result<PressureLoad, StageError> {
    let mesh = &model.mesh;
    let nodes = mesh
        .node_sets
        .get(set)
        .ok_or_else(|| StageError::new(format!("no node set `{set}` to apply the pressure on")))?;
    // Candidate faces (all their nodes in the set); a face of two elements is interior.
    let faces = faces_within(mesh, &Side::new(set, nodes.iter().copied()));
    let mut load = PressureLoad {
        forces: vec![0.0; model.n_dofs()],
        area: [0.0; 2],
        force: [0.0; 2],
        on_clamped: 0.0,
        n_faces: 0,
    };
    let mut clamped_resultant = [0.0; 3];
    for owners in faces.values() {
        let [face] = &owners[..] else {
            continue;
        };
        let corners: Vec<[f64; 3]> = face
            .nodes
            .iter()
            .map(|&node| mesh.nodes[node as usize])
            .collect();
        let (mut nodal, area_vector) = area_vectors(face.kind, &corners);
        // Orient outward: from the element's centroid toward the face's.
        let centroid = |points: &[[f64; 3]]| {
            let mut sum = [0.0; 3];
            for point in points {
                for axis in 0..3 {
                    sum[axis] += point[axis] / points.len() as f64;
                }
            }
            sum
        };
        let element_points: Vec<[f64; 3]> = mesh
            .elements
            .nodes(face.element)
            .iter()
            .map(|&node| mesh.nodes[node as usize])
            .collect();
        let outward = sub(centroid(&corners), centroid(&element_points));
        let sign = if dot(area_vector, outward) >= 0.0 {
            -pressure
        } else {
            pressure
        };
        for vector in &mut nodal {
            *vector = vector.map(|component| sign * component);
        }
        let resultant_z: f64 = nodal.iter().map(|f| f[2]).sum();
        let side = usize::from(resultant_z > 0.0);
        load.area[side] += dot(area_vector, area_vector).sqrt();
        load.force[side] += resultant_z.abs();
        load.n_faces += 1;
        for (node, force) in face.nodes.iter().zip(&nodal) {
            // A tied node's force goes to its masters (Tᵀ f).
            let on_clamped = model.add_nodal_force(*node, *force, &mut load.forces);
            for axis in 0..3 {
                clamped_resultant[axis] += on_clamped[axis];
            }
        }
    }
    load.on_clamped = dot(clamped_resultant, clamped_resultant).sqrt();
    if load.n_faces == 0 {
        return Err(StageError::new(format!(
            "node set `{set}` holds no boundary face (all the nodes of one element face) to apply the pressure on"
        )));
    }
    Ok(load)
}

/// A connected body of elements that its clamps do not hold completely.
#[derive(Debug, Clone, PartialEq)]
pub struct FloatingBody {
    /// Index of the body among all connected bodies (ordered by first element).
    pub body: usize,
    pub n_elements: usize,
    /// Part of its first element.
    pub part: String,
    pub centroid: [f64; 3],
    /// Its nodes.
    pub nodes: Vec<u32>,
    /// Its columns of R.
    pub modes: std::ops::Range<usize>,
}

impl std::fmt::Display for FloatingBody {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [x, y, z] = self.centroid;
        write!(
            f,
            "body {} (part `{}`, {} elements, centroid ({x:.4}, {y:.4}, {z:.4}) m, {} free rigid motion{})",
            self.body,
            self.part,
            self.n_elements,
            self.modes.len(),
            if self.modes.len() == 1 { "" } else { "s" }
        )
    }
}

/// The zero-energy rigid motions left by the clamps, body by body.
#[derive(Debug, Clone, PartialEq)]
pub struct FloatingBodies {
    pub bodies: Vec<FloatingBody>,
    /// n_dofs × m: one free rigid motion per column, largest component 1.
    pub R: Mat<f64>,
    /// The pinned DOFs, as many per body as it has motions; R on them is invertible.
    pub pinned: Vec<usize>,
}

/// The rigid motion (t, θ) = `coefficients` at `x`: t + θ × (x − c) / length.
fn rigid_motion(coefficients: &[f64; 6], x: [f64; 3], centroid: [f64; 3], length: f64) -> [f64; 3] {
    let theta = [coefficients[3], coefficients[4], coefficients[5]];
    let rotation = cross(theta, sub(x, centroid));
    std::array::from_fn(|axis| coefficients[axis] + rotation[axis] / length)
}

/// The floating bodies of `model` and their free rigid motions (module docs).
pub fn floating_bodies(model: &Model) -> Result<FloatingBodies, StageError> {
    let mesh = &model.mesh;
    let n = model.n_dofs();
    // Tied parts are one body with their masters.
    let (body_of_node, n_bodies) = model.bodies_of_nodes();
    let mut nodes_of_body: Vec<Vec<u32>> = vec![Vec::new(); n_bodies];
    for (node, &body) in body_of_node.iter().enumerate() {
        if body != usize::MAX {
            nodes_of_body[body].push(node as u32);
        }
    }
    let mut elements_of_body = vec![0usize; n_bodies];
    let mut part_of_body = vec![None; n_bodies];
    for element in mesh.elements.iter() {
        let body = body_of_node[element.nodes[0] as usize];
        elements_of_body[body] += 1;
        part_of_body[body].get_or_insert(element.part as usize);
    }
    let mut bodies = Vec::new();
    let mut columns: Vec<Vec<f64>> = Vec::new();
    for (body, nodes) in nodes_of_body.iter().enumerate() {
        let points: Vec<[f64; 3]> = nodes
            .iter()
            .map(|&node| mesh.nodes[node as usize])
            .collect();
        let centroid: [f64; 3] = std::array::from_fn(|axis| {
            points.iter().map(|x| x[axis]).sum::<f64>() / points.len() as f64
        });
        let length = points
            .iter()
            .map(|x| {
                let d = sub(*x, centroid);
                dot(d, d).sqrt()
            })
            .fold(f64::MIN_POSITIVE, f64::max);
        // Gram matrix of the clamp conditions on (t, θ).
        let mut gram = Mat::<f64>::zeros(6, 6);
        for (node, x) in nodes.iter().zip(&points) {
            // A tied node has no DOF but is not clamped: its masters hold it.
            if model.masters(*node).is_some() {
                continue;
            }
            for axis in 0..3 {
                if model.dof_of_node[*node as usize][axis].is_some() {
                    continue;
                }
                let row: [f64; 6] = std::array::from_fn(|k| {
                    let mut unit = [0.0; 6];
                    unit[k] = 1.0;
                    rigid_motion(&unit, *x, centroid, length)[axis]
                });
                for i in 0..6 {
                    for j in 0..6 {
                        gram[(i, j)] += row[i] * row[j];
                    }
                }
            }
        }
        let svd = gram.svd().map_err(|err| {
            StageError::new(format!(
                "SVD of the clamp conditions of body {body} failed: {err:?}"
            ))
        })?;
        let largest = svd.S()[0];
        // Clamps of a well-held body give singular values of order one (unit motions);
        // a free motion gives roundoff.
        let free: Vec<usize> = (0..6)
            .filter(|&k| svd.S()[k] <= 1e-10 * largest.max(1.0))
            .collect();
        if free.is_empty() {
            continue;
        }
        let first_mode = columns.len();
        for &k in &free {
            let coefficients: [f64; 6] = std::array::from_fn(|i| svd.V()[(i, k)]);
            let mut column = vec![0.0; n];
            for (node, x) in nodes.iter().zip(&points) {
                let motion = rigid_motion(&coefficients, *x, centroid, length);
                for (dof, value) in model.dof_of_node[*node as usize].iter().zip(motion) {
                    if let Some(dof) = dof {
                        column[*dof as usize] = value;
                    }
                }
            }
            // Largest component +1: a deterministic sign, amplitudes in metres.
            let largest =
                column.iter().copied().fold(
                    0.0f64,
                    |best, v| if v.abs() > best.abs() { v } else { best },
                );
            column.iter_mut().for_each(|v| *v /= largest);
            columns.push(column);
        }
        bodies.push(FloatingBody {
            body,
            n_elements: elements_of_body[body],
            part: part_of_body[body]
                .map(|part| mesh.parts[part].clone())
                .unwrap_or_default(),
            centroid,
            nodes: nodes.clone(),
            modes: first_mode..columns.len(),
        });
    }
    let m = columns.len();
    let R = Mat::from_fn(n, m, |dof, mode| columns[mode][dof]);
    check_kernel(model, &R, &bodies)?;
    let pinned = pins(model, &R, &bodies)?;
    Ok(FloatingBodies { bodies, R, pinned })
}

/// K R = 0 to roundoff: the elements are exact for rigid motions.
fn check_kernel(model: &Model, R: &Mat<f64>, bodies: &[FloatingBody]) -> Result<(), StageError> {
    let K = &model.K;
    let mut row_sums = vec![0.0; K.n_rows];
    for col in 0..K.n_cols {
        for entry in K.col_ptr[col]..K.col_ptr[col + 1] {
            row_sums[K.row_idx[entry]] += K.values[entry].abs();
        }
    }
    let norm = row_sums.iter().copied().fold(0.0, f64::max);
    for body in bodies {
        for mode in body.modes.clone() {
            let column: Vec<f64> = R.col(mode).iter().copied().collect();
            let KR = K.mul_vec(&column);
            let worst = KR.iter().fold(0.0f64, |max, v| max.max(v.abs()));
            if worst > 1e-8 * norm {
                return Err(StageError::new(format!(
                    "{body}: a free rigid motion is not a zero-energy mode of K (|K R| = {worst:.3e} against |K| = {norm:.3e})"
                )));
            }
        }
    }
    Ok(())
}

/// Per body, the DOFs whose rows of R are best conditioned (greedy Gram–Schmidt on rows).
fn pins(model: &Model, R: &Mat<f64>, bodies: &[FloatingBody]) -> Result<Vec<usize>, StageError> {
    let mut pinned = Vec::new();
    for body in bodies {
        let dofs: Vec<usize> = body
            .nodes
            .iter()
            .flat_map(|&node| model.dof_of_node[node as usize].iter().flatten())
            .map(|&dof| dof as usize)
            .collect();
        let modes = body.modes.clone();
        let mut basis: Vec<Vec<f64>> = Vec::new();
        for _ in modes.clone() {
            let mut best: Option<(f64, usize, Vec<f64>)> = None;
            for &dof in &dofs {
                let mut row: Vec<f64> = modes.clone().map(|mode| R[(dof, mode)]).collect();
                for direction in &basis {
                    let projection: f64 = row.iter().zip(direction).map(|(a, b)| a * b).sum();
                    for (value, unit) in row.iter_mut().zip(direction) {
                        *value -= projection * unit;
                    }
                }
                let length = row.iter().map(|v| v * v).sum::<f64>().sqrt();
                if best.as_ref().is_none_or(|(top, _, _)| length > *top) {
                    best = Some((length, dof, row));
                }
            }
            match best {
                Some((length, dof, row)) if length > 1e-6 => {
                    basis.push(row.iter().map(|v| v / length).collect());
                    pinned.push(dof);
                }
                _ => {
                    return Err(StageError::new(format!(
                        "{body}: no set of its DOFs pins its free rigid motions"
                    )));
                }
            }
        }
    }
    Ok(pinned)
}

/// The pressure as applied: area and |z resultant| of the faces on the upper (index 0) and
/// lower (index 1) pads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AppliedPressure {
    pub area: [f64; 2],
    pub force: [f64; 2],
    pub floating_bodies: usize,
}

/// K with the `pinned` rows and columns replaced by their diagonal entry alone.
pub(super) fn pin(K: &CscMatrix, pinned: &[usize]) -> CscMatrix {
    let mut is_pinned = vec![false; K.n_rows];
    for &dof in pinned {
        is_pinned[dof] = true;
    }
    let mut triplets = Vec::with_capacity(K.values.len());
    for col in 0..K.n_cols {
        for entry in K.col_ptr[col]..K.col_ptr[col + 1] {
            let row = K.row_idx[entry];
            if (is_pinned[row] || is_pinned[col]) && row != col {
                continue;
            }
            triplets.push((row, col, K.values[entry]));
        }
    }
    CscMatrix::from_triplets(K.n_rows, K.n_cols, triplets)
}

/// The pressure problem's pieces: F, R, the pins, and what the summary reports.
pub(super) struct Floating {
    pub(super) forces: Vec<f64>,
    pub(super) R: Mat<f64>,
    pub(super) pinned: Vec<usize>,
    pub(super) applied: AppliedPressure,
    pub(super) bodies: Vec<FloatingBody>,
}

/// The pressure loads of several node sets, summed.
fn pressure_loads(model: &Model, pressures: &[PressureOn]) -> Result<PressureLoad, StageError> {
    let mut total: Option<PressureLoad> = None;
    for on in pressures {
        let load = pressure_load(model, on.pressure, &on.set)?;
        total = Some(match total {
            None => load,
            Some(mut sum) => {
                for (f, g) in sum.forces.iter_mut().zip(&load.forces) {
                    *f += g;
                }
                for side in 0..2 {
                    sum.area[side] += load.area[side];
                    sum.force[side] += load.force[side];
                }
                sum.on_clamped += load.on_clamped;
                sum.n_faces += load.n_faces;
                sum
            }
        });
    }
    total.ok_or_else(|| StageError::new("load: pressure names no node set to press"))
}

/// Checks that the pressures push floating bodies, every one of them, and nothing clamped.
pub(super) fn floating_under_pressure(
    model: &Model,
    pressures: &[PressureOn],
) -> Result<Floating, StageError> {
    let sets: Vec<&str> = pressures.iter().map(|on| on.set.as_str()).collect();
    let first = sets.first().copied().unwrap_or(PRESSURE_SET);
    let bodies = floating_bodies(model)?;
    if bodies.bodies.is_empty() {
        return Err(StageError::new(format!(
            "load: pressure needs the bodies it pushes free along their normal, but every body is held by its clamps: clamp `{}` in-plane only (`clamped: \"hub, {first}:xy\"`)",
            sets.join("`, `")
        )));
    }
    let load = pressure_loads(model, pressures)?;
    let total = load.force[0] + load.force[1];
    if load.on_clamped > 1e-9 * total {
        return Err(StageError::new(format!(
            "{:.3e} N of the {total:.3e} N pressure resultant falls on clamped DOFs of `{}`: clamp them in-plane only (`{first}:xy`) so that they are free along the normal",
            load.on_clamped,
            sets.join("`, `")
        )));
    }
    for body in &bodies.bodies {
        let pushed = body
            .nodes
            .iter()
            .flat_map(|&node| model.dof_of_node[node as usize].iter().flatten())
            .any(|&dof| load.forces[dof as usize] != 0.0);
        if !pushed {
            return Err(StageError::new(format!(
                "{body} is not held by its clamps and carries no pressure: clamp it"
            )));
        }
    }
    Ok(Floating {
        forces: load.forces,
        applied: AppliedPressure {
            area: load.area,
            force: load.force,
            floating_bodies: bodies.bodies.len(),
        },
        R: bodies.R,
        pinned: bodies.pinned,
        bodies: bodies.bodies,
    })
}

pub(super) fn body_list(bodies: &[FloatingBody]) -> String {
    bodies
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<String>>()
        .join("; ")
}

/// Each body's rigid motions must move its contact pairs along their normals (B_b of full
/// column rank): a motion the contact does not see (a pad spinning about the normal) is
/// held by nothing.
pub(super) fn check_contact_holds(B: &Mat<f64>, bodies: &[FloatingBody]) -> Result<(), StageError> {
    for body in bodies {
        let modes = body.modes.clone();
        let k = modes.len();
        let gram = Mat::from_fn(k, k, |i, j| {
            (0..B.nrows())
                .map(|pair| B[(pair, modes.start + i)] * B[(pair, modes.start + j)])
                .sum::<f64>()
        });
        let svd = gram.svd().map_err(|err| {
            StageError::new(format!("SVD of the contact motions of {body}: {err:?}"))
        })?;
        let largest = svd.S()[0];
        let smallest = svd.S()[k - 1];
        if !(smallest > 1e-10 * largest) {
            return Err(StageError::new(format!(
                "{body}: its contact pairs do not hold all its free rigid motions (a motion moves none of them along the normal): guide it in-plane (`{PRESSURE_SET}:xy`, or its own loaded set's)"
            )));
        }
    }
    Ok(())
}
