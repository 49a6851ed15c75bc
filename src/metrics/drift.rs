//! Peak drift ratios per building direction over any instrumented set of
//! levels (METHODS §1 metrics), from the conditioned displacements, and the
//! residual drift of each segment from the unfiltered records (`residual`).
//!
//! Level convention (team-wide): level 0 = the base (basement, ground,
//! foundation); "Nth floor" of a US/CSMIP/NSMP building = level N−1; the
//! roof = level `structure.storeys`.  Storey L joins levels L−1 and L.
//!
//! In each direction the instrumented levels (one record per level:
//! `geometry::one_record_per_level`) are sorted; each pair of consecutive
//! instrumented levels is a **segment**.  A segment of one storey is a
//! *measured* storey drift (the values of earlier versions, unchanged); a
//! segment of several storeys gets its *average* drift ratio, peak over time
//! of |u_upper − u_lower| / H (H = the sum of its storey heights) — a lower
//! bound of the largest storey drift inside it, since at every instant the
//! segment's relative displacement is the sum of its storeys' — and every
//! storey inside gets an *estimate* from the interpolated displacement
//! profile ([`super::profile`]: not-a-knot cubic spline over all the
//! direction's instrumented levels at each time step), marked as such.

use std::collections::BTreeMap;

use super::profile::cardinal_weights;
use super::residual::{residual_drift_of, ResidualDrift};
use crate::conditioning::Motion;
use crate::error::{Error, Result};
use crate::vocab::{Channel, Event, Record, Structure};

/// Default storey height assumed when the structure states none, m.
/// HAZUS-MH Technical Manual (FEMA, 2003), Table 5.1, gives the typical
/// heights of its model building types as 10–14 ft per storey (3.0–4.3 m:
/// C1 mid-rise 5 storeys / 50 ft, S1 mid-rise 5 storeys / 60 ft, S1
/// high-rise 13 storeys / 156 ft); 3.5 m is the middle of that range.
pub const DEFAULT_ASSUMED_STOREY_HEIGHT_M: f64 = 3.5;

/// What a row of the drift table is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DriftKind {
    /// One storey between two instrumented levels: measured.
    Measured,
    /// Several storeys between two instrumented levels: the average ratio.
    Segment,
    /// One storey inside a segment: interpolated, not measured.
    Estimate,
}

impl DriftKind {
    pub fn name(self) -> &'static str {
        match self {
            DriftKind::Measured => "measured",
            DriftKind::Segment => "segment",
            DriftKind::Estimate => "estimate",
        }
    }
}

/// Where the heights of a row come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HeightSource {
    /// `structure.storey_heights_m`.
    Stated,
    /// `structure.height_m / structure.storeys`.
    FromTotalHeight,
    /// The metrics stage's `assumed_storey_height_m`: ratings provisional.
    Assumed,
    /// A segment ending at a roof whose level was ASSUMED (the storey count
    /// is unknown: `event_folder::structure` puts the roof one level above
    /// the highest labelled floor): how many storeys it spans is unknown, so
    /// its ratio is shown over the assumed storeys but never rated.
    RoofLevelAssumed,
}

impl HeightSource {
    pub fn name(self) -> &'static str {
        match self {
            HeightSource::Stated => "stated",
            HeightSource::FromTotalHeight => "from total height",
            HeightSource::Assumed => "assumed",
            HeightSource::RoofLevelAssumed => "unknown: roof level assumed",
        }
    }
}

/// Largest residual drift, as a multiple of its row's tabled peak drift,
/// that an offset reached during the motion can show.  The tabled peak comes
/// from band-passed displacements, and a zero-phase high-pass of an offset D
/// reached within a cycle leaves ±D/2 on either side of it: the tabled peak
/// of a real residual is at least about D/2 (the noise-free yielding sample:
/// D = 1.13 × the tabled peak at its second storey, a real permanent drift).
/// Beyond twice the peak the offset cannot have been reached during the
/// motion — a baseline error (an offset step, a tilt) that double
/// integration turned into a drift.  Assumes the band keeps the structure's
/// fundamental (a band-pass that removes it removes the peak too).
pub const ARTEFACT_PEAK_FACTOR: f64 = 2.0;

