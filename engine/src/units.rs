//! Parameter values against their declarations: types, bounds and units.
//!
//! Parameters are SI. A numeric parameter may be written as a bare number (SI) or as a string
//! `"<number> <unit>"` whose unit is the declared one with an optional decimal prefix
//! (`40 mm`, `17 kHz`, `210 GPa`); the value is converted to SI (rounded once, as the number
//! written in SI would be) before it is hashed, so `0.04` and `"40 mm"`, or `5e-6` and
//! `"5 us"`, are the same parameter value.

use squeal_contract::{ParamSpec, ParamType, Value};

use crate::spec::RawValue;

/// Decimal prefixes and their powers of ten.
const PREFIXES: &[(&str, i32)] = &[
    ("G", 9),
    ("M", 6),
    ("k", 3),
    ("c", -2),
    ("m", -3),
    ("u", -6),
    ("µ", -6),
    ("n", -9),
];

/// Checks `raw` against `spec`, converting units. The error is one line, without location.
pub fn convert(spec: &ParamSpec, raw: &RawValue) -> Result<Value, String> {
    let value = match (&spec.ty, raw) {
        (ParamType::Bool, RawValue::Bool(value)) => Value::Bool(*value),
        (ParamType::Int { .. }, RawValue::Int(value)) => Value::Int(*value),
        (ParamType::Float { .. }, RawValue::Int(value)) => Value::Float(*value as f64),
        (ParamType::Float { .. }, RawValue::Float(value)) => Value::Float(*value),
        (ParamType::Float { .. }, RawValue::Str(text)) => Value::Float(with_unit(spec, text)?),
        (ParamType::Str | ParamType::List | ParamType::Path, RawValue::Str(text)) => {
            Value::Str(text.clone())
        }
        (ParamType::List, RawValue::List(items)) => Value::Str(comma_separated(items)?),
        (ParamType::List, scalar @ (RawValue::Int(_) | RawValue::Float(_) | RawValue::Bool(_))) => {
            Value::Str(scalar.to_string())
        }
        (ParamType::Choice(choices), RawValue::Str(text)) if choices.contains(&text.as_str()) => {
            Value::Str(text.clone())
        }
        (ty, raw) => return Err(format!("expected {ty}, found {raw}")),
    };
    check_bounds(spec, &value)?;
    Ok(value)
}

