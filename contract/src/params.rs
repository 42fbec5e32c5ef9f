//! Stage parameters, declared once.
//!
//! A stage's parameters are one struct declared with [`stage_params!`](crate::stage_params): each field gives the
//! parameter's name, type, unit, lower bound, default and doc. From that one declaration come
//! the [`ParamSpec`] list the engine validates studies against (and `squeal stages` prints), and
//! the typed value the stage reads ([`Params::read`]). Choices are enums declared with
//! [`choice!`](crate::choice): the engine takes their names from the enum, and a stage matches on the enum, so
//! a choice cannot be declared without the code that handles it. Lists are `Vec<T>` of any item
//! that parses from text, read by one splitter ([`ListItem`]).
//!
//! ```ignore
//! stage_params! {
//!     pub struct TransientParams {
//!         /// time step
//!         #[unit = "s"]
//!         #[min = 0.0]
//!         tau: f64 = 1e-6,
//!         /// contact solver
//!         solver: Solver = Solver::ActiveSet,
//!         /// contact pairs recorded in points (empty: four spread over the pairs)
//!         record_pairs: Vec<usize> = Vec::new(),
//!     }
//! }
//! ```
//!
//! A field without `= default` is required. Parameters that several stages share are one
//! struct of their own, taken whole by each: `..scheme: SchemeParams,` before the fields
//! gives the struct a field `scheme` and the stage every parameter of `SchemeParams`, under
//! their own names. A stage names its struct once, in
//! [`HasParams`]; [`DeclaredParams`], which the engine calls, follows from it.

use std::collections::BTreeMap;
use std::fmt;
use std::path::PathBuf;

use crate::value::{StageError, Value};

/// The type of a declared parameter.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamType {
    Bool,
    Int {
        min: i64,
    },
    Float {
        min: f64,
    },
    Str,
    /// A list, kept as one string with its items comma-separated; written as a YAML list
    /// (`[35, 36]`) or as that string (`"35, 36"`).
    List,
    /// A file path. The engine makes a relative path absolute: relative to the study's folder
    /// when written in the study, to the working directory when given on the command line.
    Path,
    /// One of a fixed set of names (solver methods, window functions, ...).
    Choice(&'static [&'static str]),
}

impl fmt::Display for ParamType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamType::Bool => f.write_str("bool"),
            ParamType::Int { min } if *min > i64::MIN => write!(f, "int >= {min}"),
            ParamType::Int { .. } => f.write_str("int"),
            ParamType::Float { min } if min.is_finite() => write!(f, "float >= {min}"),
            ParamType::Float { .. } => f.write_str("float"),
            ParamType::Str => f.write_str("string"),
            ParamType::List => f.write_str("list"),
            ParamType::Path => f.write_str("path"),
            ParamType::Choice(names) => write!(f, "one of {}", names.join(" | ")),
        }
    }
}

/// A declared parameter: name, type, default, SI unit ("" if dimensionless), one-line doc.
#[derive(Debug, Clone)]
pub struct ParamSpec {
    pub name: &'static str,
    pub ty: ParamType,
    /// `None` makes the parameter required.
    pub default: Option<Value>,
    pub unit: &'static str,
    pub doc: &'static str,
}

/// Declarations written out, for callers without a stage (the engine's own tests); a stage
/// declares its parameters with [`stage_params!`](crate::stage_params).
impl ParamSpec {
    pub fn float(name: &'static str, default: f64, unit: &'static str, doc: &'static str) -> Self {
        let ty = ParamType::Float {
            min: f64::NEG_INFINITY,
        };
        let default = Some(Value::Float(default));
        ParamSpec {
            name,
            ty,
            default,
            unit,
            doc,
        }
    }

    pub fn int(name: &'static str, default: i64, doc: &'static str) -> Self {
        let ty = ParamType::Int { min: i64::MIN };
        ParamSpec {
            name,
            ty,
            default: Some(Value::Int(default)),
            unit: "",
            doc,
        }
    }

    /// A string; chain [`ParamSpec::required`] for one without a default.
    pub fn string(name: &'static str, default: &str, doc: &'static str) -> Self {
        let default = Some(Value::Str(default.to_string()));
        ParamSpec {
            name,
            ty: ParamType::Str,
            default,
            unit: "",
            doc,
        }
    }

