//! Parquet tables of the lab identification (docs/lab-tests.md,
//! docs/formats.md): `lab_identification/lab_identification.parquet`, `lab_fit/lab_fit.parquet`,
//! `lab_cycles/lab_cycles.parquet`.

use std::path::Path;

use super::parquet::{write_parquet, TableBuilder};
use crate::error::Result;
use crate::lab::{LabIdentifySettings, SpecimenIdentification};
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
    let mut rows: Vec<(&LabOutcome<'_>, &crate::lab::ParameterEstimate)> = Vec::new();
    for o in outcomes {
        for e in &o.identification.estimates {
            rows.push((o, e));
        }
    }
    let per = |f: &dyn Fn(&SpecimenIdentification) -> f64| -> Vec<f64> {
        rows.iter().map(|(o, _)| f(o.identification)).collect()
    };
    let per_opt = |f: &dyn Fn(&SpecimenIdentification) -> Option<f64>| -> Vec<Option<f64>> {
        rows.iter().map(|(o, _)| f(o.identification)).collect()
    };
    let energy_mean = |id: &SpecimenIdentification| -> Option<f64> {
        let e = &id.energy_error_per_cycle;
        (!e.is_empty()).then(|| e.iter().map(|v| v.abs()).sum::<f64>() / e.len() as f64)
    };
    let batch = TableBuilder::new(&LAB_IDENTIFICATION)
        .str(
            c::RECORD,
            &rows.iter().map(|(o, _)| o.record).collect::<Vec<_>>(),
        )
        .str(
            c::FORM,
            &rows
                .iter()
                .map(|(o, _)| o.identification.form.name())
                .collect::<Vec<_>>(),
        )
        .str(
            c::PARAMETER,
            &rows.iter().map(|(_, e)| e.name).collect::<Vec<_>>(),
        )
        .f64(c::VALUE, rows.iter().map(|(_, e)| e.value).collect())
        .f64(c::STD, rows.iter().map(|(_, e)| e.std).collect())
        .str(
            c::UNIT,
            &rows.iter().map(|(_, e)| e.units).collect::<Vec<_>>(),
        )
        .bool(c::FIXED, rows.iter().map(|(_, e)| e.fixed).collect())
        .f64(c::FORCE_NRMSE, per(&|i| i.force_nrmse))
        .f64(c::PLAIN_NRMSE, per(&|i| i.plain_nrmse))
        .opt_f64(c::ENERGY_ERROR_MEAN, per_opt(&energy_mean))
        .u32(
            c::CYCLES,
            rows.iter()
                .map(|(o, _)| o.identification.cycles.len() as u32)
                .collect(),
        )
        .opt_f64(
            c::F_STATISTIC,
            per_opt(&|i| i.form_test.as_ref().map(|t| t.f_statistic)),
        )
        .opt_f64(
            c::P_VALUE,
            per_opt(&|i| i.form_test.as_ref().map(|t| t.p_value)),
        )
        .opt_u32(
            c::EFFECTIVE_SAMPLES,
            rows.iter()
                .map(|(o, _)| {
                    o.identification
                        .form_test
                        .as_ref()
                        .map(|t| t.effective_samples as u32)
                })
                .collect(),
        )
        .str(
            c::FORM_REASON,
            &rows
                .iter()
                .map(|(o, _)| o.identification.form_reason.as_str())
                .collect::<Vec<_>>(),
        )
        .f64(c::YIELD_FORCE_N, per(&|i| i.damage.yield_force_n))
        .f64(c::DUCTILITY, per(&|i| i.damage.ductility))
        .f64(
            c::HYSTERETIC_ENERGY_J,
            per(&|i| i.damage.hysteretic_energy_j),
        )
        .opt_f64(c::PARK_ANG, per_opt(&|i| i.damage.park_ang))
        .f64(c::STIFFNESS_INDEX, per(&|i| i.damage.stiffness_index))
        .u32(
            c::SAMPLES,
            rows.iter()
                .map(|(o, _)| o.identification.samples as u32)
                .collect(),
        )
        .u32(
            c::SAMPLES_FITTED,
            rows.iter()
                .map(|(o, _)| o.identification.samples_fitted as u32)
                .collect(),
        )
        .bool(
            c::QUASI_STATIC,
            rows.iter()
                .map(|(o, _)| o.identification.quasi_static)
                .collect(),
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
    let rows: Vec<(&str, usize, &crate::lab::CycleEnergy)> = outcomes
        .iter()
        .flat_map(|o| {
            o.identification
                .cycles
                .iter()
                .enumerate()
                .map(move |(k, cy)| (o.record, k, cy))
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
        .build()?;
    write_parquet(path, &[batch], provenance)
}
