//! Parquet tables of the lab identification (docs/lab-tests.md,
//! docs/formats.md): `lab_identification/lab_identification.parquet`, `lab_fit/lab_fit.parquet`,
//! `lab_cycles/lab_cycles.parquet`.

use std::path::Path;

use super::parquet::{write_parquet, TableBuilder};
use crate::error::Result;
use crate::lab::instantaneous::InstantaneousFit;
use crate::lab::{LabIdentifySettings, ParameterEstimate, SpecimenIdentification};
use crate::vocab::tables::{
    lab_cycles, lab_fit, lab_identification, LAB_CYCLES, LAB_FIT, LAB_IDENTIFICATION,
};

/// One identified record: its name, history and identification.
pub struct LabOutcome<'a> {
    pub record: &'a str,
    pub displacement_m: &'a [f64],
    pub force_n: &'a [f64],
    pub time_s: Option<&'a [f64]>,
    pub identification: &'a SpecimenIdentification,
    /// The thesis's time–frequency identification (`stft_instantaneous`
    /// rows): None when not run (no uniform time base, or switched off),
    /// `Err(reason)` when it identified nothing.
    pub instantaneous: Option<std::result::Result<&'a InstantaneousFit, &'a str>>,
}

/// One row of `lab_identification/lab_identification.parquet`: a parameter and its record's
/// figures, whichever method produced them.
struct IdRow<'a> {
    record: &'a str,
    method: &'static str,
    form: &'a str,
    estimate: ParameterEstimate,
    force_nrmse: f64,
    plain_nrmse: f64,
    energy_mean: Option<f64>,
    cycles: u32,
    f_statistic: Option<f64>,
    p_value: Option<f64>,
    effective_samples: Option<u32>,
    reason: &'a str,
    yield_force_n: f64,
    ductility: f64,
    hysteretic_energy_j: f64,
    park_ang: Option<f64>,
    stiffness_index: f64,
    samples: u32,
    samples_fitted: u32,
    quasi_static: bool,
}

fn mean_abs(e: &[f64]) -> Option<f64> {
    (!e.is_empty()).then(|| e.iter().map(|v| v.abs()).sum::<f64>() / e.len() as f64)
}

fn id_rows<'a>(o: &'a LabOutcome<'a>) -> Vec<IdRow<'a>> {
    let id = o.identification;
    let mut rows: Vec<IdRow<'a>> = id
        .estimates
        .iter()
        .map(|e| IdRow {
            record: o.record,
            method: "whole_history",
            form: id.form.name(),
            estimate: e.clone(),
            force_nrmse: id.force_nrmse,
            plain_nrmse: id.plain_nrmse,
            energy_mean: mean_abs(&id.energy_error_per_cycle),
            cycles: id.cycles.len() as u32,
            f_statistic: id.form_test.as_ref().map(|t| t.f_statistic),
            p_value: id.form_test.as_ref().map(|t| t.p_value),
            effective_samples: id.form_test.as_ref().map(|t| t.effective_samples as u32),
            reason: &id.form_reason,
            yield_force_n: id.damage.yield_force_n,
            ductility: id.damage.ductility,
            hysteretic_energy_j: id.damage.hysteretic_energy_j,
            park_ang: id.damage.park_ang,
            stiffness_index: id.damage.stiffness_index,
            samples: id.samples as u32,
            samples_fitted: id.samples_fitted as u32,
            quasi_static: id.quasi_static,
        })
        .collect();
    let stft_row = |estimate: ParameterEstimate, form: &'a str, reason: &'a str| IdRow {
        record: o.record,
        method: "stft_instantaneous",
        form,
        estimate,
        force_nrmse: f64::NAN,
        plain_nrmse: f64::NAN,
        energy_mean: None,
        cycles: 0,
        f_statistic: None,
        p_value: None,
        effective_samples: None,
        reason,
        yield_force_n: f64::NAN,
        ductility: f64::NAN,
        hysteretic_energy_j: id.damage.hysteretic_energy_j,
        park_ang: None,
        stiffness_index: f64::NAN,
        samples: id.samples as u32,
        samples_fitted: id.samples as u32,
        quasi_static: false,
    };
    match o.instantaneous {
        Some(Ok(fit)) => {
            let peak = o.displacement_m.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let k0 = fit.estimates[0].value;
            for e in &fit.estimates {
                rows.push(IdRow {
                    force_nrmse: fit.force_nrmse,
                    plain_nrmse: fit.force_nrmse,
                    energy_mean: mean_abs(&fit.energy_error_per_cycle),
                    cycles: fit.cycles.len() as u32,
                    f_statistic: Some(fit.f_statistic),
                    p_value: Some(fit.p_value),
                    effective_samples: Some(fit.effective_samples as u32),
                    yield_force_n: fit.saturation_force_n,
                    ductility: peak * k0 / fit.saturation_force_n,
                    stiffness_index: fit.damage_index_end,
                    ..stft_row(e.clone(), "thesis_bouc_wen", &fit.verdict)
                });
            }
        }
        Some(Err(reason)) => rows.push(stft_row(
            ParameterEstimate {
                name: "none",
                value: f64::NAN,
                std: f64::NAN,
                units: "",
                fixed: true,
            },
            "not_identified",
            reason,
        )),
        None => {}
    }
    rows
}