/// What a residual drift is worth (the rule, in this order):
/// `Unresolved` when |D| < 2σ (it does not stand out of its own noise);
/// else `Artefact` when |D| > [`ARTEFACT_PEAK_FACTOR`] × the peak drift of
/// its own row; else `Resolved`.  Only resolved residuals are rated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResidualStatus {
    Resolved,
    Unresolved,
    Artefact,
}

impl ResidualStatus {
    pub fn name(self) -> &'static str {
        match self {
            ResidualStatus::Resolved => "resolved",
            ResidualStatus::Unresolved => "unresolved",
            ResidualStatus::Artefact => "artefact",
        }
    }

    /// The status of `residual` against its row's peak drift, m.
    pub fn of(residual: &ResidualDrift, peak_drift_m: f64) -> ResidualStatus {
        if !residual.resolved() {
            ResidualStatus::Unresolved
        } else if residual.drift_m.abs() > ARTEFACT_PEAK_FACTOR * peak_drift_m {
            ResidualStatus::Artefact
        } else {
            ResidualStatus::Resolved
        }
    }
}

/// Method text of each kind of row (the `method` column).
pub const MEASURED_METHOD: &str = "relative displacement of the two levels";
pub const SEGMENT_METHOD: &str =
    "relative displacement of the segment's end levels / segment height";
pub const ESTIMATE_METHOD: &str = "not-a-knot cubic spline of the displacement profile over the instrumented levels, at each time step";

/// One row of the drift table: a storey, a segment or a storey estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct DriftRow {
    pub direction: String,
    /// Upper level of the storey or segment.
    pub storey: i32,
    /// The levels the row spans (storey L: L−1 and L).
    pub lower_level: i32,
    pub upper_level: i32,
    pub kind: DriftKind,
    pub method: &'static str,
    /// The records the value comes from (for an estimate: its segment's).
    pub lower_channel: String,
    pub upper_channel: String,
    /// Height of the storey or segment, m.
    pub storey_height_m: f64,
    pub height_source: HeightSource,
    pub peak_drift_ratio: f64,
    /// Residual drift from the unfiltered records (measured and segment
    /// rows), when they were available on a common time base.
    pub residual: Option<ResidualDrift>,
    pub residual_status: Option<ResidualStatus>,
}

/// The drift table and why rows are missing (`quaketwin.notes`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DriftTable {
    pub rows: Vec<DriftRow>,
    pub notes: Vec<String>,
}

/// Storey heights h_1..h_n and where they come from.
#[derive(Debug, Clone, PartialEq)]
pub struct StoreyHeights {
    pub heights_m: Vec<f64>,
    pub source: HeightSource,
}

impl StoreyHeights {
    /// Stated heights; else the total height over the storey count; else
    /// `assumed_m` for each of `top_level` storeys.
    pub fn resolve(structure: Option<&Structure>, top_level: i32, assumed_m: f64) -> Self {
        if let Some(s) = structure {
            if !s.storey_heights_m.is_empty() {
                return StoreyHeights {
                    heights_m: s.storey_heights_m.clone(),
                    source: HeightSource::Stated,
                };
            }
            if let (Some(h), Some(n)) = (s.height_m, s.storeys) {
                if h.is_finite() && h > 0.0 && n > 0 {
                    return StoreyHeights {
                        heights_m: vec![h / n as f64; n as usize],
                        source: HeightSource::FromTotalHeight,
                    };
                }
            }
        }
        StoreyHeights {
            heights_m: vec![assumed_m; top_level.max(0) as usize],
            source: HeightSource::Assumed,
        }
    }

