//! Verification: every claim of accuracy squeal makes, against an analytic solution or an
//! independent computation, gathered in one place.
//!
//! Each case reads its reference values, its tolerances and where they come from in
//! `reference_values/<case>.json`, so that the figures a reader checks are data beside the
//! code that checks them. The tolerances say how far the discretisation (or the round-off)
//! may take a result from its reference, and why.
//!
//! Run with `cargo test --release -p squeal-stages --test verification`.

#![allow(non_snake_case)] // matrices are named as in the equations

mod anisotropy;
mod bars_in_series;
mod cantilever;
mod coincident_mortar;
mod conditioning;
mod contact_patch;
mod cwt;
mod element_convergence;
mod fit;
mod hoffmann;
mod krylov;
mod lumped_transient;
mod patch_test;
mod plate;
mod real_modes;
mod reference;
mod theta_method;