fn settings_meta(settings: &LabIdentifySettings) -> Vec<(String, String)> {
    vec![("quaketwin.lab_settings".into(), format!("{settings:?}"))]
}

/// Which lab test the tables come from and by which steps (the contract every table made
/// from an event keeps: `quaketwin.event` and `quaketwin.history`, docs/formats.md):
/// the records were converted to SI by the lab readers, then identified with `settings`.
pub fn lab_provenance(
    event_source: &str,
    records: &[&str],
    settings: &LabIdentifySettings,
) -> Vec<(String, String)> {
    let name = records.first().copied().unwrap_or(event_source);
    let event = serde_json::json!({
        "name": name,
        "source": event_source,
        "kind": "lab test",
        "records": records,
    });
    let history = serde_json::json!({
        "steps": [
            {"step": "units_to_si", "note": "lab channels converted to SI from their stated or inferred units"},
            {"step": "lab_identification", "settings": format!("{settings:?}")},
        ]
    });
    vec![
        (super::provenance::EVENT_KEY.to_string(), event.to_string()),
        (
            super::provenance::HISTORY_KEY.to_string(),
            history.to_string(),
        ),
    ]
}

/// `lab_identification/lab_identification.parquet`.
pub fn write_lab_identification(
    path: &Path,
    outcomes: &[LabOutcome<'_>],
    settings: &LabIdentifySettings,
    provenance: &[(String, String)],
) -> Result<()> {
    use lab_identification as c;
    let rows: Vec<IdRow<'_>> = outcomes.iter().flat_map(id_rows).collect();
    let batch = TableBuilder::new(&LAB_IDENTIFICATION)
        .str(
            c::RECORD,
            &rows.iter().map(|r| r.record).collect::<Vec<_>>(),
        )
        .str(
            c::METHOD,
            &rows.iter().map(|r| r.method).collect::<Vec<_>>(),
        )
        .str(c::FORM, &rows.iter().map(|r| r.form).collect::<Vec<_>>())
        .str(
            c::PARAMETER,
            &rows.iter().map(|r| r.estimate.name).collect::<Vec<_>>(),
        )
        .f64(c::VALUE, rows.iter().map(|r| r.estimate.value).collect())
        .f64(c::STD, rows.iter().map(|r| r.estimate.std).collect())
        .str(
            c::UNIT,
            &rows.iter().map(|r| r.estimate.units).collect::<Vec<_>>(),
        )
        .bool(c::FIXED, rows.iter().map(|r| r.estimate.fixed).collect())
        .f64(c::FORCE_NRMSE, rows.iter().map(|r| r.force_nrmse).collect())
        .f64(c::PLAIN_NRMSE, rows.iter().map(|r| r.plain_nrmse).collect())
        .opt_f64(
            c::ENERGY_ERROR_MEAN,
            rows.iter().map(|r| r.energy_mean).collect(),
        )
        .u32(c::CYCLES, rows.iter().map(|r| r.cycles).collect())
        .opt_f64(c::F_STATISTIC, rows.iter().map(|r| r.f_statistic).collect())
        .opt_f64(c::P_VALUE, rows.iter().map(|r| r.p_value).collect())
        .opt_u32(
            c::EFFECTIVE_SAMPLES,
            rows.iter().map(|r| r.effective_samples).collect(),
        )
        .str(
            c::FORM_REASON,
            &rows.iter().map(|r| r.reason).collect::<Vec<_>>(),
        )
        .f64(
            c::YIELD_FORCE_N,
            rows.iter().map(|r| r.yield_force_n).collect(),
        )
        .f64(c::DUCTILITY, rows.iter().map(|r| r.ductility).collect())
        .f64(
            c::HYSTERETIC_ENERGY_J,
            rows.iter().map(|r| r.hysteretic_energy_j).collect(),
        )
        .opt_f64(c::PARK_ANG, rows.iter().map(|r| r.park_ang).collect())
        .f64(
            c::STIFFNESS_INDEX,
            rows.iter().map(|r| r.stiffness_index).collect(),
        )
        .u32(c::SAMPLES, rows.iter().map(|r| r.samples).collect())
        .u32(
            c::SAMPLES_FITTED,
            rows.iter().map(|r| r.samples_fitted).collect(),
        )
        .bool(
            c::QUASI_STATIC,
            rows.iter().map(|r| r.quasi_static).collect(),
        )
        .build()?;
    let mut meta = settings_meta(settings);
    meta.extend_from_slice(provenance);
    write_parquet(path, &[batch], &meta)
}

/// `lab_fit/lab_fit.parquet`.
pub fn write_lab_fit(
    path: &Path,
    outcomes: &[LabOutcome<'_>],
    provenance: &[(String, String)],
) -> Result<()> {
    use lab_fit as c;
    let mut record = Vec::new();
    let mut fi = Vec::new();
    let (mut step, mut t, mut x, mut fm, mut ff, mut fp) = (
        Vec::new(),
        Vec::new(),
        Vec::new(),
        Vec::new(),
        Vec::new(),
        Vec::new(),
    );
    for o in outcomes {
        for i in 0..o.displacement_m.len() {
            record.push(o.record);
            step.push(i as u32);
            t.push(o.time_s.map(|t| t[i]));
            x.push(o.displacement_m[i]);
            fm.push(o.force_n[i]);
            ff.push(o.identification.fitted_force_n[i]);
            fp.push(o.identification.plain_force_n[i]);
            fi.push(match o.instantaneous {
                Some(Ok(fit)) => fit.fitted_force_n.get(i).copied(),
                _ => None,
            });
        }
    }
    let batch = TableBuilder::new(&LAB_FIT)
        .str(c::RECORD, &record)
        .u32(c::STEP, step)
        .opt_f64(c::T_S, t)
        .f64(c::DISPLACEMENT_M, x)
        .f64(c::FORCE_MEASURED_N, fm)
        .f64(c::FORCE_FITTED_N, ff)
        .f64(c::FORCE_PLAIN_N, fp)
        .opt_f64(c::FORCE_INSTANTANEOUS_N, fi)
        .build()?;
    write_parquet(path, &[batch], provenance)
}

/// `lab_cycles/lab_cycles.parquet`.
pub fn write_lab_cycles(
    path: &Path,
    outcomes: &[LabOutcome<'_>],
    provenance: &[(String, String)],
) -> Result<()> {
    use lab_cycles as c;
    // The instantaneous fit's cycles are the same (same displacement, same
    // band); its energy is matched by the cycle's start sample.
    let rows: Vec<(&str, usize, &crate::lab::CycleEnergy, Option<f64>)> = outcomes
        .iter()
        .flat_map(|o| {
            o.identification
                .cycles
                .iter()
                .enumerate()
                .map(move |(k, cy)| {
                    let other = match o.instantaneous {
                        Some(Ok(fit)) => fit
                            .cycles
                            .iter()
                            .find(|c| c.start == cy.start && c.end == cy.end)
                            .map(|c| c.fitted_j),
                        _ => None,
                    };
                    (o.record, k, cy, other)
                })
        })
        .collect();
    let batch = TableBuilder::new(&LAB_CYCLES)
        .str(c::RECORD, &rows.iter().map(|r| r.0).collect::<Vec<_>>())
        .u32(c::CYCLE, rows.iter().map(|r| r.1 as u32 + 1).collect())
        .u32(
            c::START_STEP,
            rows.iter().map(|r| r.2.start as u32).collect(),
        )
        .u32(c::END_STEP, rows.iter().map(|r| r.2.end as u32).collect())
        .f64(
            c::AMPLITUDE_M,
            rows.iter().map(|r| r.2.amplitude_m).collect(),
        )
        .f64(
            c::ENERGY_MEASURED_J,
            rows.iter().map(|r| r.2.measured_j).collect(),
        )
        .f64(
            c::ENERGY_FITTED_J,
            rows.iter().map(|r| r.2.fitted_j).collect(),
        )
        .f64(
            c::ENERGY_ERROR,
            rows.iter().map(|r| r.2.relative_error()).collect(),
        )
        .opt_f64(
            c::ENERGY_INSTANTANEOUS_J,
            rows.iter().map(|r| r.3).collect(),
        )
        .build()?;
    write_parquet(path, &[batch], provenance)
}
