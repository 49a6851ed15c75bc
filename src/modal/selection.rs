//! Automatic mode selection from the stabilisation diagram (METHODS §2):
//! pole COLUMNS followed across consecutive model orders, physical filters,
//! one mode per accepted column with statistics over its best-converged
//! part; and the manual override.
//!
//! Why columns rather than clusters over all orders (issue 13): a physical
//! mode appears at some model order and then stays, with the same frequency
//! and shape, at every higher order; weakly excited modes (torsion, higher
//! modes of short records) appear only at high orders.  Requiring a fixed
//! fraction of ALL orders swept (the former rule) discarded them.  A column
//! is therefore judged on its own span:
//! - linking: the pole of order n continues the column ending at order
//!   n − 1 (or up to `max_gap` realised orders earlier) when
//!   |Δf|/f ≤ max(`link_frequency`, ζ/2) (capped at `link_frequency_max`,
//!   see [`mode_tolerance`]) and MAC ≥ `link_mac` with the column's last pole
//!   (greedy one-to-one assignment, best match first);
//! - a column is a mode when it holds at least `min_poles` poles,
//!   `min_order_fraction` of the realised orders (default 0) and
//!   `min_relative_length` of the poles of the longest coherent, mostly
//!   physical column (default 60 %: a column's length depends on the record,
//!   not on the number of orders) unless it holds `long_enough_poles` (12),
//!   holds a
//!   pole at ≥ `min_persistence` of the realised orders from its first order
//!   to the highest order swept (a physical pole, once present, persists;
//!   noise poles come and go), its shapes are coherent (mean MAC with the
//!   column's mean shape ≥ `min_coherence`), at least `min_physical_fraction`
//!   of its poles pass the physical filters, and its estimate passes them;
//! - two accepted columns of the same mode ([`same_mode`]) are a split twin:
//!   the longer is kept, rejoined with the twin's poles of the mode (one
//!   per order, nearest its median frequency: [`rejoin_twin`]), the other
//!   reported;
//! - columns of the same mode broken by a gap (frequencies within
//!   `merge_frequency_tolerance`, MAC ≥ `merge_mac` of mean shapes) are merged
//!   first, one pole per order kept; so are mostly physical pieces of one
//!   column broken by frequency jumps (poles of different orders only, within
//!   `merge_disjoint_tolerance`, MAC ≥ `merge_mac`: [`pieces_of_one_column`]);
//! - the estimate (f, ζ, shape and their scatter) is taken over the poles in
//!   the upper `converged_fraction` of the column's orders: low orders bias
//!   damped modes (a model too small to separate them from the noise).
//!
//! Columns that look physical but fail a criterion are returned as
//! [`RejectedColumn`]s so the caller can say why fewer modes were selected.

use super::poles::{mac, mpc_mpd, normalise_shape, Pole};
use crate::error::{Error, Result};
use faer::c64;

/// Physical-mode filters.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PhysicalFilters {
    /// Damping window [min, max] (default 0.5–10 %; the thesis, METHODS §2, used 0.9–5.5 % for a masonry building).
    pub damping_min: f64,
    pub damping_max: f64,
    /// Minimum modal phase collinearity.
    pub mpc_min: f64,
    /// Maximum mean phase deviation, degrees.
    pub mpd_max_deg: f64,
    /// Band limits for the poles, Hz (`None` = the band of interest of the
    /// settings, else 0 to 0.95 × Nyquist).
    pub frequency_min_hz: Option<f64>,
    pub frequency_max_hz: Option<f64>,
}

impl Default for PhysicalFilters {
    fn default() -> Self {
        PhysicalFilters {
            damping_min: 0.005,
            damping_max: 0.10,
            mpc_min: 0.8,
            mpd_max_deg: 20.0,
            frequency_min_hz: None,
            frequency_max_hz: None,
        }
    }
}

impl PhysicalFilters {
    pub fn passes(&self, pole: &Pole, nyquist_hz: f64) -> bool {
        self.in_band(pole.frequency_hz, nyquist_hz)
            && (self.damping_min..=self.damping_max).contains(&pole.damping_ratio)
            && pole.mpc >= self.mpc_min
            && pole.mpd_deg <= self.mpd_max_deg
    }
    pub fn in_band(&self, frequency_hz: f64, nyquist_hz: f64) -> bool {
        let f_min = self.frequency_min_hz.unwrap_or(0.0);
        let f_max = self.frequency_max_hz.unwrap_or(0.95 * nyquist_hz);
        (f_min..=f_max).contains(&frequency_hz)
    }
}

