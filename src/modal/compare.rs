//! Pre/post comparison of two events of the same structure (issue 13): the
//! modes of a reference (earlier) event paired with this event's on the
//! channels both share, and the frequency shift of each pair with its
//! uncertainty, a damage indicator (a drop = stiffness loss).
//!
//! Pairing (deterministic, greedy one-to-one, best candidate first):
//! - shapes are given at channel ids (`quaketwin.output_channels`); both are
//!   restricted to the ids both events share, in the reference's order, and
//!   renormalised (largest component 1);
//! - with at least [`MIN_SHARED_FOR_MAC`] shared channels a pair needs
//!   MAC ≥ `min_mac` AND |f − f_ref|/f_ref ≤ `frequency_window`; candidates
//!   are taken by decreasing MAC (ties: smaller |Δf|, then smaller indices).
//!   with `min_mac_same_direction` set (a structure's history), two modes
//!   with the same known direction label pair from that lower MAC on.
//!   A mode holding less than [`MIN_SHARED_ENERGY`] of its shape's energy on
//!   the shared channels is not paired (its MAC there would be noise);
//! - with fewer shared channels a MAC says nothing (one component: always 1),
//!   so a pair needs the frequency window and the same direction label
//!   (`direction` of modes/modes.parquet); candidates are taken by increasing |Δf|.
//!
//! Shift and uncertainty: s = (f − f_ref)/f_ref; with the two frequency
//! standard deviations σ, σ_ref (independent estimates), first-order
//! propagation gives σ_s = √((σ/f_ref)² + (f σ_ref/f_ref²)²).  A shift is
//! significant when |s| > k σ_s, k = Student's t_{0.975, ν} with ν the
//! Welch–Satterthwaite degrees of freedom of σ_s from those of the
//! data-driven σ (Eq. S8' of docs/statistics.md; an order-spread σ counts
//! as known exactly), k = 2 when neither σ is data-driven; unknown (None)
//! when both σ are zero.
//! Each σ is the mode's data-driven standard deviation
//! (`frequency_std_data_hz` of modes/modes.parquet, issue 36: the statistical
//! error of that record's estimate, docs/statistics.md) when it was
//! computed; otherwise the order spread `frequency_std_hz` taken at least
//! `frequency_std_floor` × f: the scatter of the poles over the model
//! orders of one record understates the statistical error of the estimate
//! (the sample building identified from its quake and from its ambient
//! record: order scatter 1e-5–0.2 %, the two records' frequencies 0.1–0.3 %
//! apart; 20 synthetic 600-s ambient records: std of Δf/f 0.11–0.19 %).
//! The two σ are combined as independent whatever their kind (two records,
//! two estimates); `shift_std_basis` says which kind entered: `data`
//! (both), `order_spread` (neither) or `mixed`.

use super::poles::{mac, normalise_shape};
use super::selection::Mode;
use faer::c64;

/// Fewest shared channels for pairing by MAC.
pub const MIN_SHARED_FOR_MAC: usize = 2;
/// Least share of a shape's energy Σ|φ_k|² on the shared channels for the
/// mode to be paired by MAC.
pub const MIN_SHARED_ENERGY: f64 = 0.05;

/// MAC matrix: `result[i][j]` = MAC(a_i, b_j).  Shapes must refer to the
/// same channels in the same order (shorter vectors are compared on the common prefix).
pub fn mac_matrix(a: &[Vec<c64>], b: &[Vec<c64>]) -> Vec<Vec<f64>> {
    a.iter()
        .map(|x| b.iter().map(|y| mac(x, y)).collect())
        .collect()
}

/// A pair of matched modes.
#[derive(Debug, Clone, PartialEq)]
pub struct ModePair {
    /// Index in the first (reference, e.g. pre-event) set.
    pub reference: usize,
    /// Index in the second (e.g. post-event) set.
    pub other: usize,
    pub mac: f64,
}

/// Greedy one-to-one assignment: `candidates` (i, j, score) sorted best
/// first by the caller; a candidate is taken when neither of its modes is
/// taken yet.  Returns the pairs taken, by `i`.
fn assign(candidates: &[(usize, usize, f64)], n_a: usize, n_b: usize) -> Vec<(usize, usize, f64)> {
    let (mut used_a, mut used_b) = (vec![false; n_a], vec![false; n_b]);
    let mut taken = Vec::new();
    for &(i, j, v) in candidates {
        if !used_a[i] && !used_b[j] {
            used_a[i] = true;
            used_b[j] = true;
            taken.push((i, j, v));
        }
    }
    taken.sort_by_key(|p| p.0);
    taken
}

