//! The rows of `history_modes/history_modes.parquet` and `history_events/history_events.parquet`, the
//! fitted bands as metadata JSON, and the `--json` summary, from the
//! analysed structures.

use super::{Analysed, ModeSummary, StructureSummary};
use crate::history::{HistorySettings, ModeHistory, Status};
use crate::sinks::history_tables::{HistoryEventRow, HistoryModeRow};

/// The step of a mode: (first event, its time, %, p-value).
fn step_of(a: &Analysed, m: &ModeHistory) -> Option<(String, Option<i64>, f64, f64)> {
    let band = m.assessment.band.as_ref()?;
    let step = band.step?;
    let member = &m.track.members[step.from];
    let e = &a.history.events[member.event];
    Some((
        e.event.clone(),
        e.time_ns,
        100.0 * step.relative_change,
        step.p_value,
    ))
}

/// One row per followed mode and event holding it, by mode then date.
pub fn mode_rows(a: &Analysed) -> Vec<HistoryModeRow> {
    let events = &a.history.events;
    let mut rows = Vec::new();
    for m in &a.history.modes {
        let step = step_of(a, m);
        for (k, member) in m.track.members.iter().enumerate() {
            let e = &events[member.event];
            let mode = &e.modes[member.mode];
            let v = &m.assessment.verdicts[k];
            let band = v.band;
            rows.push(HistoryModeRow {
                structure: a.structure.clone(),
                event: e.event.clone(),
                event_time_ns: e.time_ns,
                mode: m.id as u32,
                direction: m.track.direction.clone(),
                event_mode: member.mode as u32 + 1,
                event_direction: mode.direction.clone(),
                frequency_hz: mode.frequency_hz,
                frequency_std_hz: mode.frequency_std_hz,
                damping_ratio: mode.damping_ratio,
                paired_with_event: member.paired_with.map(|(ev, _)| events[ev].event.clone()),
                mac: member.mac,
                intensity_m_s2: e.intensity_m_s2,
                predicted_frequency_hz: band.map(|b| b.0),
                band_low_hz: band.map(|b| b.1),
                band_high_hz: band.map(|b| b.2),
                deviation_percent: band.map(|b| 100.0 * (mode.frequency_hz - b.0) / b.0),
                status: v.status.name().to_string(),
                fitted: v.fitted,
                after_step: v.after_step,
                step_event: step.as_ref().map(|s| s.0.clone()),
                step_time_ns: step.as_ref().and_then(|s| s.1),
                step_percent: step.as_ref().map(|s| s.2),
                step_p_value: step.as_ref().map(|s| s.3),
            });
        }
    }
    rows
}

/// Severity order of an event's status (most severe first).
const SEVERITY: [&str; 7] = [
    "step",
    "below_band",
    "amplitude_softened",
    "above_band",
    "in_band",
    "no_band",
    "no_modes",
];

fn label(m: &ModeHistory) -> String {
    if m.track.direction.is_empty() {
        format!("mode {}", m.id)
    } else {
        format!("mode {} ({})", m.id, m.track.direction)
    }
}

/// One row per event, in date order.
pub fn event_rows(a: &Analysed) -> Vec<HistoryEventRow> {
    let events = &a.history.events;
    (0..events.len())
        .map(|i| {
            let e = &events[i];
            let s = &a.sources[i];
            let p = &a.predictions[i];
            let mut statuses: Vec<&str> = Vec::new();
            let mut flags = Vec::new();
            for m in &a.history.modes {
                let Some(k) = m.track.members.iter().position(|x| x.event == i) else {
                    continue;
                };
                let v = &m.assessment.verdicts[k];
                let f = e.modes[m.track.members[k].mode].frequency_hz;
                statuses.push(v.status.name());
                if v.status.flagged() {
                    let (pred, lo, hi) = v.band.unwrap_or((f64::NAN, f64::NAN, f64::NAN));
                    flags.push(format!(
                        "{} {:.3} Hz: {} ({:+.1} % from the predicted {:.3} Hz, band {:.3}–{:.3} Hz)",
                        label(m),
                        f,
                        v.status.name(),
                        100.0 * (f - pred) / pred,
                        pred,
                        lo,
                        hi
                    ));
                }
                if let Some(step) = m.assessment.band.as_ref().and_then(|b| b.step) {
                    if step.from == k {
                        statuses.push("step");
                        flags.push(format!(
                            "{}: permanent shift of {:+.1} % from this event on (p = {:.2e})",
                            label(m),
                            100.0 * step.relative_change,
                            step.p_value
                        ));
                    }
                }
            }
            let status = if e.modes.is_empty() {
                "no_modes"
            } else {
                SEVERITY
                    .iter()
                    .copied()
                    .find(|s| statuses.contains(s))
                    .unwrap_or("no_band")
            };
            let errors: Vec<f64> = p.errors.iter().map(|c| c.normalised_error).collect();
            let mut notes = s.notes.clone();
            notes.extend(p.notes.iter().cloned());
            HistoryEventRow {
                structure: a.structure.clone(),
                structure_name: s.structure_name.clone(),
                event: e.event.clone(),
                partition: s.event.partition.to_string_lossy().replace('\\', "/"),
                event_time_ns: e.time_ns,
                time_source: s.time_source.to_string(),
                peak_base_m_s2: s.peak_base_m_s2,
                peak_response_m_s2: s.peak_response_m_s2,
                intensity_m_s2: e.intensity_m_s2,
                rating: s.rating.clone(),
                modes: e.modes.len() as u32,
                status: status.to_string(),
                flags,
                predicted_from: p.from.clone(),
                prediction_channels: p.errors.iter().map(|c| c.channel_id.clone()).collect(),
                prediction_error_median: super::median(&errors),
                prediction_errors: errors,
                model_error_median: p.model_error_median,
                notes,
            }
        })
        .collect()
}