/// Settings of the automatic selection by pole columns (module doc).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SelectionSettings {
    /// Linking tolerance on |Δf|/f between consecutive poles of a column
    /// (lightly damped modes; widened to ζ/2 for damped ones, see `mode_tolerance`).
    pub link_frequency: f64,
    /// Upper bound of the damping-widened linking tolerance.
    #[serde(default = "default_link_frequency_max")]
    pub link_frequency_max: f64,
    /// Linking threshold on the MAC between consecutive poles of a column.
    pub link_mac: f64,
    /// Realised orders a column may skip and continue.
    pub max_gap: usize,
    /// Fewest poles of an accepted column.
    pub min_poles: usize,
    /// …and at least this fraction of the realised orders (the former
    /// clustering rule; default 0 since issue 13).  At 40 % it kept out the
    /// persistent spurious columns of 6–10 poles at orders ≥ 28 that
    /// SSI-COV/SSI-DATA find on the 600-s 5-storey ambient records, but also
    /// every mode of the short real bridge records; `min_relative_length`
    /// and the twin rule now keep the spurious columns out.
    pub min_order_fraction: f64,
    /// …and at least this fraction of the poles of the longest coherent,
    /// mostly physical column of the same diagram.
    #[serde(default = "default_min_relative_length")]
    pub min_relative_length: f64,
    /// …unless it holds at least this many poles: a column stable over this
    /// many orders is long enough whatever the longest column (the 12.4 Hz
    /// mode of the 5-storey earthquake, 12 poles over orders 12–34, was
    /// rejected next to a 21-pole fundamental).
    #[serde(default = "default_long_enough_poles")]
    pub long_enough_poles: usize,
    /// Fraction of the realised orders from the column's first order to the
    /// highest order swept at which the column must hold a pole.
    pub min_persistence: f64,
    /// Mean MAC between the column's poles and its mean shape.
    pub min_coherence: f64,
    /// Fraction of the column's poles that must pass the physical filters.
    pub min_physical_fraction: f64,
    /// Columns of one mode split by a gap: relative frequency difference and
    /// MAC of the mean shapes to merge them.
    pub merge_frequency_tolerance: f64,
    pub merge_mac: f64,
    /// Pieces of one column (poles of different orders only, see
    /// `pieces_of_one_column`): relative frequency difference to merge them.
    #[serde(default = "default_merge_disjoint_tolerance")]
    pub merge_disjoint_tolerance: f64,
    /// Upper fraction of the column's orders the estimate is taken over.
    pub converged_fraction: f64,
    /// A column shorter than the relative bar (`min_relative_length`,
    /// `long_enough_poles`) but of at least `min_poles` poles is kept when
    /// its shapes are this coherent across orders (mean MAC with the
    /// column's mean shape) and it holds a pole at
    /// `coherent_min_persistence` of the orders from its first to the
    /// highest (issue 31: the weakly excited torsion of a building, a column
    /// of 8 poles at the top orders, was rejected by the 12-pole rule).
    #[serde(default = "default_coherent_promotion_mac")]
    pub coherent_promotion_mac: f64,
    #[serde(default = "default_coherent_min_persistence")]
    pub coherent_min_persistence: f64,
}

/// 0.995 (issue 31: the weakly excited torsion of a building — the 7-storey
/// NSMP building's 8-pole torsion column — was rejected by the 12-pole
/// rule).  A column promoted this way is kept only when its shape is a
/// torsion (`modal::identify`: `direction::label` = "torsion"): the rule
/// alone promoted a spurious translational 9.64 Hz column on one of the
/// sixteen 600-s 5-storey ambient records (seed 108).
fn default_coherent_promotion_mac() -> f64 {
    0.995
}

/// A pole at every order from its first to the highest: the persistent
/// spurious columns of 6–10 poles at orders ≥ 28 of the 600-s 5-storey
/// ambient records come and go.
fn default_coherent_min_persistence() -> f64 {
    1.0
}

fn default_min_relative_length() -> f64 {
    0.6
}

fn default_long_enough_poles() -> usize {
    12
}

fn default_merge_disjoint_tolerance() -> f64 {
    0.03
}

fn default_link_frequency_max() -> f64 {
    0.05
}

