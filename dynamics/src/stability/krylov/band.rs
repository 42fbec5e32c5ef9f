//! Covering the band: shifts placed up the imaginary axis, their disks' overlaps checked, each
//! eigenvalue kept from the shift whose cell it lies in.

use std::f64::consts::PI;

use faer::c64;

use super::shift::{ShiftResult, solve_shift};
use super::{BandReport, EigenPair, KrylovOptions, ShiftReport};
use crate::stability::shift_invert::EmbeddedPattern;
use crate::stability::sliding::SlidingSystem;
use crate::stage::StageError;

/// A disk that falls short with a radius below this multiple of the band's half-width at the
/// height covered so far ends the search with an error (`solve_band`): a shift there could
/// cover only a sliver of the band.
const WEDGE_MARGIN: f64 = 1.05;

/// Heights y (rad/s) of the band the disk |λ − iω| < r covers: every point with that imaginary
/// part and |Re| ≤ (d_max/2) y is inside.
fn covered(omega: f64, radius: f64, half_rate: f64) -> (f64, f64) {
    let a = 1.0 + half_rate * half_rate;
    let discriminant = omega * omega - a * (omega * omega - radius * radius);
    if discriminant <= 0.0 {
        return (omega, omega);
    }
    let root = discriminant.sqrt();
    ((omega - root) / a, (omega + root) / a)
}

fn in_band(lambda: c64, omega_max: f64, half_rate: f64) -> bool {
    lambda.im > 0.0 && lambda.im <= omega_max && lambda.re.abs() <= half_rate * lambda.im
}

/// All eigenpairs with `0 < Im λ ≤ omega_max` and `|2 Re λ/Im λ| ≤ max_divergence_rate`,
/// ordered by frequency. `progress` receives the fraction of the band covered.
pub fn solve_band(
    system: &SlidingSystem,
    omega_max: f64,
    max_divergence_rate: f64,
    options: &KrylovOptions,
    progress: &dyn Fn(f64),
) -> Result<(Vec<EigenPair>, BandReport), StageError> {
    let pattern = EmbeddedPattern::new(system)?;
    let mut cover = Cover {
        omega_max,
        max_divergence_rate,
        half_rate: max_divergence_rate / 2.0,
        report: BandReport {
            factor_entries: pattern.factor_len(),
            ..BandReport::default()
        },
        kept: Vec::new(),
        previous: None,
        covered_to: 0.0,
        step: omega_max / 10.0,
        pending: None,
    };
    while cover.covered_to < omega_max {
        let result = cover.next_shift(system, &pattern, options)?;
        if cover.reaches(&result) {
            cover.accept(result, options)?;
            progress((cover.covered_to / omega_max).min(1.0));
        } else {
            cover.fell_short(result)?;
        }
    }
    Ok(cover.finish())
}

/// The band covered so far, shift by shift.
struct Cover {
    omega_max: f64,
    max_divergence_rate: f64,
    half_rate: f64,
    report: BandReport,
    /// The eigenpairs kept from the shifts before the previous one.
    kept: Vec<EigenPair>,
    previous: Option<Accepted>,
    /// Height up to which the band is covered.
    covered_to: f64,
    /// Height between shifts, aimed at `per_shift` eigenvalues a disk.
    step: f64,
    /// A shift whose disk fell short of what is covered, kept until a shift below fills the gap.
    pending: Option<ShiftResult>,
}

/// The last accepted shift: the top of its coverage, its cell's lower cut, the eigenvalues
/// inside its disk and the band's eigenpairs among them.
struct Accepted {
    high: f64,
    cut: f64,
    inside: Vec<c64>,
    pairs: Vec<EigenPair>,
}

