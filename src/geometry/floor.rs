//! Rigid-floor combination (METHODS §0): where a level carries two or more
//! horizontal channels in one building direction, the floor's motion is
//! formed once from them, under the assumption that the floor diaphragm is
//! rigid in its plane, and every stage that works per level (drift,
//! hysteresis, the report) uses that floor motion.
//!
//! With plan positions (`position_m`) of every horizontal channel of the
//! level, each sample is a least-squares solve for the floor's translations
//! at the reference point r = (x_c, y_c) (the stated centre of mass, else the
//! centroid of the level's sensors) and its rotation θ:
//!
//!   sensor along X at (x, y):  a = a_X − θ̈ (y − y_c)
//!   sensor along Y at (x, y):  a = a_Y + θ̈ (x − x_c)
//!
//! (3 unknowns; the normal matrix AᵀA is the same for every sample, so it is
//! factored once). A channel whose residual exceeds `disagreement_ratio` of
//! its own RMS while the system is over-determined is flagged (a local wall
//! or slab mode, a mislabelled sensor) and left out, worst first.
//!
//! Without positions the floor translation in a direction is the mean of its
//! channels (exact at the centre of mass for sensors placed symmetrically
//! about it; stated as such). A channel that disagrees with the others by
//! more than `disagreement_ratio` is flagged; with only two channels neither
//! can be blamed, so both are flagged and the mean is kept, saying so.
//!
//! Cost: each round of checking is linear in the level's channels and
//! samples (the mean of the others is the total less the channel's own), and
//! at most [`MAX_WORST_FIRST`] channels are left out one at a time; beyond
//! that every channel still above the ratio is left out in one round, so a
//! level of thousands of sensors costs a few passes, never one per sensor
//! (issue 33: 2,000 channels on one level took 215 s).

use std::collections::BTreeMap;

use nalgebra::{Matrix3, Vector3};
use serde::Serialize;
use serde_json::json;

use crate::error::Result;
use crate::vocab::{Axis, Channel, Direction, Event, QaFlag, Record, Role, SourceRef, Units};

/// Channels left out one at a time, worst first, before the rest of those
/// above the disagreement ratio are left out together (module doc).
pub const MAX_WORST_FIRST: usize = 8;

/// Settings of the rigid-floor combination.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FloorSettings {
    /// RMS of a channel's misfit to the floor motion, as a fraction of the
    /// channel's own RMS, above which it disagrees with its floor.
    pub disagreement_ratio: f64,
}

impl Default for FloorSettings {
    fn default() -> Self {
        FloorSettings {
            disagreement_ratio: 0.25,
        }
    }
}

/// What the combination did at one level.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FloorCombination {
    pub level: i32,
    /// `rigid_floor_least_squares`, `mean`, or `not_combined`.
    pub method: String,
    /// Reference point of the translations (least squares only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_m: Option<[f64; 2]>,
    /// Ids of the floor motions formed (`L2.X`, `L2.Y`).
    pub floors: Vec<String>,
    /// Sensor channels the floor motions were formed from.
    pub channels: Vec<String>,
    /// Channels flagged as disagreeing with their floor, with the misfit ratio.
    pub disagreeing: Vec<(String, f64)>,
    /// Peak |θ̈| of the floor, rad/s² (least squares only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub peak_rotation_rad_s2: Option<f64>,
    pub note: String,
}

/// One record per (horizontal axis, level): the floor motion where one was
/// formed, the single channel otherwise. Levels with several channels in a
/// direction and no floor motion are listed as ambiguous.
#[derive(Debug, Default)]
pub struct LevelSelection<'a> {
    pub records: BTreeMap<(Axis, i32), &'a Record>,
    pub ambiguous: Vec<(Axis, i32, Vec<String>)>,
}

