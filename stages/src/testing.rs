//! Stage kinds for exercising the engine: a constant source, arithmetic (of one input, and a
//! sum of two, for DAGs that join), rounding (whose output
//! often does not change when its input does, which exercises early cutoff), a sleep and a
//! failure. Registered only when a test asks for them (`SQUEAL_TEST_KINDS=1`).

use std::sync::Arc;

use crate::artifact::ArtifactType;
use crate::stage::{Inputs, Outputs, ParamSpec, Params, PortSpec, Stage, StageError};
use crate::table::{ColumnData, Table, single_output};

pub fn kinds() -> Vec<Arc<dyn Stage>> {
    vec![
        Arc::new(Constant),
        Arc::new(Affine),
        Arc::new(Sum),
        Arc::new(Round),
        Arc::new(Sleep),
        Arc::new(Fail),
    ]
}

fn input_port() -> Vec<PortSpec> {
    vec![PortSpec::one(
        "table",
        ArtifactType::Table,
        "a table with an f64 column `x`",
    )]
}

fn output_port() -> Vec<PortSpec> {
    vec![PortSpec::one(
        "table",
        ArtifactType::Table,
        "a table with an f64 column `x`",
    )]
}

fn column_x(inputs: &Inputs) -> Result<&[f64], StageError> {
    match inputs.table("table")?.column("x") {
        Some(ColumnData::F64(values)) => Ok(values),
        _ => Err(StageError::new("input table has no f64 column `x`")),
    }
}

fn x_table(values: Vec<f64>) -> Outputs {
    single_output("table", Table::new().with("x", values))
}

pub struct Constant;

impl Stage for Constant {
    fn kind(&self) -> &'static str {
        "test.constant"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Test source: a column `x` holding `value` in every row"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::float("value", 1.0, "", "the value of every row"),
            ParamSpec::int("rows", 1, "number of rows").at_least(1.0),
        ]
    }
    fn inputs(&self) -> Vec<PortSpec> {
        Vec::new()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        output_port()
    }
    fn check_params(&self, params: &Params) -> Result<(), StageError> {
        params.typed::<ConstantParams>().map(drop)
    }
    fn run(&self, params: &Params, _inputs: &Inputs) -> Result<Outputs, StageError> {
        let ConstantParams { value, rows } = params.typed()?;
        Ok(x_table(vec![value; rows as usize]))
    }
}

pub struct Affine;

impl Stage for Affine {
    fn kind(&self) -> &'static str {
        "test.affine"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Test arithmetic: x -> scale x + offset"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::float("scale", 1.0, "", "multiplier"),
            ParamSpec::float("offset", 0.0, "", "added after scaling"),
        ]
    }
    fn inputs(&self) -> Vec<PortSpec> {
        input_port()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        output_port()
    }
    fn check_params(&self, params: &Params) -> Result<(), StageError> {
        params.typed::<AffineParams>().map(drop)
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let AffineParams { scale, offset } = params.typed()?;
        Ok(x_table(
            column_x(inputs)?
                .iter()
                .map(|x| scale * x + offset)
                .collect(),
        ))
    }
}

pub struct Sum;

impl Stage for Sum {
    fn kind(&self) -> &'static str {
        "test.sum"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Test join: x -> a.x + b.x + offset, row by row"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![ParamSpec::float("offset", 0.0, "", "added to the sum")]
    }
    fn inputs(&self) -> Vec<PortSpec> {
        ["a", "b"]
            .map(|name| PortSpec::one(name, ArtifactType::Table, "a table with an f64 column `x`"))
            .to_vec()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        output_port()
    }
    fn check_params(&self, params: &Params) -> Result<(), StageError> {
        params.typed::<SumParams>().map(drop)
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let SumParams { offset } = params.typed()?;
        let column = |port: &str| match inputs.table(port)?.column("x") {
            Some(ColumnData::F64(values)) => Ok(values.clone()),
            _ => Err(StageError::new(format!(
                "input `{port}` has no f64 column `x`"
            ))),
        };
        let (a, b) = (column("a")?, column("b")?);
        Ok(x_table(
            a.iter().zip(&b).map(|(a, b)| a + b + offset).collect(),
        ))
    }
}

pub struct Round;

impl Stage for Round {
    fn kind(&self) -> &'static str {
        "test.round"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Test rounding: x rounded to `decimals` decimals"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![ParamSpec::int("decimals", 0, "decimal places kept").at_least(0.0)]
    }
    fn inputs(&self) -> Vec<PortSpec> {
        input_port()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        output_port()
    }
    fn check_params(&self, params: &Params) -> Result<(), StageError> {
        params.typed::<RoundParams>().map(drop)
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let RoundParams { decimals } = params.typed()?;
        let factor = 10f64.powi(decimals as i32);
        Ok(x_table(
            column_x(inputs)?
                .iter()
                .map(|x| (x * factor).round() / factor)
                .collect(),
        ))
    }
}

pub struct Sleep;

impl Stage for Sleep {
    fn kind(&self) -> &'static str {
        "test.sleep"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Test delay: passes its input through after `seconds`"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![ParamSpec::float("seconds", 0.1, "s", "how long to sleep").at_least(0.0)]
    }
    fn inputs(&self) -> Vec<PortSpec> {
        input_port()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        output_port()
    }
    fn check_params(&self, params: &Params) -> Result<(), StageError> {
        params.typed::<SleepParams>().map(drop)
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let SleepParams { seconds } = params.typed()?;
        std::thread::sleep(std::time::Duration::from_secs_f64(seconds));
        Ok(single_output("table", inputs.table("table")?.clone()))
    }
}

pub struct Fail;

impl Stage for Fail {
    fn kind(&self) -> &'static str {
        "test.fail"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Test failure: always fails with `message`"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![ParamSpec::string(
            "message",
            "failed on purpose",
            "the error message",
        )]
    }
    fn inputs(&self) -> Vec<PortSpec> {
        input_port()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        output_port()
    }
    fn check_params(&self, params: &Params) -> Result<(), StageError> {
        params.typed::<FailParams>().map(drop)
    }
    fn run(&self, params: &Params, _inputs: &Inputs) -> Result<Outputs, StageError> {
        let FailParams { message } = params.typed()?;
        Err(StageError::new(message))
    }
}

/// The parameters of the test kinds, as declared.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ConstantParams {
    value: f64,
    rows: i64,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct AffineParams {
    scale: f64,
    offset: f64,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct SumParams {
    offset: f64,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RoundParams {
    decimals: i64,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct SleepParams {
    seconds: f64,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct FailParams {
    message: String,
}