impl Cover {
    /// The pending shift if the gap below it is now covered, else a new shift: halfway below a
    /// pending one (its disk must reach up into it as well as down to what is covered), or a
    /// step above what is covered (the origin for the first shift).
    fn next_shift(
        &mut self,
        system: &SlidingSystem,
        pattern: &EmbeddedPattern,
        options: &KrylovOptions,
    ) -> Result<ShiftResult, StageError> {
        let (covered_to, half_rate, omega_max) = (self.covered_to, self.half_rate, self.omega_max);
        let gap_filled = self.pending.as_ref().is_some_and(|result| {
            covered(result.sigma.im, result.radius, half_rate).0 <= covered_to
        });
        match self.pending.take() {
            Some(result) if gap_filled => Ok(result),
            short => {
                let short_low = short
                    .as_ref()
                    .map(|short| covered(short.sigma.im, short.radius, half_rate).0);
                let omega = match short_low {
                    Some(low) => 0.5 * (covered_to + low),
                    None => (covered_to + self.step).min(omega_max),
                };
                let height_gap = |y: f64| ((omega - y).powi(2) + (half_rate * y).powi(2)).sqrt();
                let needed = 1.05 * height_gap(covered_to).max(short_low.map_or(0.0, height_gap));
                self.pending = short;
                solve_shift(
                    system,
                    pattern,
                    c64::new(0.0, omega),
                    needed,
                    &|lambda| in_band(lambda, omega_max, half_rate),
                    options,
                    &mut self.report,
                )
            }
        }
    }

    /// Whether the shift's disk reaches down to what is covered (to the origin for the first).
    fn reaches(&self, result: &ShiftResult) -> bool {
        let (low, _) = covered(result.sigma.im, result.radius, self.half_rate);
        if self.previous.is_none() {
            result.radius >= result.sigma.im
        } else {
            low <= self.covered_to
        }
    }

    /// A shift whose disk the basis limit left too small: an error where no shift can help,
    /// else kept while a shift halfway below fills the gap, or dropped to start over closer.
    fn fell_short(&mut self, result: ShiftResult) -> Result<(), StageError> {
        let omega = result.sigma.im;
        let (low, high) = covered(omega, result.radius, self.half_rate);
        // Where the band's wedge is about as wide as the disk, no shift can help: every disk
        // must hold the wedge's cross-section at the height covered so far, and barely wider
        // ones would crawl up the band.
        let wedge = self.half_rate * self.covered_to;
        if result.radius < WEDGE_MARGIN * wedge {
            return Err(StageError::new(format!(
                "at {:.0} Hz the band (|divergence rate| ≤ {}) reaches ±{:.0} Hz off the frequency axis, and a shift at {:.0} Hz resolves a disk of only {:.0} Hz radius with {} vectors (max_basis), too small to cover more than a sliver of it: lower max_divergence_rate or raise max_basis",
                self.covered_to / (2.0 * PI),
                self.max_divergence_rate,
                wedge / (2.0 * PI),
                omega / (2.0 * PI),
                result.radius / (2.0 * PI),
                result.basis
            )));
        }
        if self.step < 1e-4 * self.omega_max {
            return Err(StageError::new(format!(
                "the shift at {:.1} Hz trusts only a radius of {:.1} Hz with {} vectors: raise max_basis",
                omega / (2.0 * PI),
                result.radius / (2.0 * PI),
                result.basis
            )));
        }
        if self.previous.is_some() && self.pending.is_none() && low < high {
            tracing::info!(
                "stability: shift at {:.0} Hz fell short ({} vectors, trusted radius {:.0} Hz); a shift below fills the gap",
                omega / (2.0 * PI),
                result.basis,
                result.radius / (2.0 * PI)
            );
            self.report.fell_short += 1;
            self.pending = Some(result);
        } else {
            self.step = 0.5 * (omega - self.covered_to);
            self.pending = None;
            tracing::info!(
                "stability: shift at {:.0} Hz fell short ({} vectors, trusted radius {:.0} Hz); starting over closer, at {:.0} Hz",
                omega / (2.0 * PI),
                result.basis,
                result.radius / (2.0 * PI),
                (self.covered_to + self.step).min(self.omega_max) / (2.0 * PI)
            );
        }
        Ok(())
    }

