//! A lumped model as `transient.matrices` reads it: `M`, `C`, `K`, a constant load, contacts
//! given by their rows over the DOFs, and DOFs driven at a prescribed velocity; and what the
//! scheme integrates of it.
//!
//! A contact's normal row `n` gives its gap `g = g₀ + n·q`; its tangential rows `t` (and `b`)
//! its slip `s = (t·q̇ − V, b·q̇)` on a surface moving at `V` along `t`. Its reaction
//! `(r_n, r_t, r_b)` acts on the DOFs as `r_n n + r_t t + r_b b`.
//!
//! A driven DOF `d` moves as `q_d(t) = q_d(0) + V_d t`: it leaves the unknowns, and what it
//! exerts on the others becomes a load affine in time, `−K_fd q_d(t) − C_fd V_d` (its mass
//! exerts nothing: it does not accelerate). A tangential row that moves it adds `t_d V_d` to the
//! slip, a constant: the surface's speed seen by the contact becomes `V − t_d V_d`. A normal or
//! binormal row that moves it would make the gap or the slip's direction change with time, which
//! the scheme does not hold: refused.

use std::path::Path;

use serde::Deserialize;
use squeal_linalg::matrix_market::read_matrix_market;

use crate::artifact::CscMatrix;
use crate::stage::StageError;

/// One contact as the contacts file gives it.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Contact {
    /// The normal row over the DOFs: `g = gap + normal·q`.
    pub normal: Vec<f64>,
    /// The tangential row along which the surface moves: the slip is `tangent·q̇ − V`.
    pub tangent: Vec<f64>,
    /// A second tangential row (a contact that slips in a plane), or none.
    #[serde(default)]
    pub binormal: Option<Vec<f64>>,
    /// The gap at `q = 0` (m).
    #[serde(default)]
    pub gap: f64,
    /// The speed of its surface along `tangent` (m/s), if not the study's `surface_speed`.
    #[serde(default)]
    pub surface_speed: Option<f64>,
    /// Its kinetic and static friction coefficients, if not the study's.
    #[serde(default)]
    pub mu: Option<f64>,
    #[serde(default)]
    pub mu_static: Option<f64>,
}

/// A contact's friction: `(μ, μ_s)`.
pub type Friction = (f64, f64);

/// A lumped model over `n` DOFs.
#[derive(Debug, Clone)]
pub struct LumpedModel {
    pub M: CscMatrix,
    pub C: CscMatrix,
    pub K: CscMatrix,
    /// The constant load, one entry per DOF.
    pub load: Vec<f64>,
    pub contacts: Vec<Contact>,
    /// DOFs held at a prescribed velocity, ascending: `(dof, velocity)`.
    pub driven: Vec<(usize, f64)>,
}

/// Reads a Matrix Market file, the error naming it.
pub fn read_matrix(path: &Path) -> Result<CscMatrix, StageError> {
    let failed =
        |err: &dyn std::fmt::Display| StageError::new(format!("{}: {err}", path.display()));
    let text = std::fs::read_to_string(path).map_err(|err| failed(&err))?;
    read_matrix_market(&text).map_err(|err| failed(&err))
}

/// Reads a contacts file: a YAML list of contacts, an error naming its line and column.
pub fn read_contacts(path: &Path) -> Result<Vec<Contact>, StageError> {
    let failed =
        |err: &dyn std::fmt::Display| StageError::new(format!("{}: {err}", path.display()));
    let text = std::fs::read_to_string(path).map_err(|err| failed(&err))?;
    let options = serde_saphyr::options! { with_snippet: false, strict_booleans: true };
    serde_saphyr::from_str_with_options::<Vec<Contact>>(&text, options).map_err(|err| {
        let at = err
            .location()
            .map(|location| format!(":{}:{}", location.line(), location.column()))
            .unwrap_or_default();
        StageError::new(format!("{}{at}: {}", path.display(), err.without_snippet()))
    })
}