/// `quaketwin.history_models`: per structure and mode with a band, H1's
/// coefficients, s, the degrees of freedom, t, (XᵀX)⁻¹ (to redraw the
/// band at any intensity: docs/formats.md), the step and the fitted events.
pub fn models_json(analysed: &[Analysed], settings: &HistorySettings) -> serde_json::Value {
    let mut list = Vec::new();
    for a in analysed {
        for m in &a.history.modes {
            let Some(b) = &m.assessment.band else {
                continue;
            };
            let mut regressors = vec!["intercept", "ln_intensity_g"];
            if b.step.is_some() {
                regressors.push("after_step");
            }
            list.push(serde_json::json!({
                "structure": a.structure,
                "mode": m.id,
                "direction": m.track.direction,
                "model": "ln f = a + b ln(A/g) [+ c S]",
                "regressors": regressors,
                "coefficients": b.fit.coefficients,
                "residual_std": b.fit.residual_std,
                "dof": b.fit.dof,
                "confidence": settings.band.confidence,
                "t_quantile": b.t_quantile,
                "xtx_inverse": b.fit.xtx_inverse,
                "step": b.step.map(|s| serde_json::json!({
                    "event": a.history.events[m.track.members[s.from].event].event,
                    "relative_change": s.relative_change,
                    "f_statistic": s.f_statistic,
                    "p_value": s.p_value,
                })),
                "fitted_events": b.fitted.iter().map(|&k| a.history.events[m.track.members[k].event].event.clone()).collect::<Vec<_>>(),
            }));
        }
    }
    serde_json::Value::Array(list)
}

/// The `--json` summary of one structure.
pub fn summary(a: &Analysed) -> StructureSummary {
    let name = a
        .sources
        .iter()
        .rev()
        .find_map(|s| s.structure_name.clone());
    StructureSummary {
        structure: a.structure.clone(),
        name,
        events: a.history.events.len(),
        modes: a
            .history
            .modes
            .iter()
            .map(|m| {
                let mut f: Vec<f64> = (0..m.track.members.len())
                    .map(|k| a.history.member_mode(m.id - 1, k).frequency_hz)
                    .collect();
                let step = step_of(a, m);
                ModeSummary {
                    mode: m.id,
                    direction: m.track.direction.clone(),
                    events: m.track.members.len(),
                    median_frequency_hz: crate::stats::median_in_place(&mut f),
                    slope: m.assessment.band.as_ref().map(|b| b.fit.coefficients[1]),
                    fitted_events: m.assessment.band.as_ref().map_or(0, |b| b.fitted.len()),
                    flagged: m
                        .track
                        .members
                        .iter()
                        .zip(&m.assessment.verdicts)
                        .filter(|(_, v)| v.status.flagged() || v.status == Status::NoIntensity)
                        .map(|(x, v)| {
                            format!("{}: {}", a.history.events[x.event].event, v.status.name())
                        })
                        .collect(),
                    step_event: step.as_ref().map(|s| s.0.clone()),
                    step_percent: step.as_ref().map(|s| s.2),
                    note: m.assessment.note.clone(),
                }
            })
            .collect(),
    }
}