    /// Takes a shift whose disk reaches what is covered: checks it against the previous one
    /// where their disks overlap, keeps the previous shift's eigenpairs below the cut between
    /// them, and aims the next shift.
    fn accept(&mut self, result: ShiftResult, options: &KrylovOptions) -> Result<(), StageError> {
        let omega = result.sigma.im;
        let (low, high) = covered(omega, result.radius, self.half_rate);
        let mut shift_report = ShiftReport {
            frequency_hz: omega / (2.0 * PI),
            radius: result.radius,
            basis: result.basis,
            found: result.converged.len(),
            seconds: result.seconds,
            ..ShiftReport::default()
        };
        let is_inside =
            |lambda: c64| (lambda - result.sigma).norm() < result.radius && lambda.im > 0.0;
        let inside: Vec<c64> = result
            .converged
            .iter()
            .copied()
            .filter(|&lambda| is_inside(lambda))
            .collect();
        let inside_pairs: Vec<EigenPair> = result
            .pairs
            .into_iter()
            .filter(|pair| is_inside(pair.lambda))
            .collect();
        let cut = match self.previous.take() {
            Some(previous) => {
                // Both disks cover [low, previous.high]: there the two sets must agree.
                let window = (low, previous.high);
                check_overlap(
                    &previous.inside,
                    &inside,
                    window,
                    self.omega_max,
                    self.half_rate,
                )
                .map_err(|mismatch| {
                    let shifts = format!(
                        "shifts at {:.1} Hz and {:.1} Hz",
                        self.report.shifts.last().map_or(0.0, |shift| shift.frequency_hz),
                        omega / (2.0 * PI),
                    );
                    let window = format!(
                        "between {:.1} and {:.1} Hz",
                        window.0 / (2.0 * PI),
                        window.1 / (2.0 * PI)
                    );
                    let Mismatch { theirs, mine, gap } = mismatch;
                    StageError::new(if theirs == mine && gap < LOOSE_MATCH {
                        format!(
                            "{shifts} find the same {mine} eigenvalues {window}, but only to a relative {gap:.1e} (the check asks {MATCH:.0e}): they are too ill-conditioned there for the digits to be trusted (a stiffness contrast of 10⁸ between parts does it); bring the parts' stiffnesses closer, or model the stiff one as rigid"
                        )
                    } else {
                        format!(
                            "{shifts} disagree on the eigenvalues {window} ({theirs} against {mine}): an eigenvalue was missed; raise max_basis"
                        )
                    })
                })?;
                shift_report.overlap_matched = inside
                    .iter()
                    .filter(|lambda| lambda.im >= window.0 && lambda.im <= window.1)
                    .count();
                let cut = 0.5 * (window.0 + window.1);
                self.kept.extend(
                    previous
                        .pairs
                        .into_iter()
                        .filter(|pair| pair.lambda.im >= previous.cut && pair.lambda.im < cut),
                );
                cut
            }
            None => 0.0,
        };
        shift_report.kept = inside.iter().filter(|lambda| lambda.im >= cut).count();
        tracing::info!(
            "stability: shift at {:.0} Hz, {} vectors, trusted radius {:.0} Hz, {} eigenvalues kept",
            shift_report.frequency_hz,
            shift_report.basis,
            shift_report.radius / (2.0 * PI),
            shift_report.kept
        );
        self.report.shifts.push(shift_report);
        self.covered_to = high;
        // Aim the next disk at `per_shift` eigenvalues. It spans about twice the step in
        // height; the density is that of this disk's upper half, raised by half as modal
        // density grows with frequency.
        let above = inside.iter().filter(|lambda| lambda.im >= omega).count();
        self.step = if above == 0 {
            1.6 * result.radius
        } else {
            let density = 1.5 * above as f64 / result.radius;
            (options.per_shift as f64 / (2.0 * density))
                .clamp(0.1 * result.radius, 1.6 * result.radius)
        };
        self.previous = Some(Accepted {
            high,
            cut,
            inside,
            pairs: inside_pairs,
        });
        Ok(())
    }

    /// The kept eigenpairs in the band, by frequency, and the report.
    fn finish(mut self) -> (Vec<EigenPair>, BandReport) {
        if let Some(previous) = self.previous.take() {
            let cut = previous.cut;
            self.kept.extend(
                previous
                    .pairs
                    .into_iter()
                    .filter(|pair| pair.lambda.im >= cut),
            );
        }
        let (omega_max, half_rate) = (self.omega_max, self.half_rate);
        self.kept
            .retain(|pair| in_band(pair.lambda, omega_max, half_rate));
        self.kept
            .sort_by(|a, b| a.lambda.im.total_cmp(&b.lambda.im));
        (self.kept, self.report)
    }
}

