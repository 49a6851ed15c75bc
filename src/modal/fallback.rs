//! Method `auto` on an earthquake record: input–output identification, and
//! output-only SSI-COV when that selects no mode, keeping only the modes
//! that are resonances of the structure (docs/pipelines.md, `method`).
//!
//! Why: input–output identification needs base channels that are the
//! structure's input.  On a bridge driven at its abutments as well as at the
//! one bent with ground sensors they are not, and `io` finds only scattered
//! poles (CESMD Lake Crowley), while output-only identification finds the
//! transverse mode in both events.  Output-only identification of an
//! earthquake record also finds the peaks of the ground motion itself (site,
//! source, digitisation noise of film records: CESMD Painter St. 1980), so
//! a fallback mode must be amplified by the structure.

use super::spectrum::structural_amplification;
use super::{direction_label, identify_event, ChannelChoice, Method, ModalResult, ModalSettings};
use crate::error::Result;
use crate::vocab::Event;

/// A mode found output-only on an earthquake record must be a resonance:
/// the response at its frequency larger than the ground motion by this
/// factor (6 dB; a 5 %-damped mode amplifies ≈ 10×).  Below it the peak is
/// the ground motion's own.
pub const MIN_AMPLIFICATION: f64 = 2.0;

/// Half-width of the band the amplification is measured over, relative.
const AMPLIFICATION_BAND: f64 = 0.05;

/// Identifies `event` with `settings` (method `Io` as resolved by `auto`);
/// when that selects no mode, runs output-only SSI-COV on the same outputs
/// and keeps its resonances.  Returns the result kept and its settings.  A
/// note says when the fallback was used and why `io` found nothing; a
/// warning names the fallback candidates that were not resonances.
pub fn identify_event_or_output_only(
    event: &Event,
    settings: &ModalSettings,
    choice: &ChannelChoice,
) -> Result<(ModalResult, ModalSettings)> {
    let mut result = identify_event(event, settings, choice)?;
    let may_fall_back = settings.method == Method::Io
        && settings.manual_frequencies_hz.is_none()
        && result.modes.is_empty();
    if !may_fall_back {
        return Ok((result, settings.clone()));
    }
    let output_only = ModalSettings {
        method: Method::SsiCov,
        ..settings.clone()
    };
    let mut fallback = identify_event(event, &output_only, choice)?;
    let not_resonances = withdraw_unamplified(event, &mut fallback, &result.input_ids)?;
    if fallback.modes.is_empty() {
        if !not_resonances.is_empty() {
            result.warnings.push(format!(
                "output-only SSI-COV (tried because input–output found nothing) found only peaks the ground motion brings: {}",
                not_resonances.join("; ")
            ));
        }
        return Ok((result, settings.clone()));
    }
    fallback.notes.push(format!(
        "method auto: input–output identification with base channels {} selected no mode ({}); \
         output-only SSI-COV used instead, keeping the modes the structure amplifies ≥ {MIN_AMPLIFICATION} × \
         over the ground motion: the base channels may not be the structure's input (a bridge excited at \
         several supports, a sensor off the foundation). State `method` to choose",
        result.input_ids.join(", "),
        result.warnings.join("; ")
    ));
    fallback.warnings.extend(
        not_resonances
            .iter()
            .map(|w| format!("output-only candidate is not a resonance: {w}")),
    );
    Ok((fallback, output_only))
}

/// Withdraws the modes of an output-only `result` whose frequency the
/// response does not amplify over the ground motion: the amplification
/// ([`structural_amplification`]) of the channel carrying the mode's
/// largest shape component over the base channels `input_ids` in its
/// direction (all of them when none is).  Returns a description of each
/// withdrawn mode.
fn withdraw_unamplified(
    event: &Event,
    result: &mut ModalResult,
    input_ids: &[String],
) -> Result<Vec<String>> {
    struct Channel {
        samples: Vec<f64>,
        dt: f64,
        direction: String,
    }
    let channel = |id: &str| -> Result<Option<Channel>> {
        let Some(record) = event.record(id) else {
            return Ok(None);
        };
        Ok(Some(Channel {
            samples: record.samples.get()?.into_owned(),
            dt: record.channel.dt(),
            direction: direction_label(&record.channel),
        }))
    };
    let mut ground = Vec::new();
    for id in input_ids {
        ground.extend(channel(id)?);
    }
    let mut reasons = Vec::with_capacity(result.modes.len());
    let mut withdrawn = Vec::new();
    for mode in &result.modes {
        let dominant = (0..mode.shape.len())
            .max_by(|&a, &b| mode.shape[a].norm().total_cmp(&mode.shape[b].norm()))
            .unwrap_or(0);
        let Some(response) = channel(&result.output_ids[dominant])? else {
            reasons.push(None);
            continue;
        };
        let comparable =
            |u: &&Channel| u.samples.len() == response.samples.len() && u.dt == response.dt;
        let same_direction: Vec<&[f64]> = ground
            .iter()
            .filter(comparable)
            .filter(|u| u.direction == response.direction)
            .map(|u| u.samples.as_slice())
            .collect();
        let inputs: Vec<&[f64]> = if same_direction.is_empty() {
            ground
                .iter()
                .filter(comparable)
                .map(|u| u.samples.as_slice())
                .collect()
        } else {
            same_direction
        };
        // Segments of 8 s or 4 periods, whichever is longer (≥ 4 averages
        // on a 40-s record at the frequencies of bridges and buildings).
        let seconds = (8.0f64).max(4.0 / mode.frequency_hz);
        let seg = (seconds / response.dt).round() as usize;
        let amplification = structural_amplification(
            &response.samples,
            &inputs,
            response.dt,
            seg,
            mode.frequency_hz,
            AMPLIFICATION_BAND,
        );
        match amplification {
            Some(a) if a < MIN_AMPLIFICATION => {
                let text = format!(
                    "{:.3} Hz: response at {} only {a:.2} × the ground motion (need {MIN_AMPLIFICATION})",
                    mode.frequency_hz, result.output_ids[dominant]
                );
                reasons.push(Some(format!("not a resonance: {text}")));
                withdrawn.push(text);
            }
            _ => reasons.push(None),
        }
    }
    result.withdraw_modes(&reasons);
    Ok(withdrawn)
}
