//! Windows of a continuous record: durations as people write them (`1h`,
//! `30m`), and the window grid of a span.

use crate::error::{Error, Result};

pub const NS_PER_S: i64 = 1_000_000_000;

/// Parses a duration `N[s|m|h|d]` (a plain number is seconds; decimals
/// allowed: `1.5h`) into nanoseconds; zero, negative or unreadable values
/// are usage errors naming `flag`.
pub fn parse_duration(flag: &str, text: &str) -> Result<i64> {
    let t = text.trim();
    let (number, unit) = match t.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => (&t[..i], c),
        _ => (t, 's'),
    };
    let scale = match unit {
        's' => 1.0,
        'm' => 60.0,
        'h' => 3600.0,
        'd' => 86_400.0,
        _ => f64::NAN,
    };
    let value: f64 = number.trim().parse().unwrap_or(f64::NAN);
    let seconds = value * scale;
    if !(seconds.is_finite() && seconds > 0.0 && seconds < 1e9) {
        return Err(Error::usage(format!(
            "{flag} {text:?} is not a positive duration (examples: 1h, 30m, 600s, 2d)"
        )));
    }
    Ok((seconds * 1e9).round() as i64)
}

/// Longest monitoring window (`--window`), ns: one day.
pub const MAX_WINDOW_NS: i64 = 86_400 * 1_000_000_000;
/// Most windows of one track run (a year of one-minute steps is 525 600).
pub const MAX_WINDOWS: i64 = 1_000_000;

/// The windows `[t, t + length)` for t = start, start + step, … that end
/// by `end`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WindowGrid {
    pub start_ns: i64,
    pub end_ns: i64,
    pub length_ns: i64,
    pub step_ns: i64,
}

impl WindowGrid {
    /// Checks the grid: positive length and step, at least one window.
    pub fn new(start_ns: i64, end_ns: i64, length_ns: i64, step_ns: i64) -> Result<WindowGrid> {
        if end_ns <= start_ns {
            return Err(Error::usage("--end must be after --start"));
        }
        if length_ns <= 0 || step_ns <= 0 {
            return Err(Error::usage("--window and --step must be positive"));
        }
        if length_ns > MAX_WINDOW_NS {
            return Err(Error::usage(format!(
                "--window {:.0} s: at most one day ({} s); a window's samples are held at once",
                length_ns as f64 / 1e9,
                MAX_WINDOW_NS / 1_000_000_000
            )));
        }
        let windows =
            (end_ns.saturating_sub(start_ns).saturating_sub(length_ns) / step_ns).saturating_add(1);
        if windows > MAX_WINDOWS {
            return Err(Error::usage(format!(
                "--step {:.3} s gives {windows} windows from --start to --end: at most {MAX_WINDOWS} (choose a longer step or a shorter span)",
                step_ns as f64 / 1e9
            )));
        }
        if start_ns + length_ns > end_ns {
            return Err(Error::usage(format!(
                "the span from --start to --end ({:.0} s) is shorter than one window ({:.0} s)",
                (end_ns - start_ns) as f64 / 1e9,
                length_ns as f64 / 1e9
            )));
        }
        Ok(WindowGrid {
            start_ns,
            end_ns,
            length_ns,
            step_ns,
        })
    }

    /// Start times of the windows, in order.
    pub fn starts(&self) -> Vec<i64> {
        let mut v = Vec::new();
        let mut t = self.start_ns;
        while t + self.length_ns <= self.end_ns {
            v.push(t);
            t += self.step_ns;
        }
        v
    }
}