    /// A list (see [`ParamType::List`]); its default is written comma-separated.
    pub fn list(name: &'static str, default: &str, doc: &'static str) -> Self {
        ParamSpec {
            ty: ParamType::List,
            ..ParamSpec::string(name, default, doc)
        }
    }

    /// A required file path (see [`ParamType::Path`]).
    pub fn path(name: &'static str, doc: &'static str) -> Self {
        ParamSpec {
            name,
            ty: ParamType::Path,
            default: None,
            unit: "",
            doc,
        }
    }

    /// A file path that may be left out (empty by default).
    pub fn optional_path(name: &'static str, doc: &'static str) -> Self {
        ParamSpec {
            default: Some(Value::Str(String::new())),
            ..ParamSpec::path(name, doc)
        }
    }

    pub fn bool(name: &'static str, default: bool, doc: &'static str) -> Self {
        ParamSpec {
            name,
            ty: ParamType::Bool,
            default: Some(Value::Bool(default)),
            unit: "",
            doc,
        }
    }

    pub fn choice(
        name: &'static str,
        choices: &'static [&'static str],
        default: &'static str,
        doc: &'static str,
    ) -> Self {
        let default = Some(Value::Str(default.to_string()));
        ParamSpec {
            name,
            ty: ParamType::Choice(choices),
            default,
            unit: "",
            doc,
        }
    }

    /// Lower bound (inclusive) for a numeric parameter.
    pub fn at_least(mut self, bound: f64) -> Self {
        self.ty = match self.ty {
            ParamType::Float { .. } => ParamType::Float { min: bound },
            ParamType::Int { .. } => ParamType::Int { min: bound as i64 },
            other => other,
        };
        self
    }

    pub fn required(mut self) -> Self {
        self.default = None;
        self
    }
}

/// Validated parameters of one stage instance: every declared parameter is present and typed.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Params(pub BTreeMap<String, Value>);

impl Params {
    /// The parameters of `stage` at their defaults, with `overrides` (for callers that run a
    /// stage directly: tests and benchmarks).
    pub fn defaults(stage: &dyn DeclaredParams, overrides: &[(&str, Value)]) -> Params {
        let mut values: BTreeMap<String, Value> = stage
            .params()
            .into_iter()
            .filter_map(|spec| Some((spec.name.to_string(), spec.default?)))
            .collect();
        for (name, value) in overrides {
            values.insert(name.to_string(), value.clone());
        }
        Params(values)
    }

    /// The parameters as the typed struct stage `S` declares: `params.read::<Self>()?`.
    pub fn read<S: HasParams>(&self) -> Result<S::Params, StageError> {
        S::Params::from_params(self)
    }

    /// One parameter, typed (for [`stage_params!`](crate::stage_params)).
    pub fn field<T: ParamValue>(&self, name: &str) -> Result<T, StageError> {
        let value = self
            .0
            .get(name)
            .ok_or_else(|| StageError::new(format!("parameter `{name}` is missing")))?;
        T::from_value(value).map_err(|reason| StageError::new(format!("{name}: {reason}")))
    }
}

/// A Rust type a parameter can have: its declared type, and its conversions from and to the
/// [`Value`] the engine validated.
pub trait ParamValue: Sized {
    /// The declared type; `min` is the field's lower bound, if it has one.
    fn param_type(min: Option<f64>) -> ParamType;
    fn to_value(&self) -> Value;
    /// The error is the reason only; [`Params::field`] adds the parameter's name.
    fn from_value(value: &Value) -> Result<Self, String>;
}

fn expected<T>(what: &str, value: &Value) -> Result<T, String> {
    Err(format!("expected {what}, found `{value}`"))
}

impl ParamValue for f64 {
    fn param_type(min: Option<f64>) -> ParamType {
        ParamType::Float {
            min: min.unwrap_or(f64::NEG_INFINITY),
        }
    }
    fn to_value(&self) -> Value {
        Value::Float(*self)
    }
    fn from_value(value: &Value) -> Result<Self, String> {
        match value {
            Value::Float(value) => Ok(*value),
            Value::Int(value) => Ok(*value as f64),
            other => expected("a number", other),
        }
    }
}

