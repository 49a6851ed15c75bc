//! The apparent-frequency evidence: per horizontal direction, the record of
//! the highest instrumented level (with the base's as input, on their common
//! time window) tracked through the event by `modal::apparent`, and its
//! before / during / after levels around the strong shaking (the base
//! record's Arias 5–95 % span, Trifunac & Brady).  I/O free: the stage hands
//! in the conditioned records and what earlier stages tabled.

use super::indicators::FrequencyEvidence;
use crate::error::Result;
use crate::modal::apparent::{track_apparent_frequency, ApparentSettings, FrequencyTrack};
use crate::vocab::{Axis, Event, Record};

/// One direction's track and what it was computed from.
#[derive(Debug, Clone)]
pub struct TrackRows {
    pub direction: String,
    pub output_channel: String,
    pub input_channel: Option<String>,
    /// The strong shaking (the base's Arias span), s from the track's origin.
    pub strong_start_s: f64,
    pub strong_end_s: f64,
    pub track: FrequencyTrack,
    /// A synthetic event's true f₁ per point (empty for a real record).
    pub truth_hz: Vec<Option<f64>>,
}

/// What earlier stages say of a direction's fundamental.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct KnownFundamentals {
    /// Lowest identified mode per direction label (`modes/modes.parquet`).
    pub identified: Vec<(String, f64)>,
    /// The reference event's lowest mode per direction label
    /// (`frequency_shifts/frequency_shifts.parquet`, with `--reference`).
    pub reference: Vec<(String, f64)>,
}

impl KnownFundamentals {
    fn of(list: &[(String, f64)], direction: &str) -> Option<f64> {
        list.iter()
            .filter(|(d, f)| d == direction && f.is_finite() && *f > 0.0)
            .map(|(_, f)| *f)
            .min_by(|a, b| a.total_cmp(b))
    }
}

fn missing(direction: &str, channels: &str, why: String) -> FrequencyEvidence {
    FrequencyEvidence {
        direction: direction.to_string(),
        channels: channels.to_string(),
        before_hz: None,
        before_source: String::new(),
        min_during_hz: None,
        after_hz: None,
        scatter: 0.0,
        why_missing: Some(why),
    }
}

