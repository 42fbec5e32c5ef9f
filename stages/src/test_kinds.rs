//! Stage kinds for exercising the engine: a constant source, arithmetic (of one input, a sum
//! of two for DAGs that join, and a total over a list of inputs), rounding (whose output
//! often does not change when its input does, which exercises early cutoff), a sleep and a
//! failure. Registered only when a test asks for them (`SQUEAL_TEST_KINDS=1`).

use std::sync::Arc;

use crate::artifact::ArtifactType;
use crate::stage::{
    HasParams, Inputs, Outputs, Params, PortSpec, Stage, StageError, single_output,
};
use crate::table::{ColumnData, Table};

pub fn kinds() -> Vec<Arc<dyn Stage>> {
    vec![
        Arc::new(Constant),
        Arc::new(Affine),
        Arc::new(Sum),
        Arc::new(Total),
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

impl HasParams for Constant {
    type Params = ConstantParams;
}

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
    fn inputs(&self) -> Vec<PortSpec> {
        Vec::new()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        output_port()
    }
    fn run(&self, params: &Params, _inputs: &Inputs) -> Result<Outputs, StageError> {
        let ConstantParams { value, rows } = params.read::<Self>()?;
        Ok(x_table(vec![value; rows]))
    }
}

pub struct Affine;

impl HasParams for Affine {
    type Params = AffineParams;
}

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
    fn inputs(&self) -> Vec<PortSpec> {
        input_port()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        output_port()
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let AffineParams { scale, offset } = params.read::<Self>()?;
        Ok(x_table(
            column_x(inputs)?
                .iter()
                .map(|x| scale * x + offset)
                .collect(),
        ))
    }
}

pub struct Sum;

impl HasParams for Sum {
    type Params = SumParams;
}

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
    fn inputs(&self) -> Vec<PortSpec> {
        ["a", "b"]
            .map(|name| PortSpec::one(name, ArtifactType::Table, "a table with an f64 column `x`"))
            .to_vec()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        output_port()
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let SumParams { offset } = params.read::<Self>()?;
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

pub struct Total;

impl HasParams for Total {
    type Params = SumParams;
}

impl Stage for Total {
    fn kind(&self) -> &'static str {
        "test.total"
    }
    fn version(&self) -> u32 {
        1
    }
    fn doc(&self) -> &'static str {
        "Test list input: x -> the sum of every listed table's x + offset, row by row"
    }
    fn inputs(&self) -> Vec<PortSpec> {
        vec![PortSpec::list(
            "tables",
            ArtifactType::Table,
            "tables with an f64 column `x`",
        )]
    }
    fn outputs(&self) -> Vec<PortSpec> {
        output_port()
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let SumParams { offset } = params.read::<Self>()?;
        let mut total: Option<Vec<f64>> = None;
        for table in inputs.get_list::<Table>("tables")? {
            let Some(ColumnData::F64(values)) = table.column("x") else {
                return Err(StageError::new("a listed table has no f64 column `x`"));
            };
            let total = total.get_or_insert_with(|| vec![offset; values.len()]);
            if total.len() != values.len() {
                return Err(StageError::new("the listed tables differ in length"));
            }
            for (sum, value) in total.iter_mut().zip(values) {
                *sum += value;
            }
        }
        Ok(x_table(total.unwrap_or_default()))
    }
}

pub struct Round;

impl HasParams for Round {
    type Params = RoundParams;
}

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
    fn inputs(&self) -> Vec<PortSpec> {
        input_port()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        output_port()
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let RoundParams { decimals } = params.read::<Self>()?;
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

impl HasParams for Sleep {
    type Params = SleepParams;
}

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
    fn inputs(&self) -> Vec<PortSpec> {
        input_port()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        output_port()
    }
    fn run(&self, params: &Params, inputs: &Inputs) -> Result<Outputs, StageError> {
        let SleepParams { seconds } = params.read::<Self>()?;
        std::thread::sleep(std::time::Duration::from_secs_f64(seconds));
        Ok(single_output("table", inputs.table("table")?.clone()))
    }
}

pub struct Fail;

impl HasParams for Fail {
    type Params = FailParams;
}

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
    fn inputs(&self) -> Vec<PortSpec> {
        input_port()
    }
    fn outputs(&self) -> Vec<PortSpec> {
        output_port()
    }
    fn run(&self, params: &Params, _inputs: &Inputs) -> Result<Outputs, StageError> {
        let FailParams { message } = params.read::<Self>()?;
        Err(StageError::new(message))
    }
}

// The parameters of the test kinds.

crate::stage_params! {
    pub struct ConstantParams {
        /// the value of every row
        value: f64 = 1.0,
        /// number of rows
        #[min = 1]
        rows: usize = 1,
    }
}

crate::stage_params! {
    pub struct AffineParams {
        /// multiplier
        scale: f64 = 1.0,
        /// added after scaling
        offset: f64 = 0.0,
    }
}

crate::stage_params! {
    pub struct SumParams {
        /// added to the sum
        offset: f64 = 0.0,
    }
}

crate::stage_params! {
    pub struct RoundParams {
        /// decimal places kept
        #[min = 0]
        decimals: i64 = 0,
    }
}

crate::stage_params! {
    pub struct SleepParams {
        /// how long to sleep
        #[unit = "s"]
        #[min = 0.0]
        seconds: f64 = 0.1,
    }
}

crate::stage_params! {
    pub struct FailParams {
        /// the error message
        message: String = "failed on purpose".into(),
    }
}
