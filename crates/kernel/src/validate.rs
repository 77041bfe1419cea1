//! Checks of numbers read from files, messages and configs. Each returns
//! `Error::invalid` with the field path it is given and a reason that names
//! the value, so every layer refuses bad input with the same words.

use crate::error::{Error, Result};

/// `x` is a finite number: "`x` is not a finite number" otherwise.
pub fn finite(field: &str, x: f64) -> Result<()> {
    if !x.is_finite() {
        return Err(Error::invalid(field, format!("{x} is not a finite number")));
    }
    Ok(())
}

/// Every value is finite; the error names the first that is not as
/// `field[k]`.
pub fn finite_each(field: &str, values: &[f64]) -> Result<()> {
    for (k, &x) in values.iter().enumerate() {
        finite(&format!("{field}[{k}]"), x)?;
    }
    Ok(())
}

/// `x` is finite ([`finite`]) and above 0: "must be positive, got `x`"
/// otherwise.
pub fn positive(field: &str, x: f64) -> Result<()> {
    finite(field, x)?;
    if x <= 0.0 {
        return Err(Error::invalid(field, format!("must be positive, got {x}")));
    }
    Ok(())
}

/// `x` is finite and above 0, with one reason for both: "must be a positive
/// finite number, got `x`" (machine configs and post settings word it so).
pub fn positive_finite(field: &str, x: f64) -> Result<()> {
    if !x.is_finite() || x <= 0.0 {
        return Err(Error::invalid(
            field,
            format!("must be a positive finite number, got {x}"),
        ));
    }
    Ok(())
}

/// `x` is finite and at least 0: "must be a finite number >= 0" otherwise.
pub fn non_negative(field: &str, x: f64) -> Result<()> {
    if !x.is_finite() || x < 0.0 {
        return Err(Error::invalid(field, "must be a finite number >= 0"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reason(r: Result<()>) -> (String, String) {
        match r {
            Err(Error::Invalid { field, message }) => (field, message),
            other => panic!("expected Error::Invalid, got {other:?}"),
        }
    }

    #[test]
    fn each_check_accepts_its_range_and_names_field_and_value_outside_it() {
        let bad = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY];
        for x in bad {
            assert_eq!(
                reason(finite("a.b", x)),
                ("a.b".into(), format!("{x} is not a finite number"))
            );
            assert_eq!(
                reason(positive("a.b", x)),
                ("a.b".into(), format!("{x} is not a finite number"))
            );
            assert_eq!(
                reason(positive_finite("a", x)).1,
                format!("must be a positive finite number, got {x}")
            );
            assert_eq!(
                reason(non_negative("a", x)).1,
                "must be a finite number >= 0"
            );
        }
        for x in [0.0, -0.0, -1e-300, -5.0] {
            assert_eq!(
                reason(positive("r", x)),
                ("r".into(), format!("must be positive, got {x}"))
            );
            assert!(positive_finite("r", x).is_err());
        }
        for x in [-1e-300, -5.0] {
            assert!(non_negative("r", x).is_err());
        }
        for x in [0.0, -0.0, 1e-300, 7.5, f64::MAX] {
            assert!(finite("x", x).is_ok() && non_negative("x", x).is_ok());
        }
        for x in [1e-300, 7.5, f64::MAX] {
            assert!(positive("x", x).is_ok() && positive_finite("x", x).is_ok());
        }
        assert!(finite("x", -3.0).is_ok());
    }

    #[test]
    fn finite_each_names_the_first_bad_index() {
        assert!(finite_each("origin", &[0.0, -1.0, 2.0]).is_ok());
        assert_eq!(
            reason(finite_each("origin", &[0.0, f64::NAN, f64::INFINITY])),
            ("origin[1]".into(), "NaN is not a finite number".into())
        );
    }
}
