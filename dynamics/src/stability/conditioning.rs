//! How many digits of each eigenvalue to trust: its condition number and an error bound
//! (`docs/science.md` §4, "Which digits to trust").
//!
//! For `Q(λ) = λ² M + λ C + K` with right vector `x` (`Q(λ) x = 0`) and left vector `y`
//! (`yᵀ Q(λ) = 0`, the right vector of the transposed problem `Q(λ)ᵀ`), the normwise
//! condition number of a simple eigenvalue, relative to perturbations of M, C, K measured by
//! their norms (Tisseur 2000), is
//!
//! ```text
//! κ(λ) = (|λ|² ‖M‖ + |λ| ‖C‖ + ‖K‖) ‖x‖ ‖y‖ / (|λ| |yᵀ Q′(λ) x|),   Q′(λ) = 2λ M + C
//! ```
//!
//! and the computed eigenvalue is within `|δλ| / |λ| ≲ κ η` of the exact one, `η` the pair's
//! backward error (the residual every table reports). κ grows without bound at a defective
//! eigenvalue (two modes coalescing: `yᵀ Q′ x → 0`), as `|μ − μ_c|^(−1/2)` near a simple
//! coalescence, where the bound says which digits are left.
//!
//! Left vectors come from solving the transposed problem with the same solver; each right
//! eigenvalue is paired with the left eigenvalues that match it to within `MATCH_TOLERANCE`,
//! and takes the one that gives the smallest κ (in a cluster of nearly equal eigenvalues, the
//! left vector of a neighbour is nearly `Q′`-orthogonal to `x` and would overstate κ).

use faer::c64;

use super::krylov::EigenPair;

/// Left and right copies of one eigenvalue agree to this relative distance.
const MATCH_TOLERANCE: f64 = 1e-6;

/// κ of each pair of `right`, with the left vectors of `left` (the same eigenvalues of the
/// transposed problem). `norms` are `‖M‖, ‖C‖, ‖K‖`; `form(λ, y, x)` is `yᵀ Q′(λ) x`.
/// Infinite when no left eigenvalue matches, or at a defective eigenvalue.
pub fn condition_numbers(
    right: &[EigenPair],
    left: &[EigenPair],
    norms: [f64; 3],
    form: impl Fn(c64, &[c64], &[c64]) -> c64,
) -> Vec<f64> {
    right
        .iter()
        .map(|pair| {
            let lambda = pair.lambda;
            let nearest = left
                .iter()
                .map(|other| (other.lambda - lambda).norm())
                .fold(f64::INFINITY, f64::min);
            let reach = nearest.max(MATCH_TOLERANCE * lambda.norm());
            let scale = lambda.norm_sqr() * norms[0] + lambda.norm() * norms[1] + norms[2];
            let x_norm = norm(&pair.q);
            left.iter()
                .filter(|other| (other.lambda - lambda).norm() <= reach)
                .map(|other| {
                    let y = &other.q;
                    let denominator = lambda.norm() * form(lambda, y, &pair.q).norm();
                    scale * x_norm * norm(y) / denominator
                })
                .fold(f64::INFINITY, f64::min)
        })
        .collect()
}

fn norm(x: &[c64]) -> f64 {
    x.iter().map(|value| value.norm_sqr()).sum::<f64>().sqrt()
}

/// Fills `condition` of each pair; the error bound is `condition × residual`.
pub fn attach(pairs: &mut [EigenPair], conditions: Vec<f64>) {
    for (pair, condition) in pairs.iter_mut().zip(conditions) {
        pair.condition = condition;
    }
}