/// Greedy pairing by decreasing MAC (ties broken by the smaller indices)
/// of every pair reaching `min_mac`.  Greedy rather than the Hungarian
/// assignment because mode sets are small and a high-MAC pair is almost
/// never worth sacrificing for the global sum.
pub fn pair_modes(a: &[Vec<c64>], b: &[Vec<c64>], min_mac: f64) -> Vec<ModePair> {
    let mut candidates: Vec<(usize, usize, f64)> = mac_matrix(a, b)
        .iter()
        .enumerate()
        .flat_map(|(i, row)| row.iter().enumerate().map(move |(j, &v)| (i, j, v)))
        .filter(|c| c.2 >= min_mac)
        .collect();
    candidates.sort_by(|x, y| y.2.total_cmp(&x.2).then(x.0.cmp(&y.0)).then(x.1.cmp(&y.1)));
    assign(&candidates, a.len(), b.len())
        .into_iter()
        .map(|(reference, other, mac)| ModePair {
            reference,
            other,
            mac,
        })
        .collect()
}

/// Settings of the pre/post pairing (the `modal` stage's
/// `reference_min_mac` and `reference_frequency_window`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PairingSettings {
    /// Least MAC of a pair on the shared channels.
    pub min_mac: f64,
    /// Largest |f − f_ref| / f_ref of a pair.
    pub frequency_window: f64,
    /// Least relative standard deviation of each frequency in the shift's
    /// uncertainty (module doc); 0 = the modes' `frequency_std_hz` alone.
    pub frequency_std_floor: f64,
    /// Least MAC of a pair whose two modes carry the same (known) direction
    /// label, when lower than `min_mac`; `None` (the pre/post comparison):
    /// `min_mac` for every pair.  A structure's history sets it (module doc
    /// of `crate::history`): across decades a mode's shape departs from
    /// itself (strong shaking softens one support more than another; a new
    /// recorder generation reverses a channel's polarity) while its
    /// direction stays.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_mac_same_direction: Option<f64>,
}

impl Default for PairingSettings {
    fn default() -> Self {
        PairingSettings {
            min_mac: 0.8,
            frequency_window: 0.2,
            frequency_std_floor: 0.002,
            min_mac_same_direction: None,
        }
    }
}

/// One event's modes and the channel ids their shapes are given at.
#[derive(Debug, Clone, Copy)]
pub struct ModeSet<'a> {
    pub modes: &'a [Mode],
    pub channels: &'a [String],
}

/// What the pairing of a comparison was based on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PairingBasis {
    /// MAC on the shared channels and the frequency window.
    MacAndFrequency,
    /// Fewer than [`MIN_SHARED_FOR_MAC`] shared channels: the frequency
    /// window and the direction label.
    FrequencyAndDirection,
}

impl PairingBasis {
    /// The name written to `frequency_shifts/frequency_shifts.parquet` (`pairing`).
    pub fn name(self) -> &'static str {
        match self {
            PairingBasis::MacAndFrequency => "mac_and_frequency",
            PairingBasis::FrequencyAndDirection => "frequency_and_direction",
        }
    }
}

/// Frequency and damping change of one paired mode between two events.
#[derive(Debug, Clone, PartialEq)]
pub struct FrequencyShift {
    /// Index in the reference set.
    pub reference_mode: usize,
    /// Index in this (current) event's set.
    pub current_mode: usize,
    pub direction_reference: String,
    pub direction_current: String,
    pub frequency_reference_hz: f64,
    pub frequency_reference_std_hz: f64,
    pub frequency_current_hz: f64,
    pub frequency_current_std_hz: f64,
    /// 100 (f − f_ref)/f_ref; a drop (negative) indicates stiffness loss.
    pub shift_percent: f64,
    /// Its standard deviation (module doc: the data-driven σ of each state
    /// when known, else its order spread with the floor), %.
    pub shift_std_percent: f64,
    /// Data-driven σ of each frequency (`frequency_std_data_hz`), when known.
    pub frequency_reference_std_data_hz: Option<f64>,
    pub frequency_current_std_data_hz: Option<f64>,
    /// Which σ entered `shift_std_percent`: `data`, `order_spread` or `mixed`.
    pub shift_std_basis: &'static str,
    /// Welch–Satterthwaite degrees of freedom of `shift_std_percent`;
    /// None when no data-driven σ entered it.
    pub shift_dof: Option<f64>,
    /// |shift| > t_{0.975, shift_dof} σ (2σ without `shift_dof`); None
    /// when the uncertainty is unknown (both σ zero).
    pub significant: Option<bool>,
    pub damping_reference: f64,
    pub damping_current: f64,
    /// MAC on the shared channels; None when paired by frequency and direction.
    pub mac: Option<f64>,
}