/// Picks the record that stands for each level in each horizontal direction
/// (see [`LevelSelection`]). Channels not in building axes are left out.
pub fn one_record_per_level(records: &[Record]) -> LevelSelection<'_> {
    let mut groups: BTreeMap<(Axis, i32), Vec<&Record>> = BTreeMap::new();
    for r in records {
        let (Some(axis), Some(level)) = (r.channel.axis(), r.channel.level) else {
            continue;
        };
        if axis == Axis::Z {
            continue;
        }
        groups.entry((axis, level)).or_default().push(r);
    }
    let mut sel = LevelSelection::default();
    for (key, group) in groups {
        let floors: Vec<&Record> = group
            .iter()
            .copied()
            .filter(|r| r.channel.is_floor_motion())
            .collect();
        match (floors.as_slice(), group.as_slice()) {
            ([floor], _) => {
                sel.records.insert(key, *floor);
            }
            ([], [single]) => {
                sel.records.insert(key, *single);
            }
            _ => sel.ambiguous.push((
                key.0,
                key.1,
                group.iter().map(|r| r.channel.id.clone()).collect(),
            )),
        }
    }
    sel
}

/// A sensor channel that can enter a floor combination: horizontal, in
/// building axes, at a level, an acceleration with a known SI factor.
fn combinable(c: &Channel) -> Option<(Axis, i32, f64)> {
    let axis = c.axis().filter(|a| *a != Axis::Z)?;
    let level = c.level?;
    if c.is_floor_motion() || !c.units.is_acceleration() {
        return None;
    }
    Some((axis, level, c.units.to_si_factor()?))
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    if n == 0 {
        0.0
    } else {
        (s / n as f64).sqrt()
    }
}

/// A sensor entering a combination, its samples in m/s².
struct Sensor {
    index: usize,
    axis: Axis,
    si: Vec<f64>,
}

/// Forms the floor motions of `event` (see module doc): appends one record
/// per combined (level, direction), marks the sensors that went into it
/// (`combined_into`), flags those that disagree, and records the step
/// `rigid_floor` in the history.
pub fn combine_floors(
    event: &mut Event,
    settings: &FloorSettings,
) -> Result<Vec<FloorCombination>> {
    let mut by_level: BTreeMap<i32, Vec<(usize, Axis, f64)>> = BTreeMap::new();
    for (i, r) in event.records.iter().enumerate() {
        if let Some((axis, level, factor)) = combinable(&r.channel) {
            by_level.entry(level).or_default().push((i, axis, factor));
        }
    }
    let centre = event.structure.as_ref().and_then(|s| s.centre_of_mass_m);
    let mut done = Vec::new();
    let mut new_records = Vec::new();
    // Ids in use (a set: one lookup per floor motion, not a scan).
    let mut taken: std::collections::HashSet<String> =
        event.records.iter().map(|r| r.channel.id.clone()).collect();
    for (level, members) in by_level {
        let count = |a: Axis| members.iter().filter(|m| m.1 == a).count();
        if count(Axis::X) <= 1 && count(Axis::Y) <= 1 {
            continue; // one sensor per direction is the floor's motion already
        }
        let ids: Vec<String> = members
            .iter()
            .map(|m| event.records[m.0].channel.id.clone())
            .collect();
        let first = &event.records[members[0].0];
        let same_grid = members.iter().all(|m| {
            let c = &event.records[m.0];
            c.samples.len() == first.samples.len()
                && c.channel.sampling_rate_hz == first.channel.sampling_rate_hz
                && c.channel.start_ns == first.channel.start_ns
        });
        if !same_grid {
            done.push(FloorCombination {
                level,
                method: "not_combined".into(),
                reference_m: None,
                floors: Vec::new(),
                channels: ids,
                disagreeing: Vec::new(),
                peak_rotation_rad_s2: None,
                note: "channels differ in sampling rate, length or start time: not combined; stages that need one motion per level leave this level out".into(),
            });
            continue;
        }
        let sensors: Vec<Sensor> = members
            .iter()
            .map(|&(index, axis, factor)| Sensor {
                index,
                axis,
                si: event.records[index]
                    .samples
                    .iter()
                    .map(|v| v * factor)
                    .collect(),
            })
            .collect();
        let positions: Option<Vec<[f64; 2]>> = sensors
            .iter()
            .map(|s| event.records[s.index].channel.position_m)
            .collect();
        let combined = positions
            .and_then(|p| least_squares_floor(&sensors, &p, centre, settings))
            .unwrap_or_else(|| mean_floor(&sensors, settings));
        let mut comb = FloorCombination {
            level,
            method: combined.method.into(),
            reference_m: combined.reference,
            floors: Vec::new(),
            channels: Vec::new(),
            disagreeing: Vec::new(),
            peak_rotation_rad_s2: combined.peak_rotation,
            note: combined.note,
        };
        for (axis, samples, used) in combined.translations {
            let template = event.records[sensors[used[0]].index].channel.clone();
            let id = unique_id(&mut taken, &format!("L{level}.{axis:?}"));
            let used_ids: Vec<String> = used
                .iter()
                .map(|&k| event.records[sensors[k].index].channel.id.clone())
                .collect();
            for &k in &used {
                event.records[sensors[k].index].channel.combined_into = Some(id.clone());
            }
            let how = format!(
                "level {level} {axis:?} floor motion: {} of {}",
                match combined.method {
                    "mean" => "rigid-floor mean",
                    _ => "rigid-floor least squares",
                },
                used_ids.join(", ")
            );
            new_records.push(floor_record(
                &template,
                &id,
                axis,
                samples,
                used_ids.clone(),
                how,
                combined.reference,
            ));
            comb.floors.push(id);
            comb.channels.extend(used_ids);
        }
        for (k, ratio) in combined.disagreeing {
            let ch = &mut event.records[sensors[k].index].channel;
            ch.qa.push(QaFlag::Note {
                text: format!(
                    "disagrees with the rigid-floor motion of level {level}: misfit {:.0} % of its RMS (a local wall or slab mode, torsion without positions, or a mislabelled sensor)",
                    100.0 * ratio
                ),
            });
            comb.disagreeing.push((ch.id.clone(), ratio));
        }
        comb.channels.sort();
        comb.channels.dedup();
        done.push(comb);
    }
    event.records.extend(new_records);
    if !done.is_empty() {
        event.history.push(
            "rigid_floor",
            json!({ "settings": settings, "levels": done }),
        );
        for c in &done {
            if !c.disagreeing.is_empty() {
                event.notes.push(format!("level {}: {}", c.level, c.note));
            }
        }
    }
    Ok(done)
}

