//! The crate's one error: bad input names the field (a JSON-path-like
//! location, relative to what the caller passed) and says what is wrong.

use std::fmt;

/// Malformed input: a tool size, a sampling option, a face that evaluates
/// to a non-finite point, a pose with a zero axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Error {
    /// Where: `holder[1].radius_top`, `faces[3]`, `pose.axis`.
    pub field: String,
    /// What is wrong, with the offending value.
    pub message: String,
}

pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    pub fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            field: field.into(),
            message: message.into(),
        }
    }

    /// The same error seen from an enclosing field: `holder[1]` + `radius`
    /// becomes `tool.holder[1].radius` when prefixed with `tool`.
    pub fn within(mut self, outer: &str) -> Self {
        self.field = if self.field.is_empty() {
            outer.to_string()
        } else if self.field.starts_with('[') {
            format!("{outer}{}", self.field)
        } else {
            format!("{outer}.{}", self.field)
        };
        self
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.field, self.message)
    }
}

impl std::error::Error for Error {}

/// `value` must be finite and positive.
pub(crate) fn positive(field: &str, value: f64) -> Result<()> {
    if !value.is_finite() {
        return Err(Error::invalid(
            field,
            format!("{value} is not a finite number"),
        ));
    }
    if value <= 0.0 {
        return Err(Error::invalid(
            field,
            format!("must be positive, got {value}"),
        ));
    }
    Ok(())
}

/// `value` must be finite and not negative.
pub(crate) fn non_negative(field: &str, value: f64) -> Result<()> {
    if !value.is_finite() {
        return Err(Error::invalid(
            field,
            format!("{value} is not a finite number"),
        ));
    }
    if value < 0.0 {
        return Err(Error::invalid(
            field,
            format!("must not be negative, got {value}"),
        ));
    }
    Ok(())
}