/// The pre/post comparison of two events.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// Channel ids both events share, in the reference's order.
    pub shared_channels: Vec<String>,
    pub basis: PairingBasis,
    /// One per pair, by reference mode.
    pub shifts: Vec<FrequencyShift>,
    /// Channels only one event has, modes left unpaired and why.
    pub notes: Vec<String>,
}

/// Relative shift (f − f_ref)/f_ref and its standard deviation from the two
/// frequency standard deviations (module doc).
pub fn relative_shift(f_ref: f64, sd_ref: f64, f: f64, sd: f64) -> (f64, f64) {
    let s = (f - f_ref) / f_ref;
    let sd_s = ((sd / f_ref).powi(2) + (f * sd_ref / (f_ref * f_ref)).powi(2)).sqrt();
    (s, sd_s)
}

/// Welch–Satterthwaite degrees of freedom of a sum of two independent
/// variances a² + b², each term (its standard deviation, its mode): ν =
/// (a² + b²)² / (a⁴/ν_a + b⁴/ν_b), ν of a data-driven σ its
/// [`super::uncertainty::ModeStd::dof`], an order-spread σ taken as known
/// (ν = ∞, no term).  None when neither is data-driven, or when a
/// data-driven σ's ν is not known (a table of a run before Eq. S8' without
/// its blocks): then the 2 σ of before.
fn shift_dof((a, ra): (f64, &Mode), (b, rb): (f64, &Mode)) -> Option<f64> {
    let term = |x: f64, m: &Mode| m.data_std.as_ref().map(|d| x.powi(4) / d.dof);
    let (ta, tb) = (term(a, ra), term(b, rb));
    let known = |t: Option<f64>| t.is_none_or(|t| t.is_finite() && t >= 0.0);
    if (ta.is_none() && tb.is_none()) || !known(ta) || !known(tb) {
        return None;
    }
    let denominator = ta.unwrap_or(0.0) + tb.unwrap_or(0.0);
    let dof = (a * a + b * b).powi(2) / denominator;
    dof.is_finite().then_some(dof)
}

/// `shape` at `indices`, renormalised (largest component 1), and the share
/// of the shape's energy those components hold.
fn restrict(shape: &[c64], indices: &[usize]) -> (Vec<c64>, f64) {
    let total: f64 = shape.iter().map(|z| z.norm_sqr()).sum();
    let mut part: Vec<c64> = indices
        .iter()
        .map(|&k| shape.get(k).copied().unwrap_or(c64::new(0.0, 0.0)))
        .collect();
    let kept: f64 = part.iter().map(|z| z.norm_sqr()).sum();
    normalise_shape(&mut part);
    (part, if total > 0.0 { kept / total } else { 0.0 })
}

fn describe(m: &Mode, index: usize) -> String {
    let dir = if m.direction.is_empty() {
        String::new()
    } else {
        format!(", {}", m.direction)
    };
    format!("mode {} ({:.4} Hz{dir})", index + 1, m.frequency_hz)
}

/// One admissible pair of a comparison: reference mode `reference`,
/// current mode `current`, its score (higher is better: the MAC, or −|Δf|/f
/// when paired by frequency and direction), its MAC and |Δf|/f_ref.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Candidate {
    reference: usize,
    current: usize,
    score: f64,
    mac: Option<f64>,
    window: f64,
}

/// Best candidate first: higher score, then smaller |Δf|/f, then smaller
/// indices (deterministic).
fn best_first(x: &Candidate, y: &Candidate) -> std::cmp::Ordering {
    y.score
        .total_cmp(&x.score)
        .then(x.window.total_cmp(&y.window))
        .then(x.reference.cmp(&y.reference))
        .then(x.current.cmp(&y.current))
}

/// Every admissible pair of two events' modes under the module's rule,
/// best first; the shared channels (indices into reference, current), the
/// basis, and notes on channels only one side has and modes left out.
struct Candidates {
    shared: Vec<(usize, usize)>,
    basis: PairingBasis,
    list: Vec<Candidate>,
    notes: Vec<String>,
}