/// A list's items as the one string a list parameter holds: `[35, hub]` → `"35, hub"`.
fn comma_separated(items: &[RawValue]) -> Result<String, String> {
    let items = items
        .iter()
        .map(|item| match item {
            RawValue::Str(text) if text.contains(',') => Err(format!(
                "item {item} holds a comma, which would split it in two"
            )),
            RawValue::Str(text) => Ok(text.clone()),
            RawValue::List(_) => Err(format!("expected a list of scalars, found the list {item}")),
            scalar => Ok(scalar.to_string()),
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(items.join(", "))
}

fn check_bounds(spec: &ParamSpec, value: &Value) -> Result<(), String> {
    match (&spec.ty, value) {
        (ParamType::Float { min }, Value::Float(value)) if !value.is_finite() || value < min => {
            Err(format!(
                "{value} is out of range: expected a finite float >= {min}"
            ))
        }
        (ParamType::Int { min }, Value::Int(value)) if value < min => {
            Err(format!("{value} is out of range: expected an int >= {min}"))
        }
        _ => Ok(()),
    }
}

/// `"40 mm"` for a parameter in `m` → 0.04.
fn with_unit(spec: &ParamSpec, text: &str) -> Result<f64, String> {
    let text = text.trim();
    let split = text
        .find(|c: char| {
            c.is_whitespace() || (c.is_alphabetic() && c != 'e' && c != 'E') || c == 'µ'
        })
        .unwrap_or(text.len());
    let (number_text, unit) = (text[..split].trim(), text[split..].trim());
    let number: f64 = number_text.parse().map_err(|_| {
        format!(
            "expected a number with an optional unit ({}), found \"{text}\"",
            unit_name(spec)
        )
    })?;
    if unit.is_empty() || unit == spec.unit {
        return Ok(number);
    }
    if !spec.unit.is_empty() {
        for &(prefix, power) in PREFIXES {
            if unit.strip_prefix(prefix) == Some(spec.unit) {
                return Ok(shifted(number_text, number, power));
            }
        }
    }
    Err(format!(
        "unit `{unit}` does not match the parameter's unit ({})",
        unit_name(spec)
    ))
}

/// The decimal number `text` (which parses to `number`) times `10^power`, rounded once:
/// `"5 us"` is exactly the value of `5e-6` (`5.0 * 1e-6` is not), so a value means one
/// parameter whichever way it is written, and sweep instances are named by the number written.
fn shifted(text: &str, number: f64, power: i32) -> f64 {
    let (mantissa, exponent) = match text.find(['e', 'E']) {
        Some(at) => (&text[..at], text[at + 1..].parse::<i32>().ok()),
        None => (text, Some(0)),
    };
    exponent
        .and_then(|exponent| {
            format!("{mantissa}e{}", exponent.checked_add(power)?)
                .parse()
                .ok()
        })
        .unwrap_or(number * 10f64.powi(power))
}

fn unit_name(spec: &ParamSpec) -> String {
    if spec.unit.is_empty() {
        "dimensionless".into()
    } else {
        format!("`{}`", spec.unit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(spec: &ParamSpec, raw: RawValue, expected: Result<Value, &str>) {
        let actual = convert(spec, &raw);
        match (actual, expected) {
            (Ok(actual), Ok(expected)) => assert_eq!(actual, expected),
            (Err(actual), Err(expected)) => assert!(actual.contains(expected), "{actual}"),
            (actual, expected) => panic!("{raw}: got {actual:?}, expected {expected:?}"),
        }
    }

    #[test]
    fn units_convert_to_si() {
        let thickness = ParamSpec::float("thickness", 0.04, "m", "disc thickness");
        let float = |value| Ok(Value::Float(value));
        check(&thickness, RawValue::Float(0.04), float(0.04));
        check(&thickness, RawValue::Int(1), float(1.0));
        check(&thickness, RawValue::Str("40 mm".into()), float(0.04));
        check(&thickness, RawValue::Str("4cm".into()), float(0.04));
        check(&thickness, RawValue::Str("0.04 m".into()), float(0.04));
        check(&thickness, RawValue::Str("4e1 mm".into()), float(0.04));
        // Rounded once, as the number written in SI: 5.0 * 1e-6 is 4.9999999999999996e-6.
        let tau = ParamSpec::float("tau", 1e-6, "s", "time step");
        check(&tau, RawValue::Str("5 us".into()), float(5e-6));
        check(&tau, RawValue::Str("100 us".into()), float(1e-4));
        check(&tau, RawValue::Str("0.3 ms".into()), float(3e-4));
        check(&tau, RawValue::Str("2.5E-1 ns".into()), float(2.5e-10));
        check(&tau, RawValue::Str("-7 ks".into()), float(-7e3));
        check(
            &tau,
            RawValue::Str("1e99999999999 us".into()),
            Err("out of range"),
        );
        check(
            &thickness,
            RawValue::Str("40 Hz".into()),
            Err("unit `Hz` does not match"),
        );
        check(
            &thickness,
            RawValue::Str("forty".into()),
            Err("expected a number"),
        );
        check(
            &thickness,
            RawValue::Bool(true),
            Err("expected float, found true"),
        );
        let modulus = ParamSpec::float("E", 2.02e11, "Pa", "Young's modulus");
        check(&modulus, RawValue::Str("202 GPa".into()), float(2.02e11));
        let mu = ParamSpec::float("mu", 0.38, "", "friction coefficient").at_least(0.0);
        check(&mu, RawValue::Str("0.3 Pa".into()), Err("(dimensionless)"));
        check(&mu, RawValue::Float(-0.1), Err("out of range"));
    }

    #[test]
    fn other_types_are_strict() {
        let count = ParamSpec::int("n", 4, "count").at_least(1.0);
        check(&count, RawValue::Int(3), Ok(Value::Int(3)));
        check(
            &count,
            RawValue::Float(3.0),
            Err("expected int >= 1, found 3"),
        );
        check(&count, RawValue::Int(0), Err("out of range"));
        let method = ParamSpec::choice("method", &["krylov", "projection"], "krylov", "solver");
        check(
            &method,
            RawValue::Str("krylov".into()),
            Ok(Value::Str("krylov".into())),
        );
        check(
            &method,
            RawValue::Str("qz".into()),
            Err("expected one of krylov | projection"),
        );
    }

    #[test]
    fn a_list_is_kept_as_its_comma_separated_string() {
        let modes = ParamSpec::list("modes", "", "mode numbers");
        let text = |value: &str| Ok(Value::Str(value.into()));
        let list = |items: Vec<RawValue>| RawValue::List(items);
        check(
            &modes,
            list(vec![RawValue::Int(35), RawValue::Int(36)]),
            text("35, 36"),
        );
        check(&modes, RawValue::Str("35, 36".into()), text("35, 36"));
        check(&modes, list(vec![]), text(""));
        check(
            &modes,
            list(vec![RawValue::Str("hub".into()), RawValue::Float(0.5)]),
            text("hub, 0.5"),
        );
        check(
            &modes,
            list(vec![RawValue::Str("a, b".into())]),
            Err("holds a comma"),
        );
        check(
            &modes,
            list(vec![list(vec![RawValue::Int(1)])]),
            Err("expected a list of scalars, found the list [1]"),
        );
        check(&modes, RawValue::Int(35), text("35"));
        let count = ParamSpec::int("n", 4, "count");
        check(
            &count,
            list(vec![RawValue::Int(1)]),
            Err("expected int, found [1]"),
        );
    }
}