impl ParamValue for i64 {
    fn param_type(min: Option<f64>) -> ParamType {
        ParamType::Int {
            min: min.map_or(i64::MIN, |min| min as i64),
        }
    }
    fn to_value(&self) -> Value {
        Value::Int(*self)
    }
    fn from_value(value: &Value) -> Result<Self, String> {
        match value {
            Value::Int(value) => Ok(*value),
            other => expected("an integer", other),
        }
    }
}

/// A count or an index: an integer the engine holds to `>= 0` (or the field's higher bound).
impl ParamValue for usize {
    fn param_type(min: Option<f64>) -> ParamType {
        ParamType::Int {
            min: min.map_or(0, |min| (min as i64).max(0)),
        }
    }
    fn to_value(&self) -> Value {
        Value::Int(*self as i64)
    }
    fn from_value(value: &Value) -> Result<Self, String> {
        match value {
            Value::Int(value) => usize::try_from(*value)
                .map_err(|_| format!("{value} is negative: expected a count")),
            other => expected("an integer", other),
        }
    }
}

impl ParamValue for bool {
    fn param_type(_min: Option<f64>) -> ParamType {
        ParamType::Bool
    }
    fn to_value(&self) -> Value {
        Value::Bool(*self)
    }
    fn from_value(value: &Value) -> Result<Self, String> {
        match value {
            Value::Bool(value) => Ok(*value),
            other => expected("true or false", other),
        }
    }
}

impl ParamValue for String {
    fn param_type(_min: Option<f64>) -> ParamType {
        ParamType::Str
    }
    fn to_value(&self) -> Value {
        Value::Str(self.clone())
    }
    fn from_value(value: &Value) -> Result<Self, String> {
        match value {
            Value::Str(value) => Ok(value.clone()),
            other => expected("a string", other),
        }
    }
}

/// A required file path (the engine made it absolute).
impl ParamValue for PathBuf {
    fn param_type(_min: Option<f64>) -> ParamType {
        ParamType::Path
    }
    fn to_value(&self) -> Value {
        Value::Str(self.to_string_lossy().into_owned())
    }
    fn from_value(value: &Value) -> Result<Self, String> {
        match value {
            Value::Str(text) if text.is_empty() => Err("the path is empty".into()),
            Value::Str(text) => Ok(PathBuf::from(text)),
            other => expected("a path", other),
        }
    }
}

/// A file path a study may leave out: empty is `None`.
impl ParamValue for Option<PathBuf> {
    fn param_type(_min: Option<f64>) -> ParamType {
        ParamType::Path
    }
    fn to_value(&self) -> Value {
        Value::Str(
            self.as_ref()
                .map(|path| path.to_string_lossy().into_owned())
                .unwrap_or_default(),
        )
    }
    fn from_value(value: &Value) -> Result<Self, String> {
        match value {
            Value::Str(text) if text.is_empty() => Ok(None),
            Value::Str(text) => Ok(Some(PathBuf::from(text))),
            other => expected("a path", other),
        }
    }
}

/// An item of a list parameter: parsed from the text between two commas.
pub trait ListItem: Sized {
    /// What an item is, for errors: "a mode number", "a set name".
    const WHAT: &'static str;
    fn parse_item(text: &str) -> Option<Self>;
    fn write_item(&self) -> String;
}

impl ListItem for i64 {
    const WHAT: &'static str = "an integer";
    fn parse_item(text: &str) -> Option<Self> {
        text.parse().ok()
    }
    fn write_item(&self) -> String {
        self.to_string()
    }
}

impl ListItem for usize {
    const WHAT: &'static str = "a non-negative integer";
    fn parse_item(text: &str) -> Option<Self> {
        text.parse().ok()
    }
    fn write_item(&self) -> String {
        self.to_string()
    }
}

impl ListItem for f64 {
    const WHAT: &'static str = "a number";
    fn parse_item(text: &str) -> Option<Self> {
        text.parse().ok()
    }
    fn write_item(&self) -> String {
        self.to_string()
    }
}

impl ListItem for String {
    const WHAT: &'static str = "a name";
    fn parse_item(text: &str) -> Option<Self> {
        Some(text.to_string())
    }
    fn write_item(&self) -> String {
        self.clone()
    }
}