/// The tracks and the frequency evidence of every horizontal direction of
/// `event` (module doc) — its records in SI units (a condition stage's
/// event: the records as recorded in the shipped pipelines); `arias` bounds
/// the strong shaking; windows reaching into the first or last
/// `edge_guard_periods` periods of the record are dropped ([`without_edges`]).
pub fn frequency_evidence(
    event: &Event,
    known: &KnownFundamentals,
    settings: &ApparentSettings,
    arias: [f64; 2],
    edge_guard_periods: f64,
) -> Result<(Vec<TrackRows>, Vec<FrequencyEvidence>)> {
    let selection = crate::geometry::one_record_per_level(&event.records);
    let mut rows = Vec::new();
    let mut evidence = Vec::new();
    for axis in [Axis::X, Axis::Y] {
        let direction = format!("{axis:?}");
        let levels: Vec<(i32, &Record)> = selection
            .records
            .iter()
            .filter(|((a, _), _)| *a == axis)
            .map(|((_, l), r)| (*l, *r))
            .collect();
        let (base, top) = if levels.is_empty() {
            // No levels (a bridge, a structure described by roles only): the
            // first input of the axis, and its most responsive output.
            match by_role(event, axis)? {
                Some(pair) => pair,
                None => continue,
            }
        } else {
            let base = levels.iter().find(|(l, _)| *l == 0).map(|(_, r)| *r);
            let Some(&(_, top)) = levels
                .iter()
                .filter(|(l, _)| *l > 0)
                .max_by_key(|(l, _)| *l)
            else {
                evidence.push(missing(
                    &direction,
                    "",
                    "no record above the base in this direction".into(),
                ));
                continue;
            };
            (base, top)
        };
        let dt = top.channel.dt();
        let output = top.samples.get()?.to_vec();
        let input_record = base.filter(|r| (r.channel.dt() - dt).abs() < 1e-12);
        // One time base: the common window of the two records.
        let (output, input, input_id) = match input_record {
            Some(rec) => {
                let input = rec.samples.get()?.to_vec();
                match crate::metrics::drift::common_window(&[
                    (&rec.channel, input.len()),
                    (&top.channel, output.len()),
                ]) {
                    Ok(w) => (
                        output[w.offsets[1]..w.offsets[1] + w.len].to_vec(),
                        Some(input[w.offsets[0]..w.offsets[0] + w.len].to_vec()),
                        Some(rec.channel.id.clone()),
                    ),
                    Err(why) => {
                        evidence.push(missing(
                            &direction,
                            &top.channel.id,
                            format!("base and output records share no time base: {why}"),
                        ));
                        continue;
                    }
                }
            }
            None => (output, None, None),
        };
        let channels = match &input_id {
            Some(i) => format!("{} / {i}", top.channel.id),
            None => top.channel.id.clone(),
        };
        let Some(expected) = expected_frequency(event, &direction, &output, dt, known) else {
            evidence.push(missing(
                &direction,
                &channels,
                if crate::modal::is_bridge(event.structure.as_ref()) {
                    "no mode identified in this direction (a bridge's spectral peaks are the ground motion's)".into()
                } else {
                    "no expected fundamental (no mode in this direction, no spectral peak, no storey count or height)".into()
                },
            ));
            continue;
        };
        let track =
            match track_apparent_frequency(input.as_deref(), &output, dt, expected, settings) {
                Ok(t) => without_edges(t, output.len() as f64 * dt, edge_guard_periods / expected),
                Err(e) => {
                    evidence.push(missing(&direction, &channels, format!("no track: {e}")));
                    continue;
                }
            };
        let arias_of = input.as_deref().unwrap_or(&output);
        let (duration, start) =
            crate::metrics::significant_duration(arias_of, dt, arias[0], arias[1])?;
        let (strong_start, strong_end) = (start, start + duration);
        let phases = track.phases(strong_start, strong_end);
        let reference = KnownFundamentals::of(&known.reference, &direction);
        let (before_hz, before_source) = match (phases.pre_hz, reference) {
            (Some(f), _) => (Some(f), "pre-event windows".to_string()),
            (None, Some(f)) => (Some(f), "reference event".to_string()),
            (None, None) => (None, String::new()),
        };
        let why_missing = if before_hz.is_none() {
            Some(format!(
                "no pre-event window: the strong shaking starts {strong_start:.1} s into the record and a window is {:.1} s long; give --reference with an earlier event",
                track.window_s
            ))
        } else if phases.post_hz.is_none() {
            Some(format!(
                "no post-event window: the record ends {:.1} s after the strong shaking and a window is {:.1} s long",
                (output.len() as f64 * dt - strong_end).max(0.0),
                track.window_s
            ))
        } else {
            None
        };
        evidence.push(FrequencyEvidence {
            direction: direction.clone(),
            channels,
            before_hz,
            before_source,
            min_during_hz: phases.min_during_hz,
            after_hz: phases.post_hz,
            scatter: phase_scatter(&track, strong_start, strong_end),
            why_missing,
        });
        rows.push(TrackRows {
            direction,
            output_channel: top.channel.id.clone(),
            input_channel: input_id,
            strong_start_s: strong_start,
            strong_end_s: strong_end,
            track,
            truth_hz: Vec::new(),
        });
    }
    Ok((rows, evidence))
}

/// The track without the windows that use samples within `guard_s` of the
/// record's start or end.  A processed record (V2: the agency's zero-phase
/// band-pass with its padding, cosine tapers) is not the structure's LTI
/// response there — both records are filtered alike only in the interior —
/// and the ARX of such a window is biased (−3.4 % at the last window of a
/// synthetic V2 record).
fn without_edges(mut track: FrequencyTrack, length_s: f64, guard_s: f64) -> FrequencyTrack {
    track
        .points
        .retain(|p| p.start_s >= guard_s && p.end_s <= length_s - guard_s);
    track
}