fn candidates(reference: ModeSet, current: ModeSet, settings: &PairingSettings) -> Candidates {
    let mut notes = Vec::new();
    let shared: Vec<(usize, usize)> = reference
        .channels
        .iter()
        .enumerate()
        .filter_map(|(a, id)| {
            current
                .channels
                .iter()
                .position(|c| c == id)
                .map(|b| (a, b))
        })
        .collect();
    let only = |of: &[String], other: &[String]| -> Vec<String> {
        of.iter().filter(|c| !other.contains(c)).cloned().collect()
    };
    for (who, ids) in [
        ("the reference", only(reference.channels, current.channels)),
        ("this event", only(current.channels, reference.channels)),
    ] {
        if !ids.is_empty() {
            notes.push(format!(
                "channels only in {who} (left out of the shapes): {}",
                ids.join(", ")
            ));
        }
    }
    let (ra, rb) = (reference.modes, current.modes);
    let window = |i: usize, j: usize| {
        let f_ref = ra[i].frequency_hz;
        ((rb[j].frequency_hz - f_ref) / f_ref).abs()
    };
    let in_window = |i, j| window(i, j) <= settings.frequency_window;
    let basis = if shared.len() >= MIN_SHARED_FOR_MAC {
        PairingBasis::MacAndFrequency
    } else {
        notes.push(format!(
            "{} shared channel(s): mode shapes cannot be compared, modes paired by frequency (within {} %) and direction label only",
            shared.len(),
            100.0 * settings.frequency_window
        ));
        PairingBasis::FrequencyAndDirection
    };
    let mut list: Vec<Candidate> = Vec::new();
    match basis {
        PairingBasis::MacAndFrequency => {
            let (ia, ib): (Vec<usize>, Vec<usize>) = shared.iter().copied().unzip();
            let a: Vec<(Vec<c64>, f64)> = ra.iter().map(|m| restrict(&m.shape, &ia)).collect();
            let b: Vec<(Vec<c64>, f64)> = rb.iter().map(|m| restrict(&m.shape, &ib)).collect();
            for (set, modes, shapes) in [("reference", ra, &a), ("this event's", rb, &b)] {
                for (k, (_, share)) in shapes.iter().enumerate() {
                    if *share < MIN_SHARED_ENERGY {
                        notes.push(format!(
                            "{set} {} holds {:.1} % of its shape on the shared channels: not paired",
                            describe(&modes[k], k),
                            100.0 * share
                        ));
                    }
                }
            }
            for i in 0..ra.len() {
                for j in 0..rb.len() {
                    if a[i].1 < MIN_SHARED_ENERGY || b[j].1 < MIN_SHARED_ENERGY {
                        continue;
                    }
                    let m = mac(&a[i].0, &b[j].0);
                    let least = match settings.min_mac_same_direction {
                        Some(v)
                            if !ra[i].direction.is_empty()
                                && ra[i].direction == rb[j].direction =>
                        {
                            v.min(settings.min_mac)
                        }
                        _ => settings.min_mac,
                    };
                    if m >= least && in_window(i, j) {
                        list.push(Candidate {
                            reference: i,
                            current: j,
                            score: m,
                            mac: Some(m),
                            window: window(i, j),
                        });
                    }
                }
            }
        }
        PairingBasis::FrequencyAndDirection => {
            for i in 0..ra.len() {
                for j in 0..rb.len() {
                    if ra[i].direction == rb[j].direction && in_window(i, j) {
                        list.push(Candidate {
                            reference: i,
                            current: j,
                            score: -window(i, j),
                            mac: None,
                            window: window(i, j),
                        });
                    }
                }
            }
        }
    }
    list.sort_by(best_first);
    Candidates {
        shared,
        basis,
        list,
        notes,
    }
}

