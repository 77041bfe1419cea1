//! Errors: every one names the input (`what`, e.g. `positions[12][3]`) and
//! says what is wrong with it.

/// What went wrong, and where.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Error {
    /// Bad input: `what` names the offending value.
    #[error("{what}: {why}")]
    Invalid { what: String, why: String },
    /// The input is well formed but no motion meets the limits.
    #[error("{what}: {why}")]
    Infeasible { what: String, why: String },
}

impl Error {
    pub fn invalid(what: impl Into<String>, why: impl Into<String>) -> Self {
        Error::Invalid {
            what: what.into(),
            why: why.into(),
        }
    }

    pub fn infeasible(what: impl Into<String>, why: impl Into<String>) -> Self {
        Error::Infeasible {
            what: what.into(),
            why: why.into(),
        }
    }
}

pub type Result<T> = std::result::Result<T, Error>;

/// A limit must be a finite number above zero.
pub(crate) fn check_positive(what: &str, x: f64) -> Result<()> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(
            what,
            format!("is {x}: a limit must be a finite number above 0"),
        ))
    }
}

/// Every value of `row` finite.
pub(crate) fn check_finite(what: &str, row: &[f64]) -> Result<()> {
    match row.iter().position(|x| !x.is_finite()) {
        Some(j) => Err(Error::invalid(
            format!("{what}[{j}]"),
            format!("is {}, not a finite number", row[j]),
        )),
        None => Ok(()),
    }
}
