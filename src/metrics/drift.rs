//! Peak inter-storey drift ratios per storey and building direction, from
//! the conditioned displacements (METHODS §1 metrics), and the residual
//! drift of each storey from the unfiltered records (`residual`).

use std::collections::BTreeMap;

use super::residual::{residual_drift_of, ResidualDrift};
use crate::conditioning::Motion;
use crate::error::{Error, Result};
use crate::vocab::{Event, Record};

/// One storey's peak drift in one direction.
#[derive(Debug, Clone, PartialEq)]
pub struct DriftRow {
    pub direction: String,
    /// Upper level of the storey (storey L joins levels L−1 and L).
    pub storey: i32,
    pub lower_channel: String,
    pub upper_channel: String,
    pub storey_height_m: f64,
    pub peak_drift_ratio: f64,
    /// Residual drift from the unfiltered records, when they were available
    /// on a common time base ([`storey_residual_drifts`]).
    pub residual: Option<ResidualDrift>,
}

/// Residual drift per (direction, storey) of an event's records as recorded
/// (the run's source, before any conditioning step; converted to SI here).
/// Storeys whose two levels are not on a common time base, or whose records
/// cannot be converted to SI or hold non-finite samples, are left out.
pub fn storey_residual_drifts(source: &Event) -> Result<BTreeMap<(String, i32), ResidualDrift>> {
    let mut out = BTreeMap::new();
    let selection = crate::geometry::one_record_per_level(&source.records);
    let mut by_dir: BTreeMap<String, Vec<(i32, &Record)>> = BTreeMap::new();
    for (&(axis, level), r) in &selection.records {
        by_dir
            .entry(format!("{axis:?}"))
            .or_default()
            .push((level, *r));
    }
    for (dir, mut list) in by_dir {
        list.sort_by_key(|(l, _)| *l);
        for w in list.windows(2) {
            let ((l0, r0), (l1, r1)) = (w[0], w[1]);
            let (c0, c1) = (&r0.channel, &r1.channel);
            if l1 != l0 + 1 || r0.len() != r1.len() || (c0.dt() - c1.dt()).abs() > 1e-12 {
                continue;
            }
            let (Some(f0), Some(f1)) = (c0.units.to_si_factor(), c1.units.to_si_factor()) else {
                continue;
            };
            match residual_drift_of(&relative_si(r0, f0, r1, f1)?, c0.dt()) {
                Ok(residual) => {
                    out.insert((dir.clone(), l1), residual);
                }
                // Too short, non-finite: no residual drift for this storey.
                Err(Error::Usage(_) | Error::Numerical(_)) => {}
                Err(e) => return Err(e),
            }
        }
    }
    Ok(out)
}

/// The relative acceleration `upper·f_upper − lower·f_lower` (SI) of two
/// records of equal length — what `residual::residual_drift` forms from the
/// two records in SI, value for value — read a range of samples at a time:
/// of a day-long storey only the result is held (the two records in SI were
/// two more series of the record's length, 138 MB each at 200 Hz).
fn relative_si(lower: &Record, f_lower: f64, upper: &Record, f_upper: f64) -> Result<Vec<f64>> {
    const CHUNK: usize = 1 << 20;
    let n = lower.len();
    let mut relative = Vec::with_capacity(n);
    for start in (0..n).step_by(CHUNK) {
        let (l, u) = (
            lower.samples.get_range(start, CHUNK)?,
            upper.samples.get_range(start, CHUNK)?,
        );
        relative.extend(
            u.iter()
                .zip(l.iter())
                .map(|(u, l)| u * f_upper - l * f_lower),
        );
    }
    Ok(relative)
}

/// Peak inter-storey drift ratios: channels grouped by direction, ordered by
/// level; consecutive levels with known storey heights form a storey.
/// `residual`: the residual drifts of [`storey_residual_drifts`], joined by
/// (direction, storey).
pub fn storey_drift(
    event: &Event,
    motions: &[Motion],
    residual: &BTreeMap<(String, i32), ResidualDrift>,
) -> Result<Vec<DriftRow>> {
    let Some(structure) = &event.structure else {
        return Ok(Vec::new());
    };
    let heights = &structure.storey_heights_m;
    if heights.is_empty() {
        return Ok(Vec::new());
    }
    // One motion per level and direction: the rigid-floor combination where
    // a level has several channels (geometry::floor).
    let selection = crate::geometry::one_record_per_level(&event.records);
    let mut by_dir: BTreeMap<String, Vec<(i32, &Record, &Motion)>> = Default::default();
    for (&(axis, level), r) in &selection.records {
        if let Some(m) = motions.iter().find(|m| m.channel_id == r.channel.id) {
            by_dir
                .entry(format!("{axis:?}"))
                .or_default()
                .push((level, *r, m));
        }
    }
    let mut rows = Vec::new();
    for (dir, mut list) in by_dir {
        list.sort_by_key(|(l, _, _)| *l);
        for w in list.windows(2) {
            let (l0, r0, m0) = &w[0];
            let (l1, r1, m1) = &w[1];
            if *l1 != l0 + 1 || *l1 < 1 || (*l1 as usize) > heights.len() {
                continue;
            }
            if m0.displacement.len() != m1.displacement.len() || (m0.dt - m1.dt).abs() > 1e-12 {
                continue; // not on a common time base: alignment was not configured
            }
            let h = heights[*l1 as usize - 1];
            // Read a storey's two displacements at a time (parked motions).
            let ratio =
                super::interstorey_drift(&m0.displacement.get()?, &m1.displacement.get()?, h)?;
            rows.push(DriftRow {
                direction: dir.clone(),
                storey: *l1,
                lower_channel: r0.channel.id.clone(),
                upper_channel: r1.channel.id.clone(),
                storey_height_m: h,
                peak_drift_ratio: ratio,
                residual: residual.get(&(dir.clone(), *l1)).copied(),
            });
        }
    }
    Ok(rows)
}
