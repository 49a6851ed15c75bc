//! The χ² change test of every monitoring window against the training
//! period (docs/monitoring.md "Change test", docs/statistics.md Eqs. C1–C7;
//! the test itself: [`crate::modal::change_test`]).
//!
//! Each window keeps its normalised output covariances ([`window_covariances`],
//! computed from the signals when it is identified); the training windows
//! also keep those of their blocks, from which the reference's null space
//! and residual covariance come.  The model order is twice the number of
//! reference modes (the modes tracked), so the null space is the part of
//! the covariances those modes do not explain.  Training windows are
//! tested against a reference they are part of (their statistics are
//! smaller than an independent window's): the `training` column says so.

use crate::modal::change_test::{
    covariance_blocks, max_lag_for, reference_from, ChangeTestResult, ChangeTestSettings,
    CovarianceBlocks, HankelShape, DEFAULT_MAX_ORDER, MAX_CHANNELS,
};

/// The covariances of a window's signals for the change test, `None` with
/// more than [`MAX_CHANNELS`] channels or when the window is too short.
/// `lag_step`: the identification's decimation factor (lags in steps of
/// the rate it found enough for the band).
pub fn window_covariances(
    signals: &[Vec<f64>],
    lag_step: usize,
    settings: &ChangeTestSettings,
) -> Option<CovarianceBlocks> {
    if signals.len() < 2 || signals.len() > MAX_CHANNELS {
        return None;
    }
    let views: Vec<&[f64]> = signals.iter().map(|s| s.as_slice()).collect();
    let max_lag = max_lag_for(DEFAULT_MAX_ORDER, signals.len());
    covariance_blocks(&views, max_lag, lag_step, settings.blocks_per_record).ok()
}

/// Change tests of the windows (None where a window has no covariances)
/// against the windows with `training[i]`, for `modes` reference modes;
/// and a note when no test could be made.
pub fn test_windows(
    covariances: &[Option<&CovarianceBlocks>],
    training: &[bool],
    modes: usize,
    settings: &ChangeTestSettings,
) -> (Vec<Option<ChangeTestResult>>, Option<String>) {
    let none = |why: String| (vec![None; covariances.len()], Some(why));
    let reference: Vec<CovarianceBlocks> = covariances
        .iter()
        .zip(training)
        .filter(|(c, &t)| t && c.is_some_and(|c| !c.blocks.is_empty()))
        .filter_map(|(c, _)| c.cloned())
        .collect();
    let Some(first) = reference.first() else {
        return none(
            "no training window kept its covariances (more than 16 channels, or windows too short)"
                .into(),
        );
    };
    let l = first.channels;
    let shape = HankelShape::for_order((2 * modes).clamp(2, DEFAULT_MAX_ORDER), l);
    let reference = match reference_from(&reference, shape) {
        Ok(r) => r,
        Err(e) => return none(e.to_string()),
    };
    let tests = covariances
        .iter()
        .map(|c| c.and_then(|c| reference.test(c, settings.false_alarm_rate).ok()))
        .collect();
    (tests, None)
}