impl Default for SelectionSettings {
    fn default() -> Self {
        SelectionSettings {
            link_frequency: 0.01,
            link_frequency_max: default_link_frequency_max(),
            link_mac: 0.98,
            max_gap: 0,
            min_poles: 5,
            min_order_fraction: 0.0,
            min_relative_length: default_min_relative_length(),
            long_enough_poles: default_long_enough_poles(),
            min_persistence: 0.5,
            min_coherence: 0.95,
            min_physical_fraction: 0.5,
            merge_frequency_tolerance: 0.01,
            merge_mac: 0.95,
            merge_disjoint_tolerance: default_merge_disjoint_tolerance(),
            converged_fraction: 0.5,
            coherent_promotion_mac: default_coherent_promotion_mac(),
            coherent_min_persistence: default_coherent_min_persistence(),
        }
    }
}

/// One identified mode: statistics over the poles of its column.
/// Serialisable (the shape as `[re, im]` pairs) so that identified windows
/// can cross between processes (`monitor::windows_to_json`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Mode {
    pub frequency_hz: f64,
    /// Standard deviation of the frequency over the poles of the column's
    /// converged part (the order spread: a quality figure of the column,
    /// not the statistical error; that is `data_std`).
    pub frequency_std_hz: f64,
    pub damping_ratio: f64,
    /// Standard deviation of the damping ratio over the same poles (order spread).
    pub damping_std: f64,
    /// Mean complex shape (poles phase-aligned to the column's central pole),
    /// largest-modulus component 1 + 0i.
    #[serde(with = "complex_pairs")]
    pub shape: Vec<c64>,
    /// Standard deviation of each aligned shape component's modulus.
    pub shape_std: Vec<f64>,
    pub mpc: f64,
    pub mpd_deg: f64,
    /// Mean MAC between the poles used and the mean shape.
    pub mean_mac: f64,
    /// Number of poles (one per order) behind the statistics.
    pub pole_count: usize,
    /// Lowest and highest model order contributing.
    pub order_min: usize,
    pub order_max: usize,
    /// `true` when picked by the manual override rather than automatically.
    pub manual: bool,
    /// Direction label of the shape: `X`, `Y`, `torsion`, `vertical`,
    /// `mixed`, an azimuth (`360deg`) for channels not on building axes, or
    /// empty when the channels' directions are unknown.
    pub direction: String,
    /// Data-driven standard deviations of frequency, damping and shape
    /// (issue 36, [`super::uncertainty`]): the statistical error of this
    /// record's estimate, unlike `frequency_std_hz` / `damping_std` /
    /// `shape_std` above, which are the spread over model orders.  `None`
    /// when not computed (too short a record, ssi-data, switched off).
    #[serde(default)]
    pub data_std: Option<super::uncertainty::ModeStd>,
}

/// A column that looked like a mode but was not promoted, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct RejectedColumn {
    pub frequency_hz: f64,
    pub damping_ratio: f64,
    pub poles: usize,
    pub order_min: usize,
    pub order_max: usize,
    pub reason: String,
}

/// Outcome of the automatic selection.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Selection {
    pub modes: Vec<Mode>,
    /// Per mode: accepted only by the shape-coherence promotion
    /// (`coherent_promotion_mac`), a column shorter than the length rule
    /// asks; the caller keeps such a mode only when its shape is a torsion.
    pub promoted: Vec<bool>,
    /// Columns of at least 3 coherent poles that were not promoted.
    pub rejected: Vec<RejectedColumn>,
}

/// Keeps one pole per order: the one nearest `centre_hz`.
fn one_per_order(poles: &[Pole], cluster: &[usize], centre_hz: f64) -> Vec<usize> {
    one_per_order_by(poles, cluster, |i| {
        (poles[i].frequency_hz - centre_hz).abs()
    })
}

/// Keeps one pole per order: the one with the smallest `closeness`.
fn one_per_order_by(
    poles: &[Pole],
    cluster: &[usize],
    closeness: impl Fn(usize) -> f64,
) -> Vec<usize> {
    let mut kept: Vec<usize> = Vec::new();
    for &i in cluster {
        match kept.iter().position(|&k| poles[k].order == poles[i].order) {
            Some(pos) => {
                if closeness(i) < closeness(kept[pos]) {
                    kept[pos] = i;
                }
            }
            None => kept.push(i),
        }
    }
    kept.sort_by_key(|&i| (poles[i].order, i));
    kept
}