/// `wanted`, or `wanted#k` with the first free k; marked as taken.
fn unique_id(taken: &mut std::collections::HashSet<String>, wanted: &str) -> String {
    let id = if !taken.contains(wanted) {
        wanted.to_string()
    } else {
        (2..)
            .map(|k| format!("{wanted}#{k}"))
            .find(|id| !taken.contains(id))
            .expect("an unused id exists") // ok: finitely many records
    };
    taken.insert(id.clone());
    id
}

fn floor_record(
    template: &Channel,
    id: &str,
    axis: Axis,
    samples: Vec<f64>,
    combines: Vec<String>,
    how: String,
    reference: Option<[f64; 2]>,
) -> Record {
    let source = SourceRef {
        file: "(rigid-floor combination)".into(),
        member: None,
        column: None,
        format: "floor".into(),
    };
    let mut c = Channel::new(id, Units::MPerS2, template.sampling_rate_hz, source);
    c.station = template.station.clone();
    c.network = template.network.clone();
    c.level = template.level;
    c.elevation_m = template.elevation_m;
    c.direction = Some(Direction::Axis(axis));
    c.role = match template.role {
        Role::Unknown => Role::Unknown,
        r => r,
    };
    c.start_ns = template.start_ns;
    c.position_m = reference;
    c.combines = combines;
    c.inferred.push(how);
    Record::new(c, samples)
}

/// A floor's combination: translations with the sensors used (indices into
/// the sensor list), the sensors flagged, and what was done.
struct Combined {
    method: &'static str,
    reference: Option<[f64; 2]>,
    translations: Vec<(Axis, Vec<f64>, Vec<usize>)>,
    disagreeing: Vec<(usize, f64)>,
    peak_rotation: Option<f64>,
    note: String,
}