    /// Height between levels `lower` < `upper` (sum of its storeys, in
    /// order), None when a storey's height is not known.
    pub fn between(&self, lower: i32, upper: i32) -> Option<f64> {
        if lower < 0 || upper as usize > self.heights_m.len() {
            return None;
        }
        Some(self.heights_m[lower as usize..upper as usize].iter().sum())
    }
}

/// Where records share a time base: the first sample of each, and the
/// number of samples they have in common.
#[derive(Debug, Clone, PartialEq)]
pub struct Window {
    pub offsets: Vec<usize>,
    pub len: usize,
}

/// The common time window of `records` (channel, sample count): same
/// sampling interval (to 1e-12 s) and the same start, or starts a whole
/// number of samples apart; the window is their overlap.  Err: why there
/// is none.  A channel without a start time is taken to start with the
/// others when those agree.
pub fn common_window(records: &[(&Channel, usize)]) -> std::result::Result<Window, String> {
    let Some((first, _)) = records.first() else {
        return Err("no records".into());
    };
    let dt = first.dt();
    if let Some((c, _)) = records.iter().find(|(c, _)| (c.dt() - dt).abs() > 1e-12) {
        return Err(format!(
            "{} and {} are sampled at different rates ({} and {} Hz): resample them (condition step `resample`)",
            first.id, c.id, first.sampling_rate_hz, c.sampling_rate_hz
        ));
    }
    let known: Vec<i64> = records.iter().filter_map(|(c, _)| c.start_ns).collect();
    let latest = known.iter().copied().max();
    let offsets: Vec<usize> = match latest {
        Some(latest) if known.len() == records.len() => {
            let mut offsets = Vec::with_capacity(records.len());
            for (c, _) in records {
                let samples = (latest - c.start_ns.unwrap_or(latest)) as f64 * 1e-9 / dt;
                if (samples - samples.round()).abs() > 0.01 {
                    return Err(format!(
                        "{} starts {:.6} s before the latest start, not a whole number of samples: align the records (condition step `align`)",
                        c.id,
                        samples * dt
                    ));
                }
                offsets.push(samples.round() as usize);
            }
            offsets
        }
        Some(latest) if known.iter().any(|s| *s != latest) => {
            return Err(
                "some records have no start time and the others start at different times".into(),
            );
        }
        _ => vec![0; records.len()],
    };
    let len = records
        .iter()
        .zip(&offsets)
        .map(|((_, n), o)| n.saturating_sub(*o))
        .min()
        .unwrap_or(0);
    if len < 2 {
        return Err("the records do not overlap in time".into());
    }
    Ok(Window { offsets, len })
}

/// A note when `window` cuts any of `records` (ids and lengths).
fn trimmed_note(what: &str, records: &[(&Channel, usize)], window: &Window) -> Option<String> {
    if records.iter().all(|(_, n)| *n == window.len) {
        return None;
    }
    let lengths: Vec<String> = records
        .iter()
        .map(|(c, n)| format!("{} {n}", c.id))
        .collect();
    Some(format!(
        "{what}: records of different lengths ({} samples): drift over their common window of {} samples ({} s)",
        lengths.join(", "),
        window.len,
        window.len as f64 * records[0].0.dt()
    ))
}

/// One record per level of each direction, sorted by level.
fn levels_by_direction(records: &[Record]) -> BTreeMap<String, Vec<(i32, &Record)>> {
    let selection = crate::geometry::one_record_per_level(records);
    let mut by_dir: BTreeMap<String, Vec<(i32, &Record)>> = BTreeMap::new();
    for (&(axis, level), r) in &selection.records {
        by_dir
            .entry(format!("{axis:?}"))
            .or_default()
            .push((level, *r));
    }
    for list in by_dir.values_mut() {
        list.sort_by_key(|(l, _)| *l);
    }
    by_dir
}

/// Residual drifts of a source's segments, keyed by (direction, lower
/// level, upper level), and notes on the segments left out.
pub type Residuals = BTreeMap<(String, i32, i32), ResidualDrift>;