/// Mode statistics over the given poles (non-empty).
fn summarise(poles: &[Pole], members: &[usize], manual: bool) -> Mode {
    let count = members.len() as f64;
    let mean =
        |f: &dyn Fn(&Pole) -> f64| members.iter().map(|&i| f(&poles[i])).sum::<f64>() / count;
    let std = |f: &dyn Fn(&Pole) -> f64, m: f64| {
        if members.len() < 2 {
            0.0
        } else {
            (members
                .iter()
                .map(|&i| (f(&poles[i]) - m).powi(2))
                .sum::<f64>()
                / (count - 1.0))
                .sqrt()
        }
    };
    let f_mean = mean(&|p| p.frequency_hz);
    let z_mean = mean(&|p| p.damping_ratio);
    // Reference: the pole nearest the mean frequency; align each shape to it by
    // the least-squares complex scale α = (φᴴφ_ref)/(φᴴφ).
    let reference = members
        .iter()
        .copied()
        .min_by(|&a, &b| {
            (poles[a].frequency_hz - f_mean)
                .abs()
                .total_cmp(&(poles[b].frequency_hz - f_mean).abs())
        })
        .unwrap_or(members[0]);
    let phi_ref = &poles[reference].shape;
    let l = phi_ref.len();
    let aligned: Vec<Vec<c64>> = members
        .iter()
        .map(|&i| {
            let phi = &poles[i].shape;
            let mut num = c64::new(0.0, 0.0);
            let mut den = 0.0;
            for (x, y) in phi.iter().zip(phi_ref) {
                num += x.conj() * y;
                den += x.norm_sqr();
            }
            let alpha = if den > 0.0 {
                num / den
            } else {
                c64::new(1.0, 0.0)
            };
            phi.iter().map(|z| z * alpha).collect()
        })
        .collect();
    let mut shape = vec![c64::new(0.0, 0.0); l];
    for a in &aligned {
        for (s, z) in shape.iter_mut().zip(a) {
            *s += z / count;
        }
    }
    normalise_shape(&mut shape);
    let shape_std = (0..l)
        .map(|k| {
            if aligned.len() < 2 {
                return 0.0;
            }
            let m = aligned.iter().map(|a| a[k].norm()).sum::<f64>() / count;
            (aligned
                .iter()
                .map(|a| (a[k].norm() - m).powi(2))
                .sum::<f64>()
                / (count - 1.0))
                .sqrt()
        })
        .collect();
    let (mpc, mpd_deg) = mpc_mpd(&shape);
    let mean_mac = members
        .iter()
        .map(|&i| mac(&poles[i].shape, &shape))
        .sum::<f64>()
        / count;
    Mode {
        frequency_hz: f_mean,
        frequency_std_hz: std(&|p| p.frequency_hz, f_mean),
        damping_ratio: z_mean,
        damping_std: std(&|p| p.damping_ratio, z_mean),
        shape,
        shape_std,
        mpc,
        mpd_deg,
        mean_mac,
        pole_count: members.len(),
        order_min: members.iter().map(|&i| poles[i].order).min().unwrap_or(0),
        order_max: members.iter().map(|&i| poles[i].order).max().unwrap_or(0),
        manual,
        direction: String::new(),
        data_std: None,
    }
}

/// Columns of poles across consecutive orders (module doc): greedy
/// one-to-one linking of each order's in-band poles to the columns ending
/// within `max_gap` realised orders before.  `order_rank[i]` is the rank of
/// pole i's order among the realised orders.
fn build_columns(
    poles: &[Pole],
    order_rank: &[usize],
    in_band: &[bool],
    settings: &SelectionSettings,
) -> Vec<Vec<usize>> {
    let mut columns: Vec<Vec<usize>> = Vec::new();
    let ranks = order_rank.iter().copied().max().map_or(0, |m| m + 1);
    for rank in 0..ranks {
        let current: Vec<usize> = (0..poles.len())
            .filter(|&i| order_rank[i] == rank && in_band[i])
            .collect();
        let mut links: Vec<(f64, usize, usize)> = Vec::new();
        for (c, col) in columns.iter().enumerate() {
            let last = *col.last().expect("columns are never empty"); // ok: built non-empty
            if order_rank[last] + 1 + settings.max_gap < rank {
                continue;
            }
            for &i in &current {
                let (a, b) = (&poles[last], &poles[i]);
                let df = (a.frequency_hz - b.frequency_hz).abs() / a.frequency_hz;
                let m = mac(&a.shape, &b.shape);
                if df
                    <= mode_tolerance(
                        a.damping_ratio,
                        b.damping_ratio,
                        settings.link_frequency,
                        settings,
                    )
                    && m >= settings.link_mac
                {
                    links.push((df + (1.0 - m), c, i));
                }
            }
        }
        links.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
        let mut column_used = vec![false; columns.len()];
        let mut pole_used = vec![false; poles.len()];
        for (_, c, i) in links {
            if !column_used[c] && !pole_used[i] {
                column_used[c] = true;
                pole_used[i] = true;
                columns[c].push(i);
            }
        }
        for i in current {
            if !pole_used[i] {
                columns.push(vec![i]);
            }
        }
    }
    columns
}

