//! Per-channel quality checks (vocab::QaFlag): non-finite values (refused),
//! clipping, flat segments, spikes (robust, MAD-based) and the
//! signal-to-noise ratio of the strong part against pre-event noise.

use serde::{Deserialize, Serialize};

use crate::vocab::QaFlag;

/// Thresholds of the quality checks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct QaSettings {
    /// Shortest run of samples at the record's extreme value that counts as clipping.
    pub clip_min_run: usize,
    /// Samples within this fraction of the extreme count as "at the extreme".
    pub clip_relative_tolerance: f64,
    /// Shortest run of identical samples reported as a flat segment, s.
    pub flat_min_duration_s: f64,
    /// A sample is a spike when its deviation from the mean of its two
    /// neighbours exceeds this many robust standard deviations (1.4826·MAD)
    /// of that deviation in the surrounding blocks.
    pub spike_threshold: f64,
    /// Length of the pre-event noise window at the start of the record, s.
    pub snr_noise_window_s: f64,
    /// Flag `LowSnr` below this value, dB.
    pub snr_min_db: f64,
}

impl Default for QaSettings {
    fn default() -> Self {
        QaSettings {
            clip_min_run: 5,
            clip_relative_tolerance: 1e-9,
            flat_min_duration_s: 1.0,
            spike_threshold: 10.0,
            snr_noise_window_s: 2.0,
            snr_min_db: 10.0,
        }
    }
}

impl QaSettings {
    /// Thresholds the checks can use, else a usage error naming the key
    /// (`qa.…`): counts and durations positive and finite, tolerances
    /// fractions, the spike threshold a number of standard deviations.
    pub fn validate(&self) -> crate::error::Result<()> {
        let bad = |m: String| Err(crate::error::Error::usage(format!("qa.{m}")));
        if self.clip_min_run < 2 {
            return bad(format!(
                "clip_min_run = {}: must be at least 2 samples",
                self.clip_min_run
            ));
        }
        if !(self.clip_relative_tolerance >= 0.0 && self.clip_relative_tolerance < 1.0) {
            return bad(format!(
                "clip_relative_tolerance = {}: must lie in [0, 1)",
                self.clip_relative_tolerance
            ));
        }
        for (key, v) in [
            ("flat_min_duration_s", self.flat_min_duration_s),
            ("snr_noise_window_s", self.snr_noise_window_s),
            ("spike_threshold", self.spike_threshold),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(format!("{key} = {v}: must be positive and finite"));
            }
        }
        if !self.snr_min_db.is_finite() {
            return bad(format!("snr_min_db = {}: must be finite", self.snr_min_db));
        }
        Ok(())
    }
}

/// Number of non-finite samples and index of the first one.
pub fn count_non_finite(data: &[f64]) -> (usize, Option<usize>) {
    let count = data.iter().filter(|v| !v.is_finite()).count();
    (count, data.iter().position(|v| !v.is_finite()))
}

/// Clipping: runs of at least `min_run` consecutive samples whose absolute
/// value is within `relative_tolerance` of the record's largest absolute
/// value. Returns the number of samples in such runs and the level.
pub fn detect_clipping(data: &[f64], min_run: usize, relative_tolerance: f64) -> Option<QaFlag> {
    let peak = data.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if peak == 0.0 || min_run == 0 {
        return None;
    }
    let threshold = peak * (1.0 - relative_tolerance);
    let mut total = 0;
    let mut run = 0;
    let mut run_sign = 0.0;
    for &v in data.iter().chain(std::iter::once(&0.0)) {
        let at_extreme = v.abs() >= threshold && v != 0.0;
        if at_extreme && (run == 0 || v.signum() == run_sign) {
            run += 1;
            run_sign = v.signum();
        } else {
            if run >= min_run {
                total += run;
            }
            run = if at_extreme { 1 } else { 0 };
            run_sign = v.signum();
        }
    }
    (total > 0).then_some(QaFlag::Clipping {
        samples: total,
        level: peak,
    })
}

/// Flat segments: runs of identical consecutive samples lasting at least
/// `min_duration_s`.
pub fn detect_flat_segments(data: &[f64], dt: f64, min_duration_s: f64) -> Vec<QaFlag> {
    let mut flags = Vec::new();
    let min_samples = ((min_duration_s / dt).ceil() as usize).max(2);
    let mut start = 0;
    for i in 1..=data.len() {
        if i == data.len() || data[i] != data[start] {
            let len = i - start;
            if len >= min_samples {
                flags.push(QaFlag::FlatSegment {
                    at_s: start as f64 * dt,
                    duration_s: (len - 1) as f64 * dt,
                });
            }
            start = i;
        }
    }
    flags
}

