//! The values the stage contract is made of: a parameter's value, a sweep point's
//! coordinates, and a stage's error. Everything else in the crate builds on these.

use std::fmt;

/// A parameter value after validation and unit conversion.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Bool(value) => write!(f, "{value}"),
            Value::Int(value) => write!(f, "{value}"),
            // `{}` prints the shortest representation that round-trips.
            Value::Float(value) => write!(f, "{value}"),
            Value::Str(value) => f.write_str(value),
        }
    }
}

/// Sweep coordinates of a stage instance: swept parameter name and value, in sweep order.
pub type Coords = Vec<(String, Value)>;

/// Why a stage failed: a one-line message with the figures that matter
/// (residual, iteration count, offending element).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct StageError {
    pub message: String,
}

impl From<squeal_linalg::Error> for StageError {
    fn from(err: squeal_linalg::Error) -> Self {
        StageError::new(err.to_string())
    }
}

impl StageError {
    pub fn new(message: impl Into<String>) -> Self {
        StageError {
            message: message.into(),
        }
    }
}
