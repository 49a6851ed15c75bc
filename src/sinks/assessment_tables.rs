//! The assessment's Parquet tables (schemas in docs/formats.md):
//! `assessment/assessment.parquet` (one row per event: colour, priority, damage-state
//! probabilities, each indicator's value and verdict, the assumptions) and
//! `frequency_track/frequency_track.parquet` (the apparent frequency per moving window and
//! direction).

use std::path::Path;

use super::parquet::{write_parquet, TableBuilder};
use crate::assessment::change_test::ChangeTestEvidence;
use crate::assessment::frequency::TrackRows;
use crate::assessment::{Assessment, IndicatorKind};
use crate::error::Result;
use crate::vocab::tables::{assessment as a, frequency_track as f, ASSESSMENT, FREQUENCY_TRACK};
use crate::vocab::Event;

/// `frequency_track/frequency_track.parquet`.
pub fn write_frequency_track(path: &Path, event: &Event, tracks: &[TrackRows]) -> Result<()> {
    let mut direction = Vec::new();
    let mut output = Vec::new();
    let mut input: Vec<Option<String>> = Vec::new();
    let mut method = Vec::new();
    let mut window = Vec::new();
    let mut time = Vec::new();
    let mut freq = Vec::new();
    let mut damping = Vec::new();
    let mut rms = Vec::new();
    let mut phase = Vec::new();
    let mut truth: Vec<Option<f64>> = Vec::new();
    for t in tracks {
        let half = 0.5 * t.track.window_s;
        for (i, p) in t.track.points.iter().enumerate() {
            truth.push(t.truth_hz.get(i).copied().flatten());
            direction.push(t.direction.clone());
            output.push(t.output_channel.clone());
            input.push(t.input_channel.clone());
            method.push(t.track.method.to_string());
            window.push(t.track.window_s);
            time.push(p.time_s);
            freq.push(p.frequency_hz.is_finite().then_some(p.frequency_hz));
            damping.push(p.damping_ratio.is_finite().then_some(p.damping_ratio));
            rms.push(p.output_rms);
            phase.push(if p.time_s + half <= t.strong_start_s {
                "pre"
            } else if p.time_s - half >= t.strong_end_s {
                "post"
            } else {
                "strong"
            });
        }
    }
    let batch = TableBuilder::new(&FREQUENCY_TRACK)
        .str(f::DIRECTION, &direction)
        .str(f::OUTPUT_CHANNEL, &output)
        .opt_str(f::INPUT_CHANNEL, &input)
        .str(f::METHOD, &method)
        .f64(f::WINDOW_S, window)
        .f64(f::TIME_S, time)
        .opt_f64(f::FREQUENCY_HZ, freq)
        .opt_f64(f::DAMPING_RATIO, damping)
        .f64(f::OUTPUT_RMS, rms)
        .str(f::PHASE, &phase)
        .opt_f64(f::TRUE_FREQUENCY_HZ, truth)
        .build()?;
    write_parquet(
        path,
        &[batch],
        &super::provenance::Provenance::of_event(event).metadata(),
    )
}