/// Residual drift per (direction, segment) of an event's records as
/// recorded (the run's source, before any conditioning step; converted to
/// SI here), over the two levels' common time window.  Segments whose
/// records share no time base, cannot be converted to SI or hold
/// non-finite samples are left out.
pub fn storey_residual_drifts(source: &Event) -> Result<Residuals> {
    let mut out = BTreeMap::new();
    for (dir, list) in levels_by_direction(&source.records) {
        for w in list.windows(2) {
            let ((l0, r0), (l1, r1)) = (w[0], w[1]);
            let (c0, c1) = (&r0.channel, &r1.channel);
            let Ok(window) = common_window(&[(c0, r0.len()), (c1, r1.len())]) else {
                continue;
            };
            let (Some(f0), Some(f1)) = (c0.units.to_si_factor(), c1.units.to_si_factor()) else {
                continue;
            };
            match residual_drift_of(&relative_si(r0, f0, r1, f1, &window)?, c0.dt()) {
                Ok(residual) => {
                    out.insert((dir.clone(), l0, l1), residual);
                }
                // Too short, non-finite: no residual drift for this segment.
                Err(Error::Usage(_) | Error::Numerical(_)) => {}
                Err(e) => return Err(e),
            }
        }
    }
    Ok(out)
}

/// The relative acceleration `upper·f_upper − lower·f_lower` (SI) of two
/// records over their common `window` — what `residual::residual_drift`
/// forms from the two records in SI, value for value — read a range of
/// samples at a time: of a day-long storey only the result is held (the two
/// records in SI were two more series of the record's length, 138 MB each
/// at 200 Hz).
fn relative_si(
    lower: &Record,
    f_lower: f64,
    upper: &Record,
    f_upper: f64,
    window: &Window,
) -> Result<Vec<f64>> {
    const CHUNK: usize = 1 << 20;
    let n = window.len;
    let (o_lower, o_upper) = (window.offsets[0], window.offsets[1]);
    let mut relative = Vec::with_capacity(n);
    for start in (0..n).step_by(CHUNK) {
        let take = CHUNK.min(n - start);
        let (l, u) = (
            lower.samples.get_range(o_lower + start, take)?,
            upper.samples.get_range(o_upper + start, take)?,
        );
        relative.extend(
            u.iter()
                .zip(l.iter())
                .map(|(u, l)| u * f_upper - l * f_lower),
        );
    }
    Ok(relative)
}

/// A level's conditioned motion: level, record, motion.
type Level<'a> = (i32, &'a Record, &'a Motion);

