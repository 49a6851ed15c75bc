//! `change_reference/change_reference.parquet` (what a run leaves for a later run's change
//! test) and `change_test/change_test.parquet` (the test of a run against a reference
//! run): docs/statistics.md "Change test", docs/formats.md.

use std::path::Path;

use super::modal_tables::OUTPUT_CHANNELS_KEY;
use super::parquet::{write_parquet, TableBuilder};
use super::provenance::Provenance;
use crate::assessment::change_test::ChangeTestEvidence;
use crate::error::{Error, Result};
use crate::modal::change_test::{ChangeTestResult, CovarianceBlocks};
use crate::vocab::tables::{
    change_reference as cr, change_test as ct, CHANGE_REFERENCE, CHANGE_TEST,
};

/// Metadata key of the number of lags kept.
pub const MAX_LAG_KEY: &str = "quaketwin.max_lag";
/// Metadata key of the samples between lags.
pub const LAG_STEP_KEY: &str = "quaketwin.lag_step";

/// Writes the blocks of `c` (none when `c` is `None`: too many channels or
/// too short a record, said in `note`).
pub fn write_change_reference(
    path: &Path,
    c: Option<&CovarianceBlocks>,
    channels: &[String],
    note: Option<&str>,
    provenance: &Provenance,
) -> Result<()> {
    let (samples, blocks, powers): (Vec<u32>, Vec<Vec<f64>>, Vec<Option<f64>>) = match c {
        Some(c) => (
            c.block_samples.iter().map(|&n| n as u32).collect(),
            c.blocks.clone(),
            c.powers().into_iter().map(Some).collect(),
        ),
        None => (Vec::new(), Vec::new(), Vec::new()),
    };
    let batch = TableBuilder::new(&CHANGE_REFERENCE)
        .u32(cr::BLOCK.name, (0..blocks.len() as u32).collect())
        .u32(cr::BLOCK_SAMPLES.name, samples)
        .opt_f64(cr::BLOCK_POWER.name, powers)
        .list_f64(cr::COVARIANCES.name, &blocks)
        .build()?;
    let mut metadata = provenance.metadata();
    metadata.push((
        OUTPUT_CHANNELS_KEY.into(),
        serde_json::to_string(channels).unwrap_or_default(),
    ));
    metadata.push((MAX_LAG_KEY.into(), c.map_or(0, |c| c.max_lag).to_string()));
    metadata.push((LAG_STEP_KEY.into(), c.map_or(1, |c| c.lag_step).to_string()));
    if let Some(n) = note {
        metadata.push(("quaketwin.note".into(), n.to_string()));
    }
    write_parquet(path, &[batch], &metadata)
}

/// The blocks of a `change_reference/change_reference.parquet` and its channel ids; `None`
/// when the file holds no block.
pub fn read_change_reference(path: &Path) -> Result<Option<(CovarianceBlocks, Vec<String>)>> {
    use arrow_array::{Array, Float64Array, ListArray, UInt32Array};
    let table = super::parquet::ReadTable::open(path)?;
    let loc = || table.location();
    let channels: Vec<String> = table
        .metadata(OUTPUT_CHANNELS_KEY)
        .and_then(|v| serde_json::from_str(v).ok())
        .ok_or_else(|| Error::input(loc(), format!("metadata {OUTPUT_CHANNELS_KEY} missing")))?;
    let max_lag: usize = table
        .metadata(MAX_LAG_KEY)
        .and_then(|v| v.parse().ok())
        .ok_or_else(|| Error::input(loc(), format!("metadata {MAX_LAG_KEY} missing")))?;
    let lag_step: usize = table
        .metadata(LAG_STEP_KEY)
        .and_then(|v| v.parse().ok())
        .filter(|&s| s >= 1)
        .ok_or_else(|| Error::input(loc(), format!("metadata {LAG_STEP_KEY} missing")))?;
    let l = channels.len();
    let mut block_samples = Vec::new();
    let mut block_power = Vec::new();
    let mut blocks = Vec::new();
    for b in &table.batches {
        let n = table.declared::<UInt32Array>(b, &cr::BLOCK_SAMPLES)?;
        // Absent from tables written before it was kept: read as 1 (C4').
        let power = match b.schema().index_of(cr::BLOCK_POWER.name) {
            Ok(_) => Some(table.declared::<Float64Array>(b, &cr::BLOCK_POWER)?),
            Err(_) => None,
        };
        let lists = table.declared::<ListArray>(b, &cr::COVARIANCES)?;
        for i in 0..b.num_rows() {
            let values = lists.value(i);
            let values = values
                .as_any()
                .downcast_ref::<Float64Array>()
                .ok_or_else(|| Error::input(loc(), "covariances: not float64"))?;
            let v: Vec<f64> = values.values().to_vec();
            if v.len() != max_lag * l * l || v.iter().any(|x| !x.is_finite()) {
                return Err(Error::input(
                    loc(),
                    format!(
                        "covariances of block {i}: {} values, expected {} finite ones ({l} channels, lags 1–{max_lag})",
                        v.len(),
                        max_lag * l * l
                    ),
                ));
            }
            let p = power
                .as_ref()
                .and_then(|p| (!p.is_null(i)).then(|| p.value(i)))
                .unwrap_or(1.0);
            if !(p.is_finite() && p >= 0.0) {
                return Err(Error::input(
                    loc(),
                    format!("block_power of block {i}: {p} is not a finite non-negative number"),
                ));
            }
            block_samples.push(n.value(i) as usize);
            block_power.push(p);
            blocks.push(v);
        }
    }
    if blocks.is_empty() {
        return Ok(None);
    }
    let samples: usize = block_samples.iter().sum();
    let mut mean = vec![0.0; max_lag * l * l];
    for (b, &n) in blocks.iter().zip(&block_samples) {
        for (acc, v) in mean.iter_mut().zip(b) {
            *acc += v * n as f64 / samples.max(1) as f64;
        }
    }
    Ok(Some((
        CovarianceBlocks {
            channels: l,
            max_lag,
            lag_step,
            samples,
            mean,
            block_samples,
            block_power,
            blocks,
        },
        channels,
    )))
}