/// `assessment/assessment.parquet`: one row.
pub fn write_assessment(path: &Path, event: &Event, row: &Assessment) -> Result<()> {
    let o = &row.overall;
    let ind = |k: IndicatorKind| row.indicator(k);
    let value = |k: IndicatorKind| vec![ind(k).and_then(|i| i.value)];
    let state = |k: IndicatorKind| vec![ind(k).and_then(|i| i.state).map(|s| s.name())];
    let verdict = |k: IndicatorKind| vec![ind(k).map(|i| i.verdict.clone()).unwrap_or_default()];
    let p = |i: usize| vec![row.probabilities.map(|p| p[i])];
    let freq = row.frequency.as_ref();
    // The drift indicator's state is the fragility's most likely one.
    let most_likely = ind(IndicatorKind::Drift)
        .and_then(|i| i.state)
        .filter(|_| row.probabilities.is_some())
        .map(|s| s.ems98_grade());
    let change_p_value = match &row.change_test {
        Some(ChangeTestEvidence::Tested { p_value, .. }) => Some(*p_value),
        _ => None,
    };
    let batch = TableBuilder::new(&ASSESSMENT)
        .str(a::EVENT, &[row.event.as_str()])
        .opt_str(a::STRUCTURE, &[row.structure.as_deref()])
        .str(a::STRUCTURE_KIND, &[row.structure_kind.as_str()])
        .str(
            a::RATING,
            &[o.colour.map(|c| c.label()).unwrap_or("NOT RATED")],
        )
        .opt_str(a::PRIORITY, &[o.priority])
        .opt_str(a::DAMAGE_STATE, &[o.state.map(|s| s.name())])
        .str(a::CONFIDENCE, &[o.confidence.as_str()])
        .bool(a::PROVISIONAL, vec![o.provisional])
        .list_str(a::DRIVERS, std::slice::from_ref(&o.drivers))
        .opt_str(a::NOT_RATED_REASON, &[o.reason.as_deref()])
        .opt_str(
            a::BUILDING_TYPE,
            &[row.fragility.as_ref().map(|f| f.building_type)],
        )
        .opt_str(
            a::DESIGN_LEVEL,
            &[row.fragility.as_ref().map(|f| f.design_level.name())],
        )
        .str(
            a::BUILDING_TYPE_SOURCE,
            &[row.building_type_source.as_str()],
        )
        .opt_f64(a::P_NONE, p(0))
        .opt_f64(a::P_SLIGHT, p(1))
        .opt_f64(a::P_MODERATE, p(2))
        .opt_f64(a::P_EXTENSIVE, p(3))
        .opt_f64(a::P_COMPLETE, p(4))
        .opt_str(a::EMS98_GRADE, &[most_likely])
        .opt_f64(a::DRIFT_RATIO, value(IndicatorKind::Drift))
        .opt_str(a::DRIFT_STATE, &state(IndicatorKind::Drift))
        .str(a::DRIFT_VERDICT, &verdict(IndicatorKind::Drift))
        .opt_f64(a::FREQUENCY_BEFORE_HZ, vec![freq.and_then(|e| e.before_hz)])
        .opt_f64(
            a::FREQUENCY_MIN_DURING_HZ,
            vec![freq.and_then(|e| e.min_during_hz)],
        )
        .opt_f64(a::FREQUENCY_AFTER_HZ, vec![freq.and_then(|e| e.after_hz)])
        .opt_f64(
            a::FREQUENCY_DROP_DURING,
            vec![freq.and_then(|e| e.drop_during())],
        )
        .opt_f64(
            a::FREQUENCY_DROP_PERMANENT,
            vec![freq.and_then(|e| e.permanent_drop())],
        )
        .opt_str(a::FREQUENCY_STATE, &state(IndicatorKind::Frequency))
        .str(a::FREQUENCY_VERDICT, &verdict(IndicatorKind::Frequency))
        .opt_f64(a::IOTA_FINAL, value(IndicatorKind::Hysteresis))
        .opt_str(a::HYSTERESIS_STATE, &state(IndicatorKind::Hysteresis))
        .str(a::HYSTERESIS_VERDICT, &verdict(IndicatorKind::Hysteresis))
        .opt_f64(a::RESIDUAL_DRIFT_RATIO, value(IndicatorKind::ResidualDrift))
        .opt_str(a::RESIDUAL_STATE, &state(IndicatorKind::ResidualDrift))
        .str(a::RESIDUAL_VERDICT, &verdict(IndicatorKind::ResidualDrift))
        .opt_f64(a::CHANGE_TEST_RATIO, value(IndicatorKind::ChangeTest))
        .opt_f64(a::CHANGE_TEST_P_VALUE, vec![change_p_value])
        .opt_str(a::CHANGE_TEST_STATE, &state(IndicatorKind::ChangeTest))
        .opt_str(
            a::CHANGE_TEST_VERDICT,
            &[ind(IndicatorKind::ChangeTest).map(|i| i.verdict.as_str())],
        )
        .list_str(a::ASSUMPTIONS, std::slice::from_ref(&row.assumptions))
        .build()?;
    write_parquet(
        path,
        &[batch],
        &super::provenance::Provenance::of_event(event).metadata(),
    )
}