/// The one list splitter: items separated by commas, trimmed, empty items skipped, so `""`
/// is the empty list and `"35, 36,"` is `[35, 36]`.
impl<T: ListItem> ParamValue for Vec<T> {
    fn param_type(_min: Option<f64>) -> ParamType {
        ParamType::List
    }
    fn to_value(&self) -> Value {
        Value::Str(
            self.iter()
                .map(ListItem::write_item)
                .collect::<Vec<_>>()
                .join(", "),
        )
    }
    fn from_value(value: &Value) -> Result<Self, String> {
        let Value::Str(text) = value else {
            return expected("a list", value);
        };
        text.split(',')
            .map(str::trim)
            .filter(|item| !item.is_empty())
            .map(|item| T::parse_item(item).ok_or_else(|| format!("`{item}` is not {}", T::WHAT)))
            .collect()
    }
}

/// A point or a direction in space, written as a list of three numbers (`[0, 0, 1]`).
impl ParamValue for [f64; 3] {
    fn param_type(_min: Option<f64>) -> ParamType {
        ParamType::List
    }
    fn to_value(&self) -> Value {
        self.to_vec().to_value()
    }
    fn from_value(value: &Value) -> Result<Self, String> {
        let items = Vec::<f64>::from_value(value)?;
        <[f64; 3]>::try_from(items.as_slice())
            .map_err(|_| format!("{} numbers: expected three, [x, y, z]", items.len()))
    }
}

/// A stage's parameter struct, as [`stage_params!`](crate::stage_params) declares it.
pub trait StageParams: Sized + fmt::Debug + 'static {
    /// The declarations, in the struct's order.
    fn specs() -> Vec<ParamSpec>;
    /// The struct from validated parameters; an error names the parameter.
    fn from_params(params: &Params) -> Result<Self, StageError>;
    /// Whether `value` reads as parameter `name` (a list's items, say); the error is the reason.
    fn check_field(name: &str, value: &Value) -> Result<(), String>;
}

/// Ties a stage kind to its parameter struct: what it declares and what its `run` reads.
pub trait HasParams {
    type Params: StageParams;
}

/// A stage's parameters as the engine sees them; every [`HasParams`] stage has it.
pub trait DeclaredParams {
    /// The declarations, for validation and `squeal stages`.
    fn params(&self) -> Vec<ParamSpec>;
    /// Whether `value` reads as parameter `name`: what a study's validation asks of each value
    /// it converted (a list's items parse, say). The error is the reason, without the name.
    fn check_param(&self, name: &str, value: &Value) -> Result<(), String>;
    /// Reads `params` into the stage's typed struct, as its `run` does first; the result is
    /// that struct, for inspection.
    fn read_params(&self, params: &Params) -> Result<Box<dyn fmt::Debug>, StageError>;
}

impl<S: HasParams> DeclaredParams for S {
    fn params(&self) -> Vec<ParamSpec> {
        S::Params::specs()
    }
    fn check_param(&self, name: &str, value: &Value) -> Result<(), String> {
        S::Params::check_field(name, value)
    }
    fn read_params(&self, params: &Params) -> Result<Box<dyn fmt::Debug>, StageError> {
        Ok(Box::new(S::Params::from_params(params)?))
    }
}