/// Least-squares rigid-floor fit (module doc); `None` when the sensors do
/// not determine the rotation (fewer than 3, no sensor in a direction, or
/// every lever arm alike), in which case the mean is used.
fn least_squares_floor(
    sensors: &[Sensor],
    positions: &[[f64; 2]],
    centre: Option<[f64; 2]>,
    settings: &FloorSettings,
) -> Option<Combined> {
    let n = sensors.len();
    let reference = centre.unwrap_or_else(|| {
        let (sx, sy) = positions
            .iter()
            .fold((0.0, 0.0), |(x, y), p| (x + p[0], y + p[1]));
        [sx / n as f64, sy / n as f64]
    });
    let row = |k: usize| -> Vector3<f64> {
        let [x, y] = positions[k];
        match sensors[k].axis {
            Axis::X => Vector3::new(1.0, 0.0, -(y - reference[1])),
            _ => Vector3::new(0.0, 1.0, x - reference[0]),
        }
    };
    let len = sensors[0].si.len();
    let mut active: Vec<usize> = (0..n).collect();
    let mut disagreeing = Vec::new();
    let mut bulk_done = false;
    loop {
        let normal: Matrix3<f64> = active.iter().map(|&k| row(k) * row(k).transpose()).sum();
        // Scale-aware rank test: lever arms in metres, translations unitless.
        let scale = normal.diagonal().max().max(1.0);
        if active.len() < 3 || normal.determinant().abs() <= 1e-9 * scale.powi(3) {
            return None;
        }
        let inverse = normal.try_inverse()?;
        let rows: Vec<Vector3<f64>> = active.iter().map(|&k| row(k)).collect();
        let mut solution = vec![Vector3::zeros(); len];
        for (t, sol) in solution.iter_mut().enumerate() {
            let rhs: Vector3<f64> = rows
                .iter()
                .zip(&active)
                .map(|(r, &k)| r * sensors[k].si[t])
                .sum();
            *sol = inverse * rhs;
        }
        let misfit: Vec<(usize, f64)> = rows
            .iter()
            .zip(&active)
            .map(|(r, &k)| {
                let own = rms(sensors[k].si.iter().copied()).max(f64::MIN_POSITIVE);
                let res = rms((0..len).map(|t| sensors[k].si[t] - r.dot(&solution[t])));
                (k, res / own)
            })
            .collect();
        let worst = misfit
            .iter()
            .copied()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .filter(|w| w.1 > settings.disagreement_ratio);
        if let (Some((k, ratio)), true, false) = (worst, active.len() > 3, bulk_done) {
            if disagreeing.len() < MAX_WORST_FIRST {
                disagreeing.push((k, ratio));
                active.retain(|&a| a != k);
                continue;
            }
            // Many disagree: the rest above the ratio together, keeping
            // the system determined (the best three at least).
            let mut above: Vec<(usize, f64)> = misfit
                .iter()
                .copied()
                .filter(|m| m.1 > settings.disagreement_ratio)
                .collect();
            above.sort_by(|a, b| b.1.total_cmp(&a.1));
            above.truncate(active.len() - 3);
            let out: std::collections::HashSet<usize> = above.iter().map(|m| m.0).collect();
            active.retain(|a| !out.contains(a));
            disagreeing.extend(above);
            bulk_done = true; // one more solve without them, then done
            continue;
        }
        let note = if active.len() == 3 {
            "three sensors determine the floor motion exactly: no redundancy to check them against each other".to_string()
        } else {
            format!(
                "{} sensors, largest misfit {:.0} % of a sensor's RMS",
                active.len(),
                100.0 * misfit.iter().map(|m| m.1).fold(0.0, f64::max)
            )
        };
        let used = |axis: Axis| -> Vec<usize> {
            active
                .iter()
                .copied()
                .filter(|&k| sensors[k].axis == axis)
                .collect()
        };
        return Some(Combined {
            method: "rigid_floor_least_squares",
            reference: Some(reference),
            translations: vec![
                (
                    Axis::X,
                    solution.iter().map(|s| s[0]).collect(),
                    used(Axis::X),
                ),
                (
                    Axis::Y,
                    solution.iter().map(|s| s[1]).collect(),
                    used(Axis::Y),
                ),
            ]
            .into_iter()
            .filter(|(_, _, u)| !u.is_empty())
            .collect(),
            disagreeing,
            peak_rotation: Some(solution.iter().map(|s| s[2].abs()).fold(0.0, f64::max)),
            note,
        });
    }
}