/// Peak drift ratios of every segment between consecutive instrumented
/// levels and per-storey estimates inside segments of several storeys (see
/// the module); `residual`: [`storey_residual_drifts`], joined by
/// (direction, segment).  Heights: [`StoreyHeights::resolve`] with
/// `assumed_storey_height_m`.  Every reason a drift could not be formed is
/// in the notes.
pub fn storey_drift(
    event: &Event,
    motions: &[Motion],
    residual: &Residuals,
    assumed_storey_height_m: f64,
) -> Result<DriftTable> {
    let mut table = DriftTable::default();
    // One motion per level and direction: the rigid-floor combination where
    // a level has several channels (geometry::floor).
    let mut by_dir: BTreeMap<String, Vec<Level<'_>>> = BTreeMap::new();
    let mut levels_seen = false;
    for (dir, list) in levels_by_direction(&event.records) {
        levels_seen = true;
        let mut kept = Vec::new();
        for (level, r) in list {
            if level < 0 {
                table.notes.push(format!(
                    "direction {dir}: {} is at level {level}, below the base (level 0): left out of the drift",
                    r.channel.id
                ));
            } else if let Some(m) = motions.iter().find(|m| m.channel_id == r.channel.id) {
                kept.push((level, r, m));
            } else {
                table.notes.push(format!(
                    "direction {dir}: {} (level {level}) has no displacement (not an acceleration record, or the condition stage does not integrate)",
                    r.channel.id
                ));
            }
        }
        by_dir.insert(dir, kept);
    }
    if !levels_seen {
        table.notes.push(
            "no drift: no horizontal channel in building axes has a level (state `level` per channel in event.toml, or the building axes)"
                .into(),
        );
        return Ok(table);
    }
    let top = by_dir
        .values()
        .flat_map(|l| l.iter().map(|(level, _, _)| *level))
        .max()
        .unwrap_or(0);
    let heights = StoreyHeights::resolve(event.structure.as_ref(), top, assumed_storey_height_m);
    match heights.source {
        HeightSource::Assumed => table.notes.push(format!(
            "no storey heights stated (structure.storey_heights_m, or height_m with storeys): each storey assumed {} m high (metrics param assumed_storey_height_m): drift ratios and their ratings are provisional",
            assumed_storey_height_m
        )),
        HeightSource::FromTotalHeight => table.notes.push(format!(
            "storey heights from the total height: {} m each (structure.height_m / storeys)",
            heights.heights_m.first().copied().unwrap_or(0.0)
        )),
        // Set per segment in `direction_rows`, never by `resolve`.
        HeightSource::Stated | HeightSource::RoofLevelAssumed => {}
    }
    for (dir, list) in &by_dir {
        direction_rows(dir, list, &heights, residual, &mut table)?;
    }
    Ok(table)
}

