//! The change test of the `modal` stage (docs/statistics.md "Change
//! test"): every run leaves `change_reference/change_reference.parquet` (the normalised
//! output covariances of its record, per block), and a run with
//! `reference_modes` tests its record against the reference run's and
//! writes `change_test/change_test.parquet`.
//!
//! Storing the covariances, not the null space S and Σ, keeps a run
//! usable as a reference whatever the order chosen later, and a reference
//! of several runs possible (S of their union).  The order is twice the
//! reference run's modes.  The covariances are of the conditioned output
//! records, at lags that are multiples of the identification's decimation
//! factor (the rate it found enough for the band of interest).

use std::path::Path;

use crate::error::Result;
use crate::modal::change_test::{
    covariance_blocks, max_lag_for, reference_from, ChangeTestResult, CovarianceBlocks,
    HankelShape, DEFAULT_MAX_ORDER, MAX_CHANNELS,
};
use crate::modal::ModalResult;
use crate::sinks::change_tables;
use crate::sinks::provenance::Provenance;
use crate::vocab::Event;

pub const REFERENCE_FILE: &str = crate::vocab::tables::CHANGE_REFERENCE.file;
pub const TEST_FILE: &str = crate::vocab::tables::CHANGE_TEST.file;

/// Most blocks of a record, and the least a reference needs (C4).
const MAX_BLOCKS: usize = 60;
const MIN_BLOCKS: usize = 5;

/// The covariances of `event`'s output records of `result`, or why not.
pub fn record_covariances(
    event: &Event,
    result: &ModalResult,
) -> std::result::Result<CovarianceBlocks, String> {
    let l = result.output_ids.len();
    if !(2..=MAX_CHANNELS).contains(&l) {
        return Err(format!(
            "{l} output channels: the change test takes 2 to {}",
            MAX_CHANNELS
        ));
    }
    let mut signals = Vec::with_capacity(l);
    for id in &result.output_ids {
        let r = event
            .records
            .iter()
            .find(|r| &r.channel.id == id)
            .ok_or_else(|| format!("output channel {id} not among the records"))?;
        signals.push(r.samples.get().map_err(|e| e.to_string())?.into_owned());
    }
    let max_lag = max_lag_for(DEFAULT_MAX_ORDER, l);
    let step = result.decimation.max(1);
    let n = signals.iter().map(|s| s.len()).min().unwrap_or(0);
    let blocks = (n / (50 * (max_lag * step + 1))).min(MAX_BLOCKS);
    if blocks < MIN_BLOCKS {
        return Err(format!(
            "{n} samples: too short for {MIN_BLOCKS} blocks of {} samples",
            50 * (max_lag * step + 1)
        ));
    }
    let views: Vec<&[f64]> = signals.iter().map(|s| s.as_slice()).collect();
    covariance_blocks(&views, max_lag, step, blocks).map_err(|e| e.to_string())
}

/// Writes `change_reference/change_reference.parquet` of this run and, with a reference
/// run (its `modes/modes.parquet` at `reference_modes`, `reference_mode_count`
/// modes), `change_test/change_test.parquet`; a test that cannot be made is a warning
/// and a table without rows.
pub fn write(
    event: &Event,
    result: &ModalResult,
    reference: Option<(&Path, usize)>,
    false_alarm_rate: f64,
    out: &Path,
    provenance: &Provenance,
) -> Result<Option<ChangeTestResult>> {
    let own = record_covariances(event, result);
    change_tables::write_change_reference(
        &out.join(REFERENCE_FILE),
        own.as_ref().ok(),
        &result.output_ids,
        own.as_ref().err().map(String::as_str),
        provenance,
    )?;
    let Some((modes_file, modes)) = reference else {
        return Ok(None);
    };
    let reference_file = crate::vocab::tables::CHANGE_REFERENCE
        .locate(&crate::vocab::schema::run_dir_of(modes_file));
    let tested = test_against(
        &own,
        &result.output_ids,
        &reference_file,
        modes,
        false_alarm_rate,
    );
    if let Err(why) = &tested {
        crate::console::warn(format!("modal ({}): no change test: {why}", event.name));
    }
    change_tables::write_change_test(
        &out.join(TEST_FILE),
        tested.as_ref().ok(),
        &result.output_ids,
        &reference_file,
        tested.as_ref().err().map(String::as_str),
        record_rate_hz(event, result),
        provenance,
    )?;
    Ok(tested.ok())
}

/// Sampling rate of the records the covariances were computed from (the
/// first output channel's), Hz; NaN when not found.
fn record_rate_hz(event: &Event, result: &ModalResult) -> f64 {
    result
        .output_ids
        .first()
        .and_then(|id| event.records.iter().find(|r| &r.channel.id == id))
        .map_or(f64::NAN, |r| r.channel.sampling_rate_hz)
}

fn test_against(
    own: &std::result::Result<CovarianceBlocks, String>,
    channels: &[String],
    reference_file: &Path,
    modes: usize,
    false_alarm_rate: f64,
) -> std::result::Result<ChangeTestResult, String> {
    let own = own
        .as_ref()
        .map_err(|e| format!("this run's record: {e}"))?;
    if !reference_file.exists() {
        return Err(format!(
            "{} missing (a run made before the change test, or of more than 16 channels)",
            reference_file.display()
        ));
    }
    let (blocks, ref_channels) = change_tables::read_change_reference(reference_file)
        .map_err(|e| e.to_string())?
        .ok_or_else(|| format!("{} holds no block", reference_file.display()))?;
    if ref_channels != channels {
        return Err(format!(
            "the reference's output channels {ref_channels:?} differ from this run's {channels:?}"
        ));
    }
    let shape = HankelShape::for_order((2 * modes).clamp(2, DEFAULT_MAX_ORDER), channels.len());
    // One lag step for both records: their decimations may differ.
    let (a, b) = (blocks.lag_step, own.lag_step);
    let step = a / crate::conditioning::resample::gcd(a, b).max(1) * b;
    let (blocks, own) = match (blocks.at_lag_step(step), own.at_lag_step(step)) {
        (Some(r), Some(o)) if r.max_lag >= shape.max_lag() && o.max_lag >= shape.max_lag() => {
            (r, o)
        }
        _ => {
            return Err(format!(
                "the reference's lags are every {a} samples, this record's every {b}: at their common step of {step} samples fewer than the {} lags the test needs are left",
                shape.max_lag()
            ))
        }
    };
    let reference = reference_from(&[blocks], shape).map_err(|e| e.to_string())?;
    reference
        .test(&own, false_alarm_rate)
        .map_err(|e| e.to_string())
}