/// For a structure without levels: the output record of `axis` with the
/// largest RMS acceleration (the most responsive: a mid-span deck) that has
/// an input of the axis on its time base, with that input; else the most
/// responsive output alone.  `None` without an output.
fn by_role<'a>(event: &'a Event, axis: Axis) -> Result<Option<(Option<&'a Record>, &'a Record)>> {
    use crate::vocab::Role;
    let on_axis = |role: Role| {
        let mut v: Vec<&Record> = event
            .records
            .iter()
            .filter(|r| r.channel.role == role && r.channel.axis() == Some(axis))
            .filter(|r| r.channel.combined_into.is_none())
            .collect();
        v.sort_by(|a, b| a.channel.id.cmp(&b.channel.id));
        v
    };
    let mut outputs: Vec<(f64, &Record)> = Vec::new();
    for r in on_axis(Role::Output) {
        let a = r.samples.get()?;
        let rms = (a.iter().map(|v| v * v).sum::<f64>() / a.len().max(1) as f64).sqrt();
        if rms.is_finite() {
            outputs.push((rms, r));
        }
    }
    outputs.sort_by(|a, b| b.0.total_cmp(&a.0));
    // The most responsive output with an input on its time base (same start
    // and rate: a bridge's stations may be separate recorders that
    // triggered apart); else the most responsive output alone (AR).
    let inputs = on_axis(Role::Input);
    let same_base = |top: &Record| {
        inputs.iter().copied().find(|r| {
            r.channel.start_ns == top.channel.start_ns
                && (r.channel.dt() - top.channel.dt()).abs() < 1e-12
        })
    };
    let paired = outputs
        .iter()
        .find_map(|(_, top)| same_base(top).map(|input| (Some(input), *top)));
    Ok(paired.or_else(|| outputs.first().map(|(_, top)| (None, *top))))
}

/// Relative scatter of the pre- and post-event estimates (standard
/// deviation over mean of each, in quadrature): the noise a permanent drop
/// must stand out of.
pub fn phase_scatter(track: &FrequencyTrack, strong_start: f64, strong_end: f64) -> f64 {
    let half = 0.5 * track.window_s;
    let rel_std = |keep: &dyn Fn(f64) -> bool| -> f64 {
        let values: Vec<f64> = track
            .points
            .iter()
            .filter(|p| p.frequency_hz.is_finite() && keep(p.time_s))
            .map(|p| p.frequency_hz)
            .collect();
        if values.len() < 2 {
            return 0.0;
        }
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
        if mean > 0.0 {
            var.sqrt() / mean
        } else {
            0.0
        }
    };
    let pre = rel_std(&|t| t + half <= strong_start);
    let post = rel_std(&|t| t - half >= strong_end);
    pre.hypot(post)
}

/// The expected fundamental of a direction: its identified mode, unless the
/// record's lowest spectral peak lies well below it (a fundamental that
/// softened during the event, or was not selected); else the peak; else the
/// structure's estimate (EC8 / 0.1·N).
fn expected_frequency(
    event: &Event,
    direction: &str,
    output: &[f64],
    dt: f64,
    known: &KnownFundamentals,
) -> Option<f64> {
    let modal = KnownFundamentals::of(&known.identified, direction);
    let estimate = event
        .structure
        .as_ref()
        .and_then(crate::modal::fundamental_estimate)
        .map(|(f, _)| f);
    let top = modal
        .or(estimate)
        .map(|f| 1.5 * f)
        .unwrap_or(crate::modal::DEFAULT_BAND_HZ[1])
        .min(0.4 / dt);
    // A bridge's lowest spectral peaks are the ground motion's
    // (`modal::is_bridge`): only its identified mode is expected (none: the
    // direction is not tracked).
    if crate::modal::is_bridge(event.structure.as_ref()) {
        return modal;
    }
    let peak = crate::modal::lowest_peak_of_records(&[output], dt, top);
    match (modal, peak) {
        (Some(m), Some(p)) if p < 0.8 * m => Some(p),
        (Some(m), _) => Some(m),
        (None, Some(p)) => Some(p),
        (None, None) => estimate,
    }
}