/// Indices of spikes: e_i = x_i − (x_{i−1} + x_{i+1})/2 compared with the
/// robust scale 1.4826·MAD(e) taken over blocks of 256 samples (the
/// largest of the block and its two neighbours, so that strong shaking,
/// which raises the local scale, is not mistaken for spikes).
pub fn spike_indices(data: &[f64], threshold: f64) -> Vec<usize> {
    const BLOCK: usize = 256;
    let n = data.len();
    if n < 3 {
        return Vec::new();
    }
    let e: Vec<f64> = (1..n - 1)
        .map(|i| data[i] - 0.5 * (data[i - 1] + data[i + 1]))
        .collect();
    let peak = data.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let floor = peak * 1e-9;
    let scales: Vec<f64> = e
        .chunks(BLOCK)
        .map(|c| {
            let mut v = c.to_vec();
            let med = crate::stats::median_in_place(&mut v);
            let mut dev: Vec<f64> = c.iter().map(|x| (x - med).abs()).collect();
            1.4826 * crate::stats::median_in_place(&mut dev)
        })
        .collect();
    let mut out = Vec::new();
    for (j, &ej) in e.iter().enumerate() {
        let b = j / BLOCK;
        let lo = b.saturating_sub(1);
        let hi = (b + 1).min(scales.len() - 1);
        let scale = scales[lo..=hi]
            .iter()
            .fold(0.0f64, |m, &s| m.max(s))
            .max(floor);
        // The neighbours of a spike of height h deviate by −h/2: only the
        // local maximum of |e| is the spike.
        let left = if j > 0 { e[j - 1].abs() } else { 0.0 };
        let right = e.get(j + 1).map_or(0.0, |v| v.abs());
        if ej.abs() > threshold * scale && ej.abs() >= left && ej.abs() > right {
            out.push(j + 1);
        }
    }
    out
}

/// RMS of a slice about its mean.
fn rms_about_mean(data: &[f64]) -> f64 {
    if data.is_empty() {
        return 0.0;
    }
    let mean = data.iter().sum::<f64>() / data.len() as f64;
    (data.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / data.len() as f64).sqrt()
}

/// Signal-to-noise ratio, dB: RMS over the strong part (5–95 % of the
/// cumulative squared signal, i.e. the Arias D5–95 window) against RMS of
/// the first `noise_window_s` seconds. None when the record is shorter
/// than twice the noise window or the noise is exactly zero.
pub fn snr_db(data: &[f64], dt: f64, noise_window_s: f64) -> Option<f64> {
    let n_noise = (noise_window_s / dt).round() as usize;
    if n_noise < 2 || data.len() < 2 * n_noise {
        return None;
    }
    let noise = rms_about_mean(&data[..n_noise]);
    if noise == 0.0 {
        return None;
    }
    let mean = data.iter().sum::<f64>() / data.len() as f64;
    let squares = || data.iter().map(|v| (v - mean) * (v - mean));
    let total: f64 = squares().fold(0.0, |acc, s| acc + s);
    // The running sum formed again (the same additions in the same order)
    // instead of kept as a series of the record's length.
    let (mut start, mut end) = (None, None);
    let mut acc = 0.0;
    for (i, s) in squares().enumerate() {
        acc += s;
        if start.is_none() && acc >= 0.05 * total {
            start = Some(i);
        }
        if acc >= 0.95 * total {
            end = Some(i);
            break;
        }
    }
    let start = start.unwrap_or(0);
    let end = end.unwrap_or(data.len() - 1);
    let signal = rms_about_mean(&data[start..=end.max(start)]);
    Some(20.0 * (signal / noise).log10())
}

/// Largest acceleration a structure's record can physically hold, m/s²
/// (100 g: strong-motion sensors clip at a few g, the strongest ground
/// motion recorded is about 4 g).  A record in SI above it comes from a
/// wrong unit or sensitivity, and is flagged rather than written silently.
pub const MAX_PLAUSIBLE_ACCELERATION_MS2: f64 = 100.0 * crate::vocab::STANDARD_GRAVITY;

/// A note when an acceleration record in m/s² exceeds
/// [`MAX_PLAUSIBLE_ACCELERATION_MS2`] (its units or sensitivity are wrong).
pub fn implausible_acceleration(data_si: &[f64]) -> Option<QaFlag> {
    let peak = data_si.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    (peak > MAX_PLAUSIBLE_ACCELERATION_MS2).then(|| QaFlag::Note {
        text: format!(
            "physically impossible: peak acceleration {peak:e} m/s² ({:e} g) is above {} g; check the channel's units and sensitivity",
            peak / crate::vocab::STANDARD_GRAVITY,
            MAX_PLAUSIBLE_ACCELERATION_MS2 / crate::vocab::STANDARD_GRAVITY
        ),
    })
}

/// All flags for one finite record (the caller refuses non-finite data first).
pub fn quality_flags(data: &[f64], dt: f64, settings: &QaSettings) -> Vec<QaFlag> {
    let mut flags = Vec::new();
    if let Some(f) = detect_clipping(
        data,
        settings.clip_min_run,
        settings.clip_relative_tolerance,
    ) {
        flags.push(f);
    }
    flags.extend(detect_flat_segments(data, dt, settings.flat_min_duration_s));
    let spikes = spike_indices(data, settings.spike_threshold);
    if !spikes.is_empty() {
        flags.push(QaFlag::Spikes {
            count: spikes.len(),
        });
    }
    if let Some(snr) = snr_db(data, dt, settings.snr_noise_window_s) {
        if snr < settings.snr_min_db {
            flags.push(QaFlag::LowSnr { snr_db: snr });
        }
    }
    flags
}
