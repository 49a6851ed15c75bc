//! Explicit, recorded pre-processing of the records before identification:
//! mean removal and decimation with an anti-aliasing filter.
//!
//! Anti-aliasing filter: linear-phase FIR low-pass, windowed sinc with a
//! Blackman window (stop-band attenuation ≈ 74 dB), applied centred so that it
//! introduces no delay (zero phase), cut-off at 80 % of the new Nyquist
//! frequency, 40·D + 1 taps for a factor D.  Written here because only a
//! single fixed design is needed; the same filter is applied to inputs and
//! outputs so the input–output relation in the pass band is unchanged.

use crate::vocab::ProcessingStep;

/// Pre-processing settings.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Preprocessing {
    /// Subtract each channel's mean.
    pub remove_mean: bool,
    /// Keep every D-th sample after anti-alias filtering (1 = no
    /// decimation; `None` = automatic, see `modal::plan`).
    pub decimation: Option<usize>,
}

impl Default for Preprocessing {
    fn default() -> Self {
        Preprocessing {
            remove_mean: true,
            decimation: None,
        }
    }
}

/// FIR taps of the anti-aliasing low-pass for decimation factor `d` (unit DC gain).
pub fn antialias_taps(d: usize) -> Vec<f64> {
    let half = 20 * d;
    let len = 2 * half + 1;
    // Cut-off 0.8 × new Nyquist, in cycles per input sample.
    let fc = 0.8 * 0.5 / d as f64;
    let mut taps: Vec<f64> = (0..len)
        .map(|i| {
            let k = i as f64 - half as f64;
            let sinc = if k == 0.0 {
                2.0 * fc
            } else {
                (std::f64::consts::TAU * fc * k).sin() / (std::f64::consts::PI * k)
            };
            let x = std::f64::consts::TAU * i as f64 / (len - 1) as f64;
            let blackman = 0.42 - 0.5 * x.cos() + 0.08 * (2.0 * x).cos();
            sinc * blackman
        })
        .collect();
    let sum: f64 = taps.iter().sum();
    taps.iter_mut().for_each(|t| *t /= sum);
    taps
}

/// Zero-phase FIR filtering and decimation by `d`: output sample k is the
/// centred filter output at input sample k·d; samples beyond the record are
/// taken as zero (after mean removal this is a small edge effect).
pub fn decimate(signal: &[f64], d: usize, taps: &[f64]) -> Vec<f64> {
    if d <= 1 {
        return signal.to_vec();
    }
    let half = taps.len() / 2;
    let n = signal.len();
    (0..n.div_ceil(d))
        .map(|k| {
            let centre = k * d;
            let mut acc = 0.0;
            if centre >= half && centre + taps.len() - half <= n {
                // Every tap inside the record (the same sum, without the edge tests).
                let window = &signal[centre - half..centre - half + taps.len()];
                for (&w, &x) in taps.iter().zip(window) {
                    acc += w * x;
                }
                return acc;
            }
            for (t, &w) in taps.iter().enumerate() {
                let idx = centre as isize + t as isize - half as isize;
                if idx >= 0 && (idx as usize) < n {
                    acc += w * signal[idx as usize];
                }
            }
            acc
        })
        .collect()
}

/// Applies the pre-processing to every channel (inputs are not modified) and
/// returns the new signals, the new sampling interval and the recorded steps.
/// Channel by channel (in parallel): a channel is copied, its mean removed
/// and decimated before the next, so only the decimated signals accumulate.
pub fn apply<S: AsRef<[f64]> + Sync>(
    signals: &[S],
    dt: f64,
    settings: &Preprocessing,
) -> (Vec<Vec<f64>>, f64, Vec<ProcessingStep>) {
    use rayon::prelude::*;
    let mut steps = Vec::new();
    let d = settings.decimation.unwrap_or(1);
    let taps = (d > 1).then(|| antialias_taps(d));
    let out: Vec<Vec<f64>> = signals
        .par_iter()
        .map(|s| {
            let mut s = s.as_ref().to_vec();
            if settings.remove_mean {
                let mean = s.iter().sum::<f64>() / s.len().max(1) as f64;
                s.iter_mut().for_each(|v| *v -= mean);
            }
            match &taps {
                Some(taps) => decimate(&s, d, taps),
                None => s,
            }
        })
        .collect();
    if settings.remove_mean {
        steps.push(ProcessingStep {
            step: "remove_mean".into(),
            channels: Vec::new(),
            params: serde_json::json!({}),
        });
    }
    let mut dt_out = dt;
    if let Some(taps) = taps {
        dt_out = dt * d as f64;
        steps.push(ProcessingStep {
            step: "decimate".into(),
            channels: Vec::new(),
            params: serde_json::json!({
                "factor": d,
                "filter": "FIR windowed-sinc, Blackman window, zero phase",
                "taps": taps.len(),
                "cutoff_hz": 0.8 * 0.5 / dt_out,
                "sampling_rate_hz_in": 1.0 / dt,
                "sampling_rate_hz_out": 1.0 / dt_out,
            }),
        });
    }
    (out, dt_out, steps)
}
