//! Stages that turn meshes, models and modes into files other tools read: VTU for ParaView
//! ([`vtu`]), Matrix Market for scipy and MATLAB ([`matrix_market`]). Each returns
//! [`Document`](squeal_contract::Document) outputs; the engine writes them as `<output>.<extension>`.

pub mod matrix_market;
pub mod vtu;