/// Checks that two shifts found the same eigenvalues in the band part of `window` (heights):
/// each eigenvalue strictly inside, found by one, must be matched by the other. Returns the
/// two counts on failure.
/// Relative distance at which two shifts' copies of an eigenvalue match.
const MATCH: f64 = 1e-6;
/// Two overlaps whose eigenvalues pair up within this distance, though not within [`MATCH`],
/// found the same eigenvalues, inaccurately.
const LOOSE_MATCH: f64 = 1e-2;

/// Two shifts' eigenvalues in their overlap that do not match: how many each found, and the
/// largest relative distance from one's eigenvalue to the other's nearest.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Mismatch {
    theirs: usize,
    mine: usize,
    gap: f64,
}

fn check_overlap(
    theirs: &[c64],
    mine: &[c64],
    window: (f64, f64),
    omega_max: f64,
    half_rate: f64,
) -> Result<(), Mismatch> {
    let margin = 1e-6 * window.1;
    let within = |lambda: c64, slack: f64| {
        lambda.im >= window.0 - slack
            && lambda.im <= window.1 + slack
            && lambda.im <= omega_max + slack
            && lambda.re.abs() <= half_rate * lambda.im + slack
    };
    let strict = |set: &[c64]| -> Vec<c64> {
        set.iter()
            .copied()
            .filter(|&lambda| within(lambda, -margin))
            .collect()
    };
    let loose = |set: &[c64]| -> Vec<c64> {
        set.iter()
            .copied()
            .filter(|&lambda| within(lambda, margin))
            .collect()
    };
    let (theirs_strict, mine_strict) = (strict(theirs), strict(mine));
    if match_count(&mine_strict, &loose(theirs)) != mine_strict.len()
        || match_count(&theirs_strict, &loose(mine)) != theirs_strict.len()
    {
        let nearest = |a: &[c64], b: &[c64]| {
            a.iter()
                .map(|lambda| {
                    b.iter()
                        .map(|other| (other - lambda).norm() / lambda.norm())
                        .fold(f64::INFINITY, f64::min)
                })
                .fold(0.0, f64::max)
        };
        return Err(Mismatch {
            theirs: theirs_strict.len(),
            mine: mine_strict.len(),
            gap: nearest(&mine_strict, &loose(theirs)).max(nearest(&theirs_strict, &loose(mine))),
        });
    }
    Ok(())
}

/// Number of one-to-one matches between two sets of eigenvalues (relative distance [`MATCH`]).
fn match_count(a: &[c64], b: &[c64]) -> usize {
    let mut used = vec![false; b.len()];
    let mut matched = 0;
    for lambda in a {
        let best = b
            .iter()
            .enumerate()
            .filter(|(j, _)| !used[*j])
            .map(|(j, other)| (j, (other - lambda).norm()))
            .min_by(|x, y| x.1.total_cmp(&y.1));
        if let Some((j, distance)) = best
            && distance <= MATCH * lambda.norm()
        {
            used[j] = true;
            matched += 1;
        }
    }
    matched
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two shifts' copies of the same eigenvalues: matching, found by both only to a relative
    /// 5e-6 (ill-conditioned), or one missed.
    #[test]
    fn an_overlap_tells_a_missed_eigenvalue_from_inaccurate_ones() {
        let window = (10.0, 20.0);
        let found = [c64::new(-0.01, 12.0), c64::new(-0.02, 15.0)];
        let check = |mine: &[c64]| check_overlap(&found, mine, window, 100.0, 0.05);
        assert_eq!(check(&found), Ok(()));
        let inaccurate = [c64::new(-0.01, 12.00006), c64::new(-0.02, 15.0)];
        let Err(mismatch) = check(&inaccurate) else {
            panic!("a gap of 5e-6 passed")
        };
        assert_eq!((mismatch.theirs, mismatch.mine), (2, 2));
        assert!((mismatch.gap - 5e-6).abs() < 1e-9, "{}", mismatch.gap);
        assert!(mismatch.gap < LOOSE_MATCH);
        let Err(missed) = check(&found[..1]) else {
            panic!("a missed eigenvalue passed")
        };
        assert_eq!((missed.theirs, missed.mine), (2, 1));
    }
}
