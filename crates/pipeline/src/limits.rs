//! The time limit of a job: a [`Progress`] wrapper whose check stops the
//! work once the limit has passed. The planners and the simulator check at
//! their progress points and inside their long loops, so a job over its
//! limit stops at its next check (docs/limits.md).

use std::time::Instant;
use toolpath_kernel::error::{Error, Result};
use toolpath_planners::Progress;

/// A limit on the wall-clock time of one job, and the parameter that set it
/// (named in the error, so the operator knows what to raise).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeLimit {
    pub seconds: f64,
    /// The setting it came from: `--time-limit`, `node.job_time_limit_s`, ...
    pub parameter: &'static str,
}

use toolpath_formats::job::MAX_TIME_LIMIT_S;

impl TimeLimit {
    /// Checks a limit given in `field`: finite, positive, at most [`MAX_TIME_LIMIT_S`].
    pub fn validate(seconds: f64, field: &str) -> Result<()> {
        if !seconds.is_finite() || seconds <= 0.0 || seconds > MAX_TIME_LIMIT_S {
            return Err(Error::invalid(
                field,
                format!(
                    "{seconds} is not a time limit in s: give a number in (0, {MAX_TIME_LIMIT_S}]"
                ),
            ));
        }
        Ok(())
    }
}

/// `inner`'s progress with a time limit counted from [`Limited::new`]: its
/// check fails with `Error::Stopped` (not canceled) once the limit has
/// passed, after asking `inner` first (a cancel wins over a limit).
pub(crate) struct Limited<'a> {
    inner: &'a dyn Progress,
    limit: Option<TimeLimit>,
    started: Instant,
}

impl<'a> Limited<'a> {
    pub fn new(inner: &'a dyn Progress, limit: Option<TimeLimit>) -> Self {
        Self {
            inner,
            limit,
            started: Instant::now(),
        }
    }
}

impl Progress for Limited<'_> {
    fn set(&self, fraction: f32) {
        self.inner.set(fraction)
    }

    fn check(&self) -> Result<()> {
        self.inner.check()?;
        let Some(limit) = self.limit else {
            return Ok(());
        };
        let spent = self.started.elapsed().as_secs_f64();
        if spent > limit.seconds {
            return Err(Error::Stopped {
                message: format!(
                    "over its time limit of {} s ({spent:.1} s spent; raise {} or make the job lighter: a larger scallop, tool or belt)",
                    limit.seconds, limit.parameter
                ),
                canceled: false,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_planners::NoProgress;

    #[test]
    fn a_passed_limit_stops_and_names_its_parameter() {
        let limit = TimeLimit {
            seconds: 1e-9,
            parameter: "--time-limit",
        };
        let l = Limited::new(&NoProgress, Some(limit));
        std::thread::sleep(std::time::Duration::from_millis(2));
        let e = l.check().unwrap_err();
        assert!(
            matches!(
                e,
                Error::Stopped {
                    canceled: false,
                    ..
                }
            ),
            "{e:?}"
        );
        let text = e.to_string();
        assert!(
            text.starts_with("stopped: over its time limit of 0.000000001 s (")
                && text.contains("--time-limit"),
            "{text}"
        );
        let long = Limited::new(
            &NoProgress,
            Some(TimeLimit {
                seconds: 3600.0,
                parameter: "x",
            }),
        );
        assert!(long.check().is_ok());
        assert!(Limited::new(&NoProgress, None).check().is_ok());
    }

    #[test]
    fn limits_outside_the_range_are_refused() {
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e9] {
            let e = TimeLimit::validate(bad, "time_limit_s").unwrap_err();
            assert!(e.to_string().contains("time_limit_s"), "{e}");
        }
        TimeLimit::validate(0.5, "time_limit_s").unwrap();
    }
}