/// Frequency tolerance for two estimates of one mode with damping ratios
/// `zeta_a`, `zeta_b`: `base`, widened to half the half-power half-bandwidth
/// (|Δf|/f ≤ ζ/2, capped at `link_frequency_max`).  A damped mode's
/// frequency estimate scatters over its own resonance width from order to
/// order (on the Painter St. overpass, 2023, the transverse mode at 4.0 Hz
/// with ζ ≈ 7 % moves ±3 % between orders), so a fixed 1 % breaks its column
/// into pieces; a lightly damped mode keeps the strict tolerance.  ζ/2
/// rather than ζ: at ζ the 3–4 %-damped modes of the 5-storey ambient
/// records gathered stray poles and their damping estimates lost 0.006.
fn mode_tolerance(zeta_a: f64, zeta_b: f64, base: f64, settings: &SelectionSettings) -> f64 {
    let half = 0.5 * zeta_a.min(zeta_b);
    if half.is_finite() && half > base {
        half.min(settings.link_frequency_max)
    } else {
        base
    }
}

/// Two estimates (column summaries) of one mode: frequencies within
/// [`mode_tolerance`] and shapes with MAC ≥ `merge_mac`.  Decides both the
/// merging of a column broken by a gap and the dropping of a split twin.
fn same_mode(a: &Mode, b: &Mode, settings: &SelectionSettings) -> bool {
    let tolerance = mode_tolerance(
        a.damping_ratio,
        b.damping_ratio,
        settings.merge_frequency_tolerance,
        settings,
    );
    (a.frequency_hz - b.frequency_hz).abs() / a.frequency_hz.max(b.frequency_hz) <= tolerance
        && mac(&a.shape, &b.shape) >= settings.merge_mac
}

/// Two pieces of one column broken where the frequency jumped from one
/// order to the next by more than the link tolerance: they hold poles of
/// different orders only (a split twin holds two poles at the same orders),
/// their frequencies lie within `merge_disjoint_tolerance` and their shapes
/// agree (MAC ≥ `merge_mac`).  On short earthquake records the frequency
/// estimate of a mode wanders by 1–3 % between consecutive orders (Painter
/// St. overpass, 2014–2023 events: the 4.3 Hz transverse mode broke into
/// five pieces at the ζ/2 link tolerance), more than a link may allow
/// without gathering stray poles of the neighbouring damped modes.
fn pieces_of_one_column(a: &Mode, b: &Mode, settings: &SelectionSettings) -> bool {
    (a.frequency_hz - b.frequency_hz).abs() / a.frequency_hz.max(b.frequency_hz)
        <= settings.merge_disjoint_tolerance
        && mac(&a.shape, &b.shape) >= settings.merge_mac
}

fn mostly_physical(poles: &[Pole], members: &[usize]) -> bool {
    2 * members.iter().filter(|&&i| poles[i].physical).count() > members.len()
}

fn mean_frequency(poles: &[Pole], members: &[usize]) -> f64 {
    members.iter().map(|&i| poles[i].frequency_hz).sum::<f64>() / members.len().max(1) as f64
}