/// Writes the test of a run against `reference` (one row per channel; no
/// row when no test could be made, and why in `note`).
pub fn write_change_test(
    path: &Path,
    t: Option<&ChangeTestResult>,
    channels: &[String],
    reference: &Path,
    note: Option<&str>,
    rate_hz: f64,
    provenance: &Provenance,
) -> Result<()> {
    let empty = ChangeTestResult {
        statistic: 0.0,
        threshold: 0.0,
        p_value: 1.0,
        dof: 0,
        covariance_dof: 0,
        false_alarm_rate: 0.0,
        changed: false,
        channel_contributions: Vec::new(),
        mode_contributions: Vec::new(),
        unexplained_contribution: 0.0,
    };
    let (t, channels) = match t {
        Some(t) => (t, channels),
        None => (&empty, &[][..]),
    };
    let n = channels.len();
    let batch = TableBuilder::new(&CHANGE_TEST)
        .str(ct::CHANNEL.name, channels)
        .f64(ct::CONTRIBUTION.name, t.channel_contributions.clone())
        .f64(ct::STATISTIC.name, vec![t.statistic; n])
        .f64(ct::THRESHOLD.name, vec![t.threshold; n])
        .f64(ct::P_VALUE.name, vec![t.p_value; n])
        .i32(ct::DOF.name, vec![t.dof as i32; n])
        .i32(ct::COVARIANCE_DOF.name, vec![t.covariance_dof as i32; n])
        .f64(ct::FALSE_ALARM_RATE.name, vec![t.false_alarm_rate; n])
        .bool(ct::CHANGED.name, vec![t.changed; n])
        .build()?;
    let mut metadata = provenance.metadata();
    metadata.push((
        "quaketwin.reference".into(),
        reference.display().to_string(),
    ));
    if let Some(n) = note {
        metadata.push(("quaketwin.note".into(), n.to_string()));
    }
    if n > 0 {
        // Eq. C8: each reference mode's share of the statistic.
        let modes: Vec<serde_json::Value> = t
            .mode_contributions
            .iter()
            .map(|m| {
                serde_json::json!({
                    "frequency_hz": m.frequency_per_sample * rate_hz,
                    "damping_ratio": m.damping_ratio,
                    "contribution": m.contribution,
                })
            })
            .collect();
        metadata.push((
            "quaketwin.mode_contributions".into(),
            serde_json::json!({"modes": modes, "unexplained": t.unexplained_contribution})
                .to_string(),
        ));
    }
    write_parquet(path, &[batch], &metadata)
}

/// The test a run's `change_test/change_test.parquet` holds, as the
/// assessment's evidence (`crate::assessment::change_test`): `None` when
/// the file is absent (the run had no reference); a table without rows
/// (no test could be made) gives its note as the reason.
pub fn read_change_test_evidence(dir: &Path) -> Result<Option<ChangeTestEvidence>> {
    use arrow_array::{Array, BooleanArray, Float64Array};
    let path = CHANGE_TEST.locate(dir);
    if !path.is_file() {
        return Ok(None);
    }
    let table = super::parquet::ReadTable::open(&path)?;
    let Some(b) = table.batches.iter().find(|b| b.num_rows() > 0) else {
        let reason = table
            .metadata("quaketwin.note")
            .unwrap_or("the change test table holds no row")
            .to_string();
        return Ok(Some(ChangeTestEvidence::NotTested { reason }));
    };
    let number = |spec| -> Result<f64> { Ok(table.declared::<Float64Array>(b, spec)?.value(0)) };
    let changed = table.declared::<BooleanArray>(b, &ct::CHANGED)?;
    // Eq. C8's shares, as write_change_test stores them.
    let leading_mode = table
        .metadata("quaketwin.mode_contributions")
        .and_then(|v| serde_json::from_str::<serde_json::Value>(v).ok())
        .and_then(|v| {
            v["modes"]
                .as_array()?
                .iter()
                .filter_map(|m| Some((m["frequency_hz"].as_f64()?, m["contribution"].as_f64()?)))
                .max_by(|a, b| a.1.total_cmp(&b.1))
        });
    Ok(Some(ChangeTestEvidence::Tested {
        statistic: number(&ct::STATISTIC)?,
        threshold: number(&ct::THRESHOLD)?,
        p_value: number(&ct::P_VALUE)?,
        false_alarm_rate: number(&ct::FALSE_ALARM_RATE)?,
        changed: !changed.is_null(0) && changed.value(0),
        leading_mode,
    }))
}