/// The largest `|A − Aᵀ|` entry over the largest `|A|` entry.
fn asymmetry(A: &CscMatrix) -> f64 {
    let scale = A
        .triplets()
        .fold(0.0_f64, |largest, (_, _, value)| largest.max(value.abs()));
    let transposed = A.transpose();
    let dense = A.to_dense();
    let worst = transposed
        .triplets()
        .map(|(i, j, value)| (dense[(i, j)] - value).abs())
        .fold(0.0, f64::max);
    if scale > 0.0 { worst / scale } else { 0.0 }
}

impl LumpedModel {
    /// Checks sizes, symmetry and the contacts' rows; `mu`, `mu_static` for the message of a
    /// bad pair.
    pub fn check(&self) -> Result<(), StageError> {
        let n = self.M.n_rows;
        let bad = |message: String| Err(StageError::new(message));
        if n == 0 {
            return bad("M has no rows: the model has no DOFs".into());
        }
        for (name, A) in [("M", &self.M), ("C", &self.C), ("K", &self.K)] {
            if A.n_rows != n || A.n_cols != n {
                return bad(format!(
                    "{name} is {} x {}, M is {n} x {n}: the matrices must be square and of one size",
                    A.n_rows, A.n_cols
                ));
            }
            if let Some((i, j, value)) = A.triplets().find(|(_, _, value)| !value.is_finite()) {
                return bad(format!("{name}[{i}, {j}] = {value} is not finite"));
            }
            let asymmetry = asymmetry(A);
            if asymmetry > 1e-12 {
                let hint = match name {
                    "K" => ": friction enters through the contacts, not through K",
                    _ => "",
                };
                return bad(format!(
                    "{name} is not symmetric (largest |{name} - {name}^T| is {asymmetry:.2e} of its largest entry){hint}"
                ));
            }
        }
        if self.load.len() != n {
            return bad(format!(
                "load has {} entries, the model {n} DOFs",
                self.load.len()
            ));
        }
        if let Some(&(dof, _)) = self.driven.iter().find(|(dof, _)| *dof >= n) {
            return bad(format!(
                "prescribed_dofs: DOF {dof} is not among the model's {n} DOFs (0 to {})",
                n - 1
            ));
        }
        if let Some(pair) = self.driven.windows(2).find(|pair| pair[0].0 == pair[1].0) {
            return bad(format!("prescribed_dofs: DOF {} is given twice", pair[0].0));
        }
        if self.driven.len() == n {
            return bad("prescribed_dofs: every DOF is driven, none is left to integrate".into());
        }
        for (c, contact) in self.contacts.iter().enumerate() {
            let rows = [
                ("normal", Some(&contact.normal)),
                ("tangent", Some(&contact.tangent)),
                ("binormal", contact.binormal.as_ref()),
            ];
            for (name, row) in rows {
                let Some(row) = row else { continue };
                if row.len() != n {
                    return bad(format!(
                        "contact {c}: its {name} row has {} entries, the model {n} DOFs",
                        row.len()
                    ));
                }
                if row.iter().any(|value| !value.is_finite()) {
                    return bad(format!("contact {c}: its {name} row is not finite"));
                }
                if row.iter().all(|&value| value == 0.0) {
                    return bad(format!(
                        "contact {c}: its {name} row is zero: it moves no DOF"
                    ));
                }
            }
            if !contact.gap.is_finite() {
                return bad(format!("contact {c}: gap = {} is not finite", contact.gap));
            }
            for (name, value) in [
                ("surface_speed", contact.surface_speed),
                ("mu", contact.mu),
                ("mu_static", contact.mu_static),
            ] {
                if let Some(value) = value
                    && (!value.is_finite() || (name != "surface_speed" && value < 0.0))
                {
                    return bad(format!(
                        "contact {c}: {name} = {value} must be finite{}",
                        if name == "surface_speed" {
                            ""
                        } else {
                            " and not negative"
                        }
                    ));
                }
            }
            for &(dof, _) in &self.driven {
                for (name, row) in [
                    ("normal", Some(&contact.normal)),
                    ("binormal", contact.binormal.as_ref()),
                ] {
                    if let Some(row) = row
                        && row[dof] != 0.0
                    {
                        return bad(format!(
                            "contact {c}: its {name} row moves DOF {dof}, which is driven at a prescribed velocity: its {} would change with time, which the scheme cannot hold (only a tangent row may move a driven DOF)",
                            if name == "normal" {
                                "gap"
                            } else {
                                "slip direction"
                            }
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    pub fn n_dofs(&self) -> usize {
        self.M.n_rows
    }

    /// The DOFs the scheme integrates (those not driven), ascending.
    pub fn free_dofs(&self) -> Vec<usize> {
        (0..self.n_dofs())
            .filter(|dof| self.driven.binary_search_by_key(dof, |(d, _)| *d).is_err())
            .collect()
    }

    /// The surface's speed as contact `c` sees it: `V − t_d V_d` over the driven DOFs, `V` its
    /// own or `surface_speed`.
    pub fn sliding_speed(&self, c: usize, surface_speed: f64) -> f64 {
        let contact = &self.contacts[c];
        self.driven.iter().fold(
            contact.surface_speed.unwrap_or(surface_speed),
            |speed, &(dof, velocity)| speed - contact.tangent[dof] * velocity,
        )
    }

    /// Contact `c`'s friction, its own or `(mu, mu_static)` (a static coefficient of 0 meaning
    /// μ); refused if the static one is below the kinetic.
    pub fn friction(&self, c: usize, (mu, mu_static): Friction) -> Result<Friction, StageError> {
        let contact = &self.contacts[c];
        let kinetic = contact.mu.unwrap_or(mu);
        let held = match contact.mu_static.unwrap_or(mu_static) {
            0.0 => kinetic,
            held => held,
        };
        if held < kinetic {
            return Err(StageError::new(format!(
                "contact {c}: mu_static = {held} is below mu = {kinetic}: static friction holds at least what kinetic friction does"
            )));
        }
        Ok((kinetic, held))
    }

    /// `H`'s rows over the free DOFs, three per contact (n, t, b; b empty without a binormal).
    pub fn h_rows(&self, free: &[usize]) -> Vec<Vec<(usize, f64)>> {
        let restrict = |row: &[f64]| -> Vec<(usize, f64)> {
            free.iter()
                .enumerate()
                .filter(|(_, dof)| row[**dof] != 0.0)
                .map(|(k, dof)| (k, row[*dof]))
                .collect()
        };
        self.contacts
            .iter()
            .flat_map(|contact| {
                [
                    restrict(&contact.normal),
                    restrict(&contact.tangent),
                    contact
                        .binormal
                        .as_deref()
                        .map(restrict)
                        .unwrap_or_default(),
                ]
            })
            .collect()
    }

    /// What the driven DOFs exert on the free ones at `t = 0` and per unit time, from their
    /// initial displacement `q_driven`: `(−K_fd q_d(0) − C_fd V_d, −K_fd V_d)`.
    pub fn driven_load(&self, free: &[usize], q_driven: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let n = self.n_dofs();
        let mut row_of = vec![usize::MAX; n];
        for (k, &dof) in free.iter().enumerate() {
            row_of[dof] = k;
        }
        let (mut constant, mut rate) = (vec![0.0; free.len()], vec![0.0; free.len()]);
        for (&(dof, velocity), &q) in self.driven.iter().zip(q_driven) {
            // Column `dof` of K and C on the free rows.
            for (i, j, entry) in self.K.triplets() {
                if j == dof && row_of[i] != usize::MAX {
                    constant[row_of[i]] -= entry * q;
                    rate[row_of[i]] -= entry * velocity;
                }
            }
            for (i, j, entry) in self.C.triplets() {
                if j == dof && row_of[i] != usize::MAX {
                    constant[row_of[i]] -= entry * velocity;
                }
            }
        }
        (constant, rate)
    }
}
