//! The evidence of the `assess` stage, read from the tables the earlier
//! stages of the run wrote (those the run manifest lists): drift rows,
//! Bouc-Wen outcomes with ι, modes per direction, the change test.

use std::path::Path;

use crate::assessment::change_test::ChangeTestEvidence;
use crate::assessment::indicators::{DriftEvidence, HysteresisEvidence, HysteresisOutcome};
use crate::error::Result;
use crate::report::table::{self, Table};
use crate::vocab::tables as t;

/// The change test of this run against its reference (`modal` stage with
/// `reference_modes`), when the run wrote one.
pub fn change_test_evidence(dir: &Path) -> Result<Option<ChangeTestEvidence>> {
    if read(dir, &t::CHANGE_TEST).is_none() {
        return Ok(None);
    }
    crate::sinks::change_tables::read_change_test_evidence(dir)
}

/// A table of the run, when the run manifest lists it and it reads.
pub fn read(dir: &Path, schema: &crate::vocab::schema::TableSchema) -> Option<Table> {
    let listed = crate::pipeline::listed_results(dir)
        .map(|files| {
            files
                .iter()
                .any(|f| f == schema.file || f == schema.flat_file())
        })
        .unwrap_or(true);
    let path = schema.locate(dir);
    (listed && path.exists())
        .then(|| table::load(&path, None).ok())
        .flatten()
}

fn number(t: &Table, column: &str, row: usize) -> Option<f64> {
    t.number(column)?.get(row).copied().flatten()
}

/// (direction label, frequency) of every row of a modes-like table (the
/// lowest per direction is taken where it is used).
pub fn modes_per_direction(
    t: &Option<Table>,
    direction: &str,
    frequency: &str,
) -> Vec<(String, f64)> {
    let Some(t) = t else {
        return Vec::new();
    };
    (0..t.rows)
        .filter_map(|r| Some((t.key(direction, r)?, number(t, frequency, r)?)))
        .collect()
}

pub fn drift_evidence(d: &Table) -> Vec<DriftEvidence> {
    use t::drift as c;
    (0..d.rows)
        .map(|r| DriftEvidence {
            direction: d.key(c::DIRECTION.name, r).unwrap_or_default(),
            lower_level: number(d, c::LOWER_LEVEL.name, r).unwrap_or(-1.0) as i32,
            upper_level: number(d, c::UPPER_LEVEL.name, r).unwrap_or(-1.0) as i32,
            kind: d.key(c::KIND.name, r).unwrap_or_default(),
            peak_ratio: number(d, c::PEAK_DRIFT_RATIO.name, r).unwrap_or(f64::NAN),
            height_source: d.key(c::HEIGHT_SOURCE.name, r).unwrap_or_default(),
            residual_ratio: number(d, c::RESIDUAL_DRIFT_RATIO.name, r),
            residual_status: d.key(c::RESIDUAL_STATUS.name, r),
        })
        .collect()
}

/// Per direction: the Bouc-Wen verdict (bouc_wen/bouc_wen.parquet's `verdict`,
/// else its statuses), the energies of its DoFs and, where identified, ι
/// from damage/damage.parquet.
pub fn hysteresis_evidence(dir: &Path) -> Vec<HysteresisEvidence> {
    use t::bouc_wen as c;
    let Some(b) = read(dir, &t::BOUC_WEN) else {
        return Vec::new();
    };
    let damage = read(dir, &t::DAMAGE);
    let mut out = Vec::new();
    for (keys, rows) in b.groups(&[c::DIRECTION.name]) {
        let direction = keys.first().cloned().unwrap_or_default();
        let key = |col: &str, r: usize| b.key(col, r).unwrap_or_default();
        let reason = rows
            .iter()
            .map(|&r| key(c::REASON.name, r))
            .find(|s| !s.is_empty())
            .unwrap_or_default();
        let verdict = rows
            .iter()
            .map(|&r| key(c::VERDICT.name, r))
            .find(|s| !s.is_empty())
            .unwrap_or_else(|| {
                // Tables written before the verdict column: from the statuses.
                if rows
                    .iter()
                    .any(|&r| key(c::STATUS.name, r).starts_with("identified"))
                {
                    "nonlinear_identified".into()
                } else {
                    "not_identifiable".into()
                }
            });
        // One energy per DoF (repeated on its parameter rows).
        let mut seen = std::collections::BTreeSet::new();
        let energies: Vec<f64> = rows
            .iter()
            .filter(|&&r| seen.insert(key(c::DOF.name, r)))
            .filter_map(|&r| number(&b, c::ENERGY_HYSTERETIC_J.name, r))
            .collect();
        let energy_j = (!energies.is_empty()).then(|| energies.iter().sum());
        let outcome = match verdict.as_str() {
            "nonlinear_identified" => {
                let (final_iota, peak_iota) = damage
                    .as_ref()
                    .map(|d| iota_of(d, &direction))
                    .unwrap_or((None, None));
                HysteresisOutcome::Nonlinear {
                    final_iota,
                    peak_iota,
                    energy_j,
                }
            }
            "no_significant_hysteresis" => HysteresisOutcome::NoSignificantHysteresis { reason },
            _ => HysteresisOutcome::NotIdentifiable { reason },
        };
        out.push(HysteresisEvidence { direction, outcome });
    }
    out
}

/// (final, peak) ι of `direction` in damage/damage.parquet.
fn iota_of(d: &Table, direction: &str) -> (Option<f64>, Option<f64>) {
    let (Some(iota), Some(time)) = (
        d.number(t::damage::IOTA.name),
        d.number(t::damage::T_S.name),
    ) else {
        return (None, None);
    };
    let mut last: Option<(f64, f64)> = None;
    let mut peak: Option<f64> = None;
    for r in 0..d.rows {
        if d.key(t::damage::DIRECTION.name, r).as_deref() != Some(direction) {
            continue;
        }
        let (Some(v), Some(at)) = (iota[r], time[r]) else {
            continue;
        };
        if last.is_none_or(|(lt, _)| at >= lt) {
            last = Some((at, v));
        }
        peak = Some(peak.map_or(v, |p| p.max(v)));
    }
    (last.map(|(_, v)| v), peak)
}