/// Merges columns of at least two poles that are one mode ([`same_mode`]),
/// or mostly physical pieces of one column broken by frequency jumps
/// ([`pieces_of_one_column`]; single poles are left alone: merged, they
/// made spurious columns next to the damped fifth mode of the 5-storey
/// ambient records).  Where both
/// hold a pole of one order, the pole nearest the merged mean frequency is
/// kept.  Summaries are cached and updated after each merge: the diagram of
/// a real record holds hundreds of single-pole columns.
fn merge_columns(
    poles: &[Pole],
    columns: Vec<Vec<usize>>,
    settings: &SelectionSettings,
) -> Vec<Vec<usize>> {
    let (mut live, untouched): (Vec<Vec<usize>>, Vec<Vec<usize>>) =
        columns.into_iter().partition(|c| c.len() >= 2);
    let mut summaries: Vec<Mode> = live.iter().map(|c| summarise(poles, c, false)).collect();
    let orders_of = |c: &[usize]| -> Vec<usize> { c.iter().map(|&i| poles[i].order).collect() };
    let mut orders: Vec<Vec<usize>> = live.iter().map(|c| orders_of(c)).collect();
    loop {
        let mut merge: Option<(usize, usize)> = None;
        'search: for a in 0..live.len() {
            for b in (a + 1)..live.len() {
                let (sa, sb) = (&summaries[a], &summaries[b]);
                let pieces = mostly_physical(poles, &live[a])
                    && mostly_physical(poles, &live[b])
                    && !orders[a].iter().any(|o| orders[b].contains(o));
                if same_mode(sa, sb, settings) || (pieces && pieces_of_one_column(sa, sb, settings))
                {
                    merge = Some((a, b));
                    break 'search;
                }
            }
        }
        let Some((a, b)) = merge else { break };
        let moved = live.remove(b);
        summaries.remove(b);
        orders.remove(b);
        live[a].extend(moved);
        let centre = mean_frequency(poles, &live[a]);
        live[a] = one_per_order(poles, &live[a], centre);
        summaries[a] = summarise(poles, &live[a], false);
        orders[a] = orders_of(&live[a]);
    }
    live.extend(untouched);
    live
}

