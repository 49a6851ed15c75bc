//! TEMPORARY STUB (not committed): replaced by the helper's implementation.
use serde::{Deserialize, Serialize};
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ApparentSettings {
    pub window_periods: f64,
    pub min_window_s: f64,
    pub step_fraction: f64,
}
impl Default for ApparentSettings {
    fn default() -> Self {
        ApparentSettings {
            window_periods: 5.0,
            min_window_s: 2.0,
            step_fraction: 0.25,
        }
    }
}
impl ApparentSettings {
    pub fn validate(&self) -> crate::error::Result<()> {
        Ok(())
    }
}
#[derive(Debug, Clone, PartialEq)]
pub struct TrackPoint {
    pub time_s: f64,
    pub frequency_hz: f64,
    pub damping_ratio: f64,
    pub output_rms: f64,
}
#[derive(Debug, Clone, PartialEq)]
pub struct FrequencyTrack {
    pub method: &'static str,
    pub window_s: f64,
    pub points: Vec<TrackPoint>,
}
pub fn track_apparent_frequency(
    _input: Option<&[f64]>,
    _output: &[f64],
    _dt: f64,
    _expected_hz: f64,
    _settings: &ApparentSettings,
) -> crate::error::Result<FrequencyTrack> {
    Err(crate::error::Error::numerical("stub"))
}
pub struct FrequencyPhases {
    pub pre_hz: Option<f64>,
    pub pre_windows: usize,
    pub min_during_hz: Option<f64>,
    pub post_hz: Option<f64>,
    pub post_windows: usize,
}
impl FrequencyTrack {
    pub fn phases(&self, _a: f64, _b: f64) -> FrequencyPhases {
        FrequencyPhases {
            pre_hz: None,
            pre_windows: 0,
            min_during_hz: None,
            post_hz: None,
            post_windows: 0,
        }
    }
}