/// Declares a stage's parameter struct; see the [module docs](crate::params).
#[macro_export]
macro_rules! stage_params {
    (
        $(#[$struct_attr:meta])*
        $vis:vis struct $Name:ident {
            $(.. $shared:ident : $Shared:ty,)*
            $(
                $(#[doc = $doc:literal])*
                $(#[unit = $unit:literal])?
                $(#[min = $min:expr])?
                $field:ident : $ty:ty $(= $default:expr)?
            ),* $(,)?
        }
    ) => {
        $(#[$struct_attr])*
        #[derive(Debug, Clone, PartialEq)]
        $vis struct $Name {
            $( pub $shared: $Shared, )*
            $( $(#[doc = $doc])* pub $field: $ty, )*
        }

        impl $crate::params::StageParams for $Name {
            fn specs() -> Vec<$crate::params::ParamSpec> {
                let shared: Vec<Vec<$crate::params::ParamSpec>> = vec![$(
                    <$Shared as $crate::params::StageParams>::specs()
                ),*];
                let own = vec![$(
                    $crate::params::ParamSpec {
                        name: stringify!($field),
                        ty: <$ty as $crate::params::ParamValue>::param_type(
                            $crate::stage_params!(@min $($min)?),
                        ),
                        default: $crate::stage_params!(@default $ty $(, $default)?),
                        unit: $crate::stage_params!(@unit $($unit)?),
                        doc: concat!($($doc),*).trim(),
                    }
                ),*];
                shared.into_iter().flatten().chain(own).collect()
            }

            #[allow(unused_variables)]
            fn from_params(
                params: &$crate::params::Params,
            ) -> Result<Self, $crate::value::StageError> {
                Ok($Name {
                    $( $shared: <$Shared as $crate::params::StageParams>::from_params(params)?, )*
                    $( $field: params.field(stringify!($field))?, )*
                })
            }

            #[allow(unused_variables)]
            fn check_field(name: &str, value: &$crate::value::Value) -> Result<(), String> {
                $(
                    if name == stringify!($field) {
                        return <$ty as $crate::params::ParamValue>::from_value(value).map(drop);
                    }
                )*
                $(
                    let specs = <$Shared as $crate::params::StageParams>::specs();
                    if specs.iter().any(|spec| spec.name == name) {
                        return <$Shared as $crate::params::StageParams>::check_field(name, value);
                    }
                )*
                Err(format!("no parameter `{name}`"))
            }
        }
    };
    (@min) => { None };
    (@min $min:expr) => { Some(($min) as f64) };
    (@unit) => { "" };
    (@unit $unit:literal) => { $unit };
    (@default $ty:ty) => { None };
    (@default $ty:ty, $default:expr) => {{
        let default: $ty = $default;
        Some($crate::params::ParamValue::to_value(&default))
    }};
}

/// Declares a choice parameter's enum: each variant with the name a study writes.
///
/// ```ignore
/// choice! {
///     /// The contact solver.
///     pub enum Solver {
///         ActiveSet = "active_set",
///         GaussSeidel = "gauss_seidel",
///     }
/// }
/// ```
#[macro_export]
macro_rules! choice {
    (
        $(#[$attr:meta])*
        $vis:vis enum $Name:ident {
            $( $(#[doc = $doc:literal])* $Variant:ident = $text:literal ),* $(,)?
        }
    ) => {
        $(#[$attr])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        $vis enum $Name {
            $( $(#[doc = $doc])* $Variant, )*
        }

        impl $Name {
            /// The names a study writes, in declaration order.
            pub const NAMES: &'static [&'static str] = &[$($text),*];

            /// The name a study writes.
            pub fn name(self) -> &'static str {
                match self {
                    $( $Name::$Variant => $text, )*
                }
            }
        }

        impl std::fmt::Display for $Name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl std::str::FromStr for $Name {
            type Err = String;
            fn from_str(text: &str) -> Result<Self, String> {
                match text {
                    $( $text => Ok($Name::$Variant), )*
                    other => Err(format!(
                        "`{other}` is not one of {}",
                        $Name::NAMES.join(" | ")
                    )),
                }
            }
        }

        impl $crate::params::ParamValue for $Name {
            fn param_type(_min: Option<f64>) -> $crate::params::ParamType {
                $crate::params::ParamType::Choice($Name::NAMES)
            }
            fn to_value(&self) -> $crate::value::Value {
                $crate::value::Value::Str(self.name().to_string())
            }
            fn from_value(value: &$crate::value::Value) -> Result<Self, String> {
                match value {
                    $crate::value::Value::Str(text) => text.parse(),
                    other => Err(format!("expected a name, found `{other}`")),
                }
            }
        }

        impl $crate::params::ListItem for $Name {
            const WHAT: &'static str = concat!("one of ", $($text, " "),*);
            fn parse_item(text: &str) -> Option<Self> {
                text.parse().ok()
            }
            fn write_item(&self) -> String {
                self.name().to_string()
            }
        }
    };
}

stage_params! {
    /// The parameters of a stage that has none.
    pub struct NoParams {}
}

#[cfg(test)]
mod tests {
    use super::*;

    choice! {
        /// A choice for the tests.
        enum Colour {
            Red = "red",
            DeepBlue = "deep_blue",
        }
    }

    stage_params! {
        struct Example {
            /// a length
            /// over two lines
            #[unit = "m"]
            #[min = 0.0]
            length: f64 = 0.04,
            /// how many
            #[min = 1]
            count: usize = 3,
            /// the colour
            colour: Colour = Colour::DeepBlue,
            /// some modes
            modes: Vec<i64> = vec![35, 36],
            /// a required path
            path: PathBuf,
        }
    }

    fn spec(name: &str) -> ParamSpec {
        Example::specs()
            .into_iter()
            .find(|spec| spec.name == name)
            .unwrap()
    }

    #[test]
    fn one_declaration_gives_the_specs() {
        let length = spec("length");
        assert_eq!(length.ty, ParamType::Float { min: 0.0 });
        assert_eq!(length.unit, "m");
        assert_eq!(length.default, Some(Value::Float(0.04)));
        assert_eq!(length.doc, "a length over two lines");
        assert_eq!(spec("count").ty, ParamType::Int { min: 1 });
        assert_eq!(spec("colour").ty, ParamType::Choice(&["red", "deep_blue"]));
        assert_eq!(spec("colour").default, Some(Value::Str("deep_blue".into())));
        assert_eq!(spec("modes").default, Some(Value::Str("35, 36".into())));
        assert_eq!(spec("path").default, None);
        assert_eq!(spec("path").ty, ParamType::Path);
    }

    #[test]
    fn the_same_declaration_reads_the_values() {
        let mut params = Params(
            Example::specs()
                .into_iter()
                .filter_map(|spec| Some((spec.name.to_string(), spec.default?)))
                .collect(),
        );
        params.0.insert("path".into(), Value::Str("a.msh".into()));
        params
            .0
            .insert("modes".into(), Value::Str(" 1,2 ,, 3,".into()));
        params.0.insert("colour".into(), Value::Str("red".into()));
        let example = Example::from_params(&params).unwrap();
        assert_eq!(
            example,
            Example {
                length: 0.04,
                count: 3,
                colour: Colour::Red,
                modes: vec![1, 2, 3],
                path: PathBuf::from("a.msh"),
            }
        );
    }

    #[test]
    fn a_bad_list_item_or_choice_is_an_error_naming_the_parameter() {
        let mut params = Params(
            Example::specs()
                .into_iter()
                .filter_map(|spec| Some((spec.name.to_string(), spec.default?)))
                .collect(),
        );
        params.0.insert("path".into(), Value::Str("a.msh".into()));
        params.0.insert("modes".into(), Value::Str("1, two".into()));
        let err = Example::from_params(&params).unwrap_err();
        assert_eq!(err.message, "modes: `two` is not an integer");
        params.0.insert("modes".into(), Value::Str("1".into()));
        params.0.insert("colour".into(), Value::Str("green".into()));
        let err = Example::from_params(&params).unwrap_err();
        assert_eq!(err.message, "colour: `green` is not one of red | deep_blue");
        params.0.insert("colour".into(), Value::Str("red".into()));
        params.0.remove("path");
        let err = Example::from_params(&params).unwrap_err();
        assert_eq!(err.message, "parameter `path` is missing");
    }

    stage_params! {
        struct Extended {
            ..base: Example,
            /// one more
            extra: bool = true,
        }
    }

    #[test]
    fn a_shared_struct_gives_its_parameters_under_their_own_names() {
        let names: Vec<&str> = Extended::specs().iter().map(|spec| spec.name).collect();
        assert_eq!(
            names,
            ["length", "count", "colour", "modes", "path", "extra"]
        );
        let mut params = Params(
            Extended::specs()
                .into_iter()
                .filter_map(|spec| Some((spec.name.to_string(), spec.default?)))
                .collect(),
        );
        params.0.insert("path".into(), Value::Str("a.msh".into()));
        params.0.insert("count".into(), Value::Int(7));
        let extended = Extended::from_params(&params).unwrap();
        assert_eq!((extended.base.count, extended.extra), (7, true));
        assert_eq!(
            Extended::check_field("colour", &Value::Str("green".into())).unwrap_err(),
            "`green` is not one of red | deep_blue"
        );
        assert!(Extended::check_field("extra", &Value::Bool(false)).is_ok());
        assert_eq!(
            Extended::check_field("colours", &Value::Bool(false)).unwrap_err(),
            "no parameter `colours`"
        );
    }
}