/// The best-converged part of a column: its poles in the upper
/// `fraction` of its orders, physical ones only when there are at least 2.
fn converged_part(poles: &[Pole], column: &[usize], fraction: f64) -> Vec<usize> {
    let mut sorted: Vec<usize> = column.to_vec();
    sorted.sort_by_key(|&i| (poles[i].order, i));
    let keep = ((fraction * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    let upper: Vec<usize> = sorted[sorted.len() - keep..].to_vec();
    let physical: Vec<usize> = upper
        .iter()
        .copied()
        .filter(|&i| poles[i].physical)
        .collect();
    if physical.len() >= 2 {
        physical
    } else {
        upper
    }
}

/// A column promoted to a mode: its poles, the poles of its estimate, the
/// mode, and the column's description (reported if it later turns out to be
/// a split twin).
struct Accepted {
    members: Vec<usize>,
    part: Vec<usize>,
    mode: Mode,
    column: RejectedColumn,
    /// Accepted by the shape-coherence promotion only.
    promoted: bool,
}

/// Rejoins a split column: `twin` holds poles of the mode of `kept` (see
/// [`same_mode`]).  How a mode's column splits: near the top of the orders
/// the mode's pole and a spurious neighbour come within the link tolerance,
/// the greedy linking (nearest to each column's LAST pole) sends the mode's
/// column onto the neighbour, which drifts away, while the mode's own poles
/// continue in the neighbour's column, the twin.  The estimate, taken over
/// the upper orders, then mixed the drift in (synthetic archive,
/// 2026-01-03T00:00: the 10.553 Hz mode estimated at 10.489 Hz from a column
/// ending 10.48, 10.40, 10.34, 10.39 Hz, its poles 10.57, 10.53, 10.54,
/// 10.52 Hz in the twin).  Rule: at each order keep, among the kept
/// column's pole and the twin's poles within the link tolerance
/// ([`mode_tolerance`]) of the kept column's median frequency, the pole
/// nearest that median (robust to the drifting tail), then retake the
/// estimate over the converged part.
fn rejoin_twin(poles: &[Pole], kept: &mut Accepted, twin: &[usize], settings: &SelectionSettings) {
    let mut frequencies: Vec<f64> = kept
        .members
        .iter()
        .map(|&i| poles[i].frequency_hz)
        .collect();
    let centre = crate::stats::median_in_place(&mut frequencies);
    let zeta = kept.mode.damping_ratio;
    let mut pool = kept.members.clone();
    pool.extend(twin.iter().copied().filter(|&i| {
        let tolerance = mode_tolerance(
            zeta,
            poles[i].damping_ratio,
            settings.link_frequency,
            settings,
        );
        (poles[i].frequency_hz - centre).abs() / centre <= tolerance
    }));
    kept.members = one_per_order(poles, &pool, centre);
    kept.part = converged_part(poles, &kept.members, settings.converged_fraction);
    kept.mode = summarise(poles, &kept.part, false);
    kept.column.poles = kept.members.len();
}

/// Automatic selection by pole columns (module doc).  `orders` are the
/// realised model orders, ascending.  Sets `Pole::mode` of the poles behind
/// each mode (its converged part) and returns modes in ascending frequency.
pub fn select_automatic(
    poles: &mut [Pole],
    orders: &[usize],
    filters: &PhysicalFilters,
    nyquist_hz: f64,
    settings: &SelectionSettings,
) -> Selection {
    let order_rank: Vec<usize> = poles
        .iter()
        .map(|p| {
            orders
                .iter()
                .position(|&o| o == p.order)
                .unwrap_or(usize::MAX)
        })
        .collect();
    let in_band: Vec<bool> = poles
        .iter()
        .zip(&order_rank)
        .map(|(p, &r)| r != usize::MAX && filters.in_band(p.frequency_hz, nyquist_hz))
        .collect();
    let columns = merge_columns(
        poles,
        build_columns(poles, &order_rank, &in_band, settings),
        settings,
    );
    let max_rank = orders.len().saturating_sub(1);
    let columns: Vec<Vec<usize>> = columns.into_iter().filter(|c| c.len() >= 3).collect();
    // The longest coherent, mostly physical column sets the bar for the
    // others (`min_relative_length`): how long a mode's column is depends on
    // the record (length, excitation, noise), not on the number of orders.
    let longest = columns
        .iter()
        .filter(|c| {
            let physical = c.iter().filter(|&&i| poles[i].physical).count();
            summarise(poles, c, false).mean_mac >= settings.min_coherence
                && physical as f64 >= settings.min_physical_fraction * c.len() as f64
        })
        .map(|c| c.len())
        .max()
        .unwrap_or(0);
    // A column as long as `long_enough_poles` is long enough whatever the
    // longest one: the relative bar keeps short spurious columns out, not
    // a mode whose column is merely shorter than the fundamental's.
    let relative = ((settings.min_relative_length * longest as f64).ceil() as usize)
        .min(settings.long_enough_poles.max(settings.min_poles));
    let min_poles = settings
        .min_poles
        .max((settings.min_order_fraction * orders.len() as f64).ceil() as usize)
        .max(relative);
    let mut accepted: Vec<Accepted> = Vec::new();
    let mut rejected = Vec::new();
    for column in columns {
        let all = summarise(poles, &column, false);
        let physical = column.iter().filter(|&&i| poles[i].physical).count();
        let first_rank = column.iter().map(|&i| order_rank[i]).min().unwrap_or(0);
        let span = max_rank + 1 - first_rank.min(max_rank);
        let persistence = column.len() as f64 / span.max(1) as f64;
        let part = converged_part(poles, &column, settings.converged_fraction);
        let mode = summarise(poles, &part, false);
        let estimate_ok = (filters.damping_min..=filters.damping_max).contains(&mode.damping_ratio)
            && mode.mpc >= filters.mpc_min
            && mode.mpd_deg <= filters.mpd_max_deg;
        let reason = if all.mean_mac < settings.min_coherence {
            if all.mean_mac < 0.8 {
                continue; // an incoherent chain of noise poles: not worth a word
            }
            Some(format!(
                "shapes not coherent (mean MAC {:.3} < {})",
                all.mean_mac, settings.min_coherence
            ))
        } else if (physical as f64) < settings.min_physical_fraction * column.len() as f64 {
            Some(format!(
                "only {physical} of {} poles pass the physical filters (damping {:.1}–{:.1} %, MPC ≥ {}, MPD ≤ {}°)",
                column.len(),
                100.0 * filters.damping_min,
                100.0 * filters.damping_max,
                filters.mpc_min,
                filters.mpd_max_deg
            ))
        } else if !estimate_ok {
            Some(format!(
                "estimate outside the physical filters (ζ {:.2} %, MPC {:.2}, MPD {:.0}°)",
                100.0 * mode.damping_ratio,
                mode.mpc,
                mode.mpd_deg
            ))
        } else if column.len() < min_poles
            && !(column.len() >= settings.min_poles
                && all.mean_mac >= settings.coherent_promotion_mac
                && persistence >= settings.coherent_min_persistence)
        {
            Some(format!(
                "only {} poles (need {min_poles}, or {} with shapes coherent to MAC ≥ {} at ≥ {:.0} % of the orders from its first; mean MAC {:.3})",
                column.len(),
                settings.min_poles,
                settings.coherent_promotion_mac,
                100.0 * settings.coherent_min_persistence,
                all.mean_mac
            ))
        } else if persistence < settings.min_persistence {
            Some(format!(
                "present at {} of the {span} orders from its first (need {:.0} %)",
                column.len(),
                100.0 * settings.min_persistence
            ))
        } else {
            None
        };
        match reason {
            None => accepted.push(Accepted {
                promoted: column.len() < min_poles,
                column: RejectedColumn {
                    frequency_hz: mode.frequency_hz,
                    damping_ratio: mode.damping_ratio,
                    poles: column.len(),
                    order_min: all.order_min,
                    order_max: all.order_max,
                    reason: String::new(),
                },
                members: column,
                part,
                mode,
            }),
            Some(reason) => {
                if physical > 0 {
                    rejected.push(RejectedColumn {
                        frequency_hz: mode.frequency_hz,
                        damping_ratio: mode.damping_ratio,
                        poles: column.len(),
                        order_min: all.order_min,
                        order_max: all.order_max,
                        reason,
                    })
                }
            }
        }
    }
    // One mode, two columns: at high orders a mode can be fitted twice (a
    // split twin a few per cent apart with the same shape).  Keep the longer
    // column, rejoined with the twin's poles of the mode ([`rejoin_twin`]);
    // the twin is reported.
    accepted.sort_by(|a, b| {
        b.column
            .poles
            .cmp(&a.column.poles)
            .then(a.mode.frequency_hz.total_cmp(&b.mode.frequency_hz))
    });
    let mut kept: Vec<Accepted> = Vec::new();
    for candidate in accepted {
        match kept
            .iter_mut()
            .find(|k| same_mode(&k.mode, &candidate.mode, settings))
        {
            Some(k) => {
                rejoin_twin(poles, k, &candidate.members, settings);
                rejected.push(RejectedColumn {
                    reason: format!(
                        "twin of the {:.3} Hz mode (same shape, a longer column; its poles near that mode joined it)",
                        k.mode.frequency_hz
                    ),
                    ..candidate.column
                });
            }
            None => kept.push(candidate),
        }
    }
    let mut accepted = kept;
    accepted.sort_by(|a, b| a.mode.frequency_hz.total_cmp(&b.mode.frequency_hz));
    rejected.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
    for (m, a) in accepted.iter().enumerate() {
        for &i in &a.part {
            poles[i].mode = Some(m);
        }
    }
    Selection {
        promoted: accepted.iter().map(|a| a.promoted).collect(),
        modes: accepted.into_iter().map(|a| a.mode).collect(),
        rejected,
    }
}

/// Manual override: for each requested frequency, the physical poles that are
/// stable in frequency and lie within ±`relative_band` of it (one per order,
/// nearest the request) form the mode.  Fails naming the frequency when no
/// such pole exists.  Sets `Pole::mode` (index in the returned list).
pub fn select_manual(
    poles: &mut [Pole],
    frequencies_hz: &[f64],
    relative_band: f64,
) -> Result<Vec<Mode>> {
    let mut modes = Vec::with_capacity(frequencies_hz.len());
    let mut assigned: Vec<Vec<usize>> = Vec::new();
    for &target in frequencies_hz {
        if !(target.is_finite() && target > 0.0) {
            return Err(Error::usage(format!(
                "manual mode pick: frequency {target} is not a positive number"
            )));
        }
        let near: Vec<usize> = (0..poles.len())
            .filter(|&i| {
                let p = &poles[i];
                p.physical
                    && p.stable_frequency
                    && (p.frequency_hz - target).abs() <= relative_band * target
            })
            .collect();
        let members = one_per_order(poles, &near, target);
        if members.is_empty() {
            return Err(Error::NotIdentifiable {
                stage: "modal".into(),
                message: format!(
                    "manual pick {target} Hz: no stable physical pole within ±{:.1} %",
                    100.0 * relative_band
                ),
                f_test: None,
            });
        }
        modes.push(summarise(poles, &members, true));
        assigned.push(members);
    }
    for (m, c) in assigned.iter().enumerate() {
        for &i in c {
            poles[i].mode = Some(m);
        }
    }
    Ok(modes)
}

/// A complex vector as `[[re, im], …]` (serde), for [`Mode::shape`].
mod complex_pairs {
    use faer::c64;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(v: &[c64], s: S) -> Result<S::Ok, S::Error> {
        v.iter()
            .map(|z| [z.re, z.im])
            .collect::<Vec<_>>()
            .serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<c64>, D::Error> {
        let pairs = Vec::<[f64; 2]>::deserialize(d)?;
        Ok(pairs.into_iter().map(|[re, im]| c64::new(re, im)).collect())
    }
}