/// Pairs the modes of `reference` and `current` on their shared channels
/// and reports the frequency shifts (module doc).
pub fn compare_events(
    reference: ModeSet,
    current: ModeSet,
    settings: &PairingSettings,
) -> Comparison {
    let Candidates {
        shared,
        basis,
        list: candidates,
        mut notes,
    } = candidates(reference, current, settings);
    let shared_channels: Vec<String> = shared
        .iter()
        .map(|&(a, _)| reference.channels[a].clone())
        .collect();
    let (ra, rb) = (reference.modes, current.modes);
    if ra.is_empty() {
        notes.push(
            "the reference run identified no mode (its modes/modes.parquet warnings say why)"
                .into(),
        );
    }
    if rb.is_empty() {
        notes.push(
            "this event's identification found no mode (modes/modes.parquet warnings say why)"
                .into(),
        );
    }
    let scored: Vec<(usize, usize, f64)> = candidates
        .iter()
        .map(|c| (c.reference, c.current, c.score))
        .collect();
    let taken = assign(&scored, ra.len(), rb.len());
    let mac_of = |i: usize, j: usize| {
        candidates
            .iter()
            .find(|c| c.reference == i && c.current == j)
            .and_then(|c| c.mac)
    };
    let shifts: Vec<FrequencyShift> = taken
        .iter()
        .map(|&(i, j, _)| shift((&ra[i], i), (&rb[j], j), mac_of(i, j), settings))
        .collect();
    let why = match basis {
        PairingBasis::MacAndFrequency => format!(
            "no mode within {} % with MAC ≥ {} on the {} shared channels",
            100.0 * settings.frequency_window,
            settings.min_mac,
            shared.len()
        ),
        PairingBasis::FrequencyAndDirection => format!(
            "no mode of the same direction within {} %",
            100.0 * settings.frequency_window
        ),
    };
    // (When one side has no mode at all, its note above says why.)
    for (i, m) in ra.iter().enumerate().filter(|_| !rb.is_empty()) {
        if !taken.iter().any(|p| p.0 == i) {
            notes.push(format!(
                "reference {} not found in this event: {why}",
                describe(m, i)
            ));
        }
    }
    for (j, m) in rb.iter().enumerate().filter(|_| !ra.is_empty()) {
        if !taken.iter().any(|p| p.1 == j) {
            notes.push(format!(
                "this event's {} has no partner in the reference: {why}",
                describe(m, j)
            ));
        }
    }
    Comparison {
        shared_channels,
        basis,
        shifts,
        notes,
    }
}

/// One event's mode in a [`ModeTrack`].
#[derive(Debug, Clone, PartialEq)]
pub struct TrackMember {
    /// Index of the event (into the sets given to [`track_across_events`]).
    pub event: usize,
    /// Index of the mode in that event's set.
    pub mode: usize,
    /// The earlier member it was paired with (event, mode); `None` for the
    /// member that opened the track.
    pub paired_with: Option<(usize, usize)>,
    /// MAC to that member on the channels the two events share; `None`
    /// when it opened the track or was paired by frequency and direction.
    pub mac: Option<f64>,
}

/// One mode followed across N events: its members in event order.
#[derive(Debug, Clone, PartialEq)]
pub struct ModeTrack {
    pub members: Vec<TrackMember>,
    /// The direction label most of its members carry (ties: the earliest
    /// member's; empty labels count only when no member has another).
    pub direction: String,
}

/// The pre/post pairing generalised to N events (issue 35): the events are
/// taken in the order given (the caller's: by date, so that a growing
/// history keeps its ids); the first event's modes open one track each;
/// every later event's modes are paired with the tracks built so far, one
/// to one, by the rule of [`compare_events`] applied between the new
/// event and each earlier event that holds a member of a track (shapes on
/// the channels the two events share, MAC ≥ `min_mac` within the frequency
/// window, or frequency and direction below two shared channels).  A
/// track's score for a new mode is that of its best-scoring member, so a
/// mode is followed even when its frequency wanders from event to event
/// (amplitude dependence) or when one event shares few channels with
/// another; candidates are taken greedily, best first, as in the pre/post
/// pairing.  A mode no track takes opens a new one.  Tracks are returned in
/// the order they were opened (the track id is that rank + 1).
pub fn track_across_events(sets: &[ModeSet], settings: &PairingSettings) -> Vec<ModeTrack> {
    let mut tracks: Vec<ModeTrack> = Vec::new();
    // Track of each (event, mode) already placed.
    let mut track_of: std::collections::BTreeMap<(usize, usize), usize> = Default::default();
    for (new, set) in sets.iter().enumerate() {
        // (track, new mode) → the best candidate over the track's members.
        let mut best: std::collections::BTreeMap<(usize, usize), (Candidate, (usize, usize))> =
            Default::default();
        for earlier in 0..new {
            if !track_of.keys().any(|&(e, _)| e == earlier) {
                continue;
            }
            for c in candidates(sets[earlier], *set, settings).list {
                let Some(&t) = track_of.get(&(earlier, c.reference)) else {
                    continue;
                };
                let entry = best.entry((t, c.current));
                let better = |old: &(Candidate, (usize, usize))| {
                    best_first(&c, &old.0) == std::cmp::Ordering::Less
                };
                match entry {
                    std::collections::btree_map::Entry::Vacant(v) => {
                        v.insert((c, (earlier, c.reference)));
                    }
                    std::collections::btree_map::Entry::Occupied(mut o) => {
                        if better(o.get()) {
                            o.insert((c, (earlier, c.reference)));
                        }
                    }
                }
            }
        }
        // One greedy assignment of tracks to this event's modes.
        let mut scored: Vec<(Candidate, usize, (usize, usize))> = best
            .into_iter()
            .map(|((t, _), (c, member))| (Candidate { reference: t, ..c }, t, member))
            .collect();
        scored.sort_by(|x, y| best_first(&x.0, &y.0));
        let list: Vec<(usize, usize, f64)> = scored
            .iter()
            .map(|(c, t, _)| (*t, c.current, c.score))
            .collect();
        let taken = assign(&list, tracks.len(), set.modes.len());
        for j in 0..set.modes.len() {
            let member = match taken.iter().find(|p| p.1 == j) {
                Some(&(t, _, _)) => {
                    let (c, _, with) = scored
                        .iter()
                        .find(|(c, tt, _)| *tt == t && c.current == j)
                        .copied()
                        .expect("a taken pair is a candidate"); // ok: `taken` ⊆ `list`
                    tracks[t].members.push(TrackMember {
                        event: new,
                        mode: j,
                        paired_with: Some(with),
                        mac: c.mac,
                    });
                    t
                }
                None => {
                    tracks.push(ModeTrack {
                        members: vec![TrackMember {
                            event: new,
                            mode: j,
                            paired_with: None,
                            mac: None,
                        }],
                        direction: String::new(),
                    });
                    tracks.len() - 1
                }
            };
            track_of.insert((new, j), member);
        }
    }
    for t in &mut tracks {
        t.direction = majority_direction(
            t.members
                .iter()
                .map(|m| sets[m.event].modes[m.mode].direction.as_str()),
        );
    }
    tracks
}