/// Mean of the channels per direction (module doc), for directions with
/// two or more channels.
fn mean_floor(sensors: &[Sensor], settings: &FloorSettings) -> Combined {
    let len = sensors[0].si.len();
    let sum_of = |ks: &[usize]| -> Vec<f64> {
        let mut total = vec![0.0; len];
        for &k in ks {
            for (s, v) in total.iter_mut().zip(&sensors[k].si) {
                *s += v;
            }
        }
        total
    };
    let mean_of = |ks: &[usize]| -> Vec<f64> {
        let n = ks.len() as f64;
        sum_of(ks).into_iter().map(|s| s / n).collect()
    };
    let mut translations = Vec::new();
    let mut disagreeing = Vec::new();
    let mut notes = Vec::new();
    for axis in [Axis::X, Axis::Y] {
        let mut active: Vec<usize> = (0..sensors.len())
            .filter(|&k| sensors[k].axis == axis)
            .collect();
        if active.len() < 2 {
            continue;
        }
        // Misfit of each channel against the mean of the others (the
        // total less its own: one pass over the channels, not one each).
        let misfits = |active: &[usize]| -> Vec<(usize, f64)> {
            let total = sum_of(active);
            let others = (active.len() - 1) as f64;
            active
                .iter()
                .map(|&k| {
                    let own = &sensors[k].si;
                    let m = |t: usize| (total[t] - own[t]) / others;
                    let scale = rms((0..len).map(m)).max(f64::MIN_POSITIVE);
                    (k, rms((0..len).map(|t| own[t] - m(t))) / scale)
                })
                .collect()
        };
        let mut left_out = 0usize;
        loop {
            let m = misfits(&active);
            let worst = m.iter().copied().max_by(|a, b| a.1.total_cmp(&b.1));
            match worst {
                Some((k, r)) if r > settings.disagreement_ratio && active.len() > 2 => {
                    if left_out < MAX_WORST_FIRST {
                        disagreeing.push((k, r));
                        active.retain(|&a| a != k);
                        left_out += 1;
                        continue;
                    }
                    // Many disagree: the rest above the ratio together,
                    // keeping the two that agree best.
                    let mut above: Vec<(usize, f64)> = m
                        .iter()
                        .copied()
                        .filter(|x| x.1 > settings.disagreement_ratio)
                        .collect();
                    above.sort_by(|a, b| b.1.total_cmp(&a.1));
                    above.truncate(active.len() - 2);
                    let out: std::collections::HashSet<usize> = above.iter().map(|x| x.0).collect();
                    active.retain(|a| !out.contains(a));
                    disagreeing.extend(above);
                    break;
                }
                Some((_, r)) if r > settings.disagreement_ratio => {
                    // Two channels that disagree: neither can be blamed.
                    disagreeing.extend(m.iter().copied());
                    notes.push(format!(
                        "{axis:?}: the two channels disagree by {:.0} % (torsion or a local mode); their mean is kept — give position_m to resolve the floor rotation",
                        100.0 * r
                    ));
                    break;
                }
                _ => break,
            }
        }
        translations.push((axis, mean_of(&active), active));
    }
    Combined {
        method: "mean",
        reference: None,
        translations,
        disagreeing,
        peak_rotation: None,
        note: if notes.is_empty() {
            "mean of the channels in each direction (no plan positions: exact at the centre of mass for sensors placed symmetrically about it)".into()
        } else {
            notes.join("; ")
        },
    }
}
