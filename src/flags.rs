//! Values of command-line flags (and the Python package's keywords that
//! mirror them) checked once, with a usage error naming the flag.

use std::time::Duration;

use crate::error::{Error, Result};

/// Longest duration a seconds flag takes (one day).
pub const MAX_FLAG_SECONDS: f64 = 86_400.0;

/// A number of seconds, positive (or zero where `zero_allowed`) and at most
/// [`MAX_FLAG_SECONDS`].
pub fn seconds(flag: &str, s: f64, zero_allowed: bool) -> Result<Duration> {
    if zero_allowed && s == 0.0 {
        return Ok(Duration::ZERO);
    }
    if s.is_finite() && s > 0.0 && s <= MAX_FLAG_SECONDS {
        Ok(Duration::from_secs_f64(s))
    } else {
        Err(Error::usage(format!(
            "{flag} {s}: seconds, positive{} and at most {MAX_FLAG_SECONDS}",
            if zero_allowed { " or zero" } else { "" }
        )))
    }
}