/// The label most of `labels` carry (ties: the earliest); empty labels
/// count only when all are empty.
fn majority_direction<'a>(labels: impl Iterator<Item = &'a str>) -> String {
    let mut counts: Vec<(&str, usize)> = Vec::new();
    for l in labels.filter(|l| !l.is_empty()) {
        match counts.iter_mut().find(|(k, _)| *k == l) {
            Some(c) => c.1 += 1,
            None => counts.push((l, 1)),
        }
    }
    // max_by_key keeps the last maximum: scan in reverse for the earliest.
    counts
        .iter()
        .rev()
        .max_by_key(|(_, n)| *n)
        .map(|(l, _)| l.to_string())
        .unwrap_or_default()
}

fn shift(
    (r, i): (&Mode, usize),
    (c, j): (&Mode, usize),
    mac: Option<f64>,
    settings: &PairingSettings,
) -> FrequencyShift {
    let data = |m: &Mode| m.data_std.as_ref().map(|d| d.frequency_hz);
    let sigma = |m: &Mode| {
        data(m).unwrap_or_else(|| {
            m.frequency_std_hz
                .max(settings.frequency_std_floor * m.frequency_hz)
        })
    };
    let (s, sd) = relative_shift(r.frequency_hz, sigma(r), c.frequency_hz, sigma(c));
    let dof = shift_dof(
        (c.frequency_hz * sigma(r) / r.frequency_hz.powi(2), r),
        (sigma(c) / r.frequency_hz, c),
    );
    let factor = dof.map_or(2.0, super::uncertainty::interval_factor);
    let basis = match (data(r).is_some(), data(c).is_some()) {
        (true, true) => "data",
        (false, false) => "order_spread",
        _ => "mixed",
    };
    FrequencyShift {
        reference_mode: i,
        current_mode: j,
        direction_reference: r.direction.clone(),
        direction_current: c.direction.clone(),
        frequency_reference_hz: r.frequency_hz,
        frequency_reference_std_hz: r.frequency_std_hz,
        frequency_current_hz: c.frequency_hz,
        frequency_current_std_hz: c.frequency_std_hz,
        shift_percent: 100.0 * s,
        shift_std_percent: 100.0 * sd,
        frequency_reference_std_data_hz: data(r),
        frequency_current_std_data_hz: data(c),
        shift_std_basis: basis,
        shift_dof: dof,
        significant: (sd.is_finite() && sd > 0.0 && factor.is_finite())
            .then(|| s.abs() > factor * sd),
        damping_reference: r.damping_ratio,
        damping_current: c.damping_ratio,
        mac,
    }
}