/// The rows of one direction (its levels sorted).
fn direction_rows(
    dir: &str,
    list: &[Level<'_>],
    heights: &StoreyHeights,
    residual: &Residuals,
    table: &mut DriftTable,
) -> Result<()> {
    if list.len() < 2 {
        let only = match list.first() {
            Some((l, r, _)) => format!("only level {l} ({}) is instrumented", r.channel.id),
            None => "no level has a displacement".into(),
        };
        table.notes.push(format!(
            "direction {dir}: no drift: {only}; a drift needs two levels"
        ));
        return Ok(());
    }
    let mut segments_formed = Vec::new();
    for w in list.windows(2) {
        let ((l0, r0, m0), (l1, r1, m1)) = (w[0], w[1]);
        let what = format!("direction {dir}, levels {l0}–{l1}");
        let Some(h) = heights.between(l0, l1) else {
            table.notes.push(format!(
                "{what}: no drift: the stated storey heights cover {} storeys, the segment reaches level {l1}",
                heights.heights_m.len()
            ));
            continue;
        };
        let pair = [
            (&r0.channel, m0.displacement.len()),
            (&r1.channel, m1.displacement.len()),
        ];
        let window = match common_window(&pair) {
            Ok(w) => w,
            Err(why) => {
                table.notes.push(format!("{what}: no drift: {why}"));
                continue;
            }
        };
        table.notes.extend(trimmed_note(&what, &pair, &window));
        let span = |m: &Motion, o: usize| -> Result<Vec<f64>> {
            Ok(m.displacement.get_range(o, window.len)?.into_owned())
        };
        // Read a segment's two displacements at a time (parked motions).
        let ratio = super::interstorey_drift(
            &span(m0, window.offsets[0])?,
            &span(m1, window.offsets[1])?,
            h,
        )?;
        let res = residual.get(&(dir.to_string(), l0, l1)).copied();
        let roof_assumed = [&r0.channel, &r1.channel].iter().any(|c| {
            c.inferred
                .iter()
                .any(|i| i.starts_with("level=") && i.contains("ASSUMED"))
        });
        if roof_assumed {
            table.notes.push(format!(
                "{what}: the roof's level is assumed (storey count unknown): the segment's height is unknown, its drift ratio is shown over the assumed storeys and not rated; state structure.storeys in event.toml"
            ));
        }
        let kind = if l1 == l0 + 1 {
            DriftKind::Measured
        } else {
            DriftKind::Segment
        };
        table.rows.push(DriftRow {
            direction: dir.to_string(),
            storey: l1,
            lower_level: l0,
            upper_level: l1,
            kind,
            method: if kind == DriftKind::Measured {
                MEASURED_METHOD
            } else {
                SEGMENT_METHOD
            },
            lower_channel: r0.channel.id.clone(),
            upper_channel: r1.channel.id.clone(),
            storey_height_m: h,
            height_source: if roof_assumed {
                HeightSource::RoofLevelAssumed
            } else {
                heights.source
            },
            peak_drift_ratio: ratio,
            residual: res,
            residual_status: res.map(|x| ResidualStatus::of(&x, ratio * h)),
        });
        if kind == DriftKind::Segment {
            segments_formed.push(table.rows.len() - 1);
        }
    }
    if !segments_formed.is_empty() {
        estimate_rows(dir, list, heights, &segments_formed, table)?;
    }
    Ok(())
}

/// Per-storey estimates inside the segment rows `segments` of one direction
/// (module doc; [`super::profile`]), inserted after each segment's row.
fn estimate_rows(
    dir: &str,
    list: &[Level<'_>],
    heights: &StoreyHeights,
    segments: &[usize],
    table: &mut DriftTable,
) -> Result<()> {
    let (lowest, highest) = (list[0].0, list[list.len() - 1].0);
    let Some(_) = heights.between(lowest, highest) else {
        table.notes.push(format!(
            "direction {dir}: no per-storey estimates: storey heights are not known up to level {highest}"
        ));
        return Ok(());
    };
    let all: Vec<(&Channel, usize)> = list
        .iter()
        .map(|(_, r, m)| (&r.channel, m.displacement.len()))
        .collect();
    let window = match common_window(&all) {
        Ok(w) => w,
        Err(why) => {
            table
                .notes
                .push(format!("direction {dir}: no per-storey estimates: {why}"));
            return Ok(());
        }
    };
    // Elevation of every level from the lowest instrumented one.
    let elevation = |level: i32| heights.between(lowest, level).unwrap_or(0.0);
    let knots: Vec<f64> = list.iter().map(|(l, _, _)| elevation(*l)).collect();
    let boundaries: Vec<f64> = (lowest..=highest).map(elevation).collect();
    let weights = cardinal_weights(&knots, &boundaries)?;
    let displacements: Vec<Vec<f64>> = list
        .iter()
        .zip(&window.offsets)
        .map(|((_, _, m), &o)| Ok(m.displacement.get_range(o, window.len)?.into_owned()))
        .collect::<Result<_>>()?;
    let mut inserted = 0;
    for &s in segments {
        let seg = table.rows[s + inserted].clone();
        let mut estimates = Vec::new();
        for storey in seg.lower_level + 1..=seg.upper_level {
            let (a, b) = ((storey - 1 - lowest) as usize, (storey - lowest) as usize);
            let coefficients: Vec<f64> = weights[b]
                .iter()
                .zip(&weights[a])
                .map(|(wb, wa)| wb - wa)
                .collect();
            let peak = (0..window.len).fold(0.0f64, |peak, t| {
                let d: f64 = coefficients
                    .iter()
                    .zip(&displacements)
                    .map(|(c, u)| c * u[t])
                    .sum();
                peak.max(d.abs())
            });
            let h = heights.between(storey - 1, storey).unwrap_or(f64::NAN);
            estimates.push(DriftRow {
                storey,
                lower_level: storey - 1,
                upper_level: storey,
                kind: DriftKind::Estimate,
                method: ESTIMATE_METHOD,
                storey_height_m: h,
                peak_drift_ratio: peak / h,
                residual: None,
                residual_status: None,
                ..seg.clone()
            });
        }
        let at = s + inserted + 1;
        inserted += estimates.len();
        table.rows.splice(at..at, estimates);
    }
    Ok(())
}
