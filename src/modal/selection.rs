//! Automatic mode selection from the stabilisation diagram (METHODS §2):
//! physical filters, hierarchical clustering of stable poles, one mode per
//! cluster with mean and standard deviation; and the manual override.
//!
//! Clustering (documented choice): agglomerative clustering with AVERAGE
//! linkage (UPGMA) on the distance
//!   d(i, j) = |f_i − f_j| / max(f_i, f_j) + w_ζ |ζ_i − ζ_j| / max(ζ_i, ζ_j) + (1 − MAC(φ_i, φ_j)),
//! merging while the closest pair of clusters is nearer than `threshold`.
//! Average linkage is used rather than single linkage because single linkage
//! chains neighbouring physical and spurious poles into one cluster.
//! A cluster is a mode only if it holds poles from at least
//! `min_cluster_fraction` (default 40 %) of the model orders swept (a
//! physical mode shows up at almost every order above its own; noise poles
//! do not: in the 5-storey synthetic tests physical clusters held 15–20 poles
//! of 21 orders, noise clusters at most 8).  Within a
//! cluster only one pole per order is kept (the one nearest the cluster's
//! median frequency).

use super::poles::{mac, mpc_mpd, normalise_shape, Pole};
use crate::error::{Error, Result};
use faer::c64;

/// Physical-mode filters applied before clustering.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PhysicalFilters {
    /// Damping window [min, max] (METHODS §2: 0.9–5.5 %).
    pub damping_min: f64,
    pub damping_max: f64,
    /// Minimum modal phase collinearity.
    pub mpc_min: f64,
    /// Maximum mean phase deviation, degrees.
    pub mpd_max_deg: f64,
    /// Band limits for the poles, Hz (`None` = 0 to 0.95 × Nyquist).
    pub frequency_min_hz: Option<f64>,
    pub frequency_max_hz: Option<f64>,
}

impl Default for PhysicalFilters {
    fn default() -> Self {
        PhysicalFilters {
            damping_min: 0.009,
            damping_max: 0.055,
            mpc_min: 0.8,
            mpd_max_deg: 20.0,
            frequency_min_hz: None,
            frequency_max_hz: None,
        }
    }
}

impl PhysicalFilters {
    pub fn passes(&self, pole: &Pole, nyquist_hz: f64) -> bool {
        let f_min = self.frequency_min_hz.unwrap_or(0.0);
        let f_max = self.frequency_max_hz.unwrap_or(0.95 * nyquist_hz);
        (self.damping_min..=self.damping_max).contains(&pole.damping_ratio)
            && pole.mpc >= self.mpc_min
            && pole.mpd_deg <= self.mpd_max_deg
            && pole.frequency_hz >= f_min
            && pole.frequency_hz <= f_max
    }
}

/// Settings of the automatic clustering.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ClusterSettings {
    /// Weight w_ζ of the relative damping difference in the distance.
    pub damping_weight: f64,
    /// Average-linkage merge threshold on the distance.
    pub threshold: f64,
    /// A cluster must hold poles of at least this fraction of the orders swept.
    pub min_cluster_fraction: f64,
    /// Clusters closer than this relative frequency difference whose medoid
    /// shapes have MAC ≥ `merge_mac_min` are merged (one mode split in two).
    pub merge_frequency_tolerance: f64,
    pub merge_mac_min: f64,
    /// Candidates must be stable in damping too, not only in frequency and
    /// shape.  Off by default: with noisy data damping estimates wander by
    /// more than 5 % between consecutive orders, and requiring it lost a true
    /// mode of the 5-storey synthetic test for 1 seed in 20; damping still
    /// enters the clustering distance.
    pub require_damping_stability: bool,
}

impl Default for ClusterSettings {
    fn default() -> Self {
        ClusterSettings {
            damping_weight: 0.1,
            threshold: 0.04,
            min_cluster_fraction: 0.4,
            merge_frequency_tolerance: 0.01,
            merge_mac_min: 0.98,
            require_damping_stability: false,
        }
    }
}

/// One identified mode: statistics over the poles of its cluster.
#[derive(Debug, Clone, PartialEq)]
pub struct Mode {
    pub frequency_hz: f64,
    pub frequency_std_hz: f64,
    pub damping_ratio: f64,
    pub damping_std: f64,
    /// Mean complex shape (poles phase-aligned to the cluster's central pole),
    /// largest-modulus component 1 + 0i.
    pub shape: Vec<c64>,
    /// Standard deviation of each aligned shape component's modulus.
    pub shape_std: Vec<f64>,
    pub mpc: f64,
    pub mpd_deg: f64,
    /// Mean MAC between the cluster's poles and the mean shape.
    pub mean_mac: f64,
    /// Number of poles (one per order) behind the statistics.
    pub pole_count: usize,
    /// Lowest and highest model order contributing.
    pub order_min: usize,
    pub order_max: usize,
    /// `true` when picked by the manual override rather than clustering.
    pub manual: bool,
}

fn distance(a: &Pole, b: &Pole, damping_weight: f64) -> f64 {
    let df = (a.frequency_hz - b.frequency_hz).abs() / a.frequency_hz.max(b.frequency_hz);
    let dz = (a.damping_ratio - b.damping_ratio).abs()
        / a.damping_ratio.abs().max(b.damping_ratio.abs()).max(1e-12);
    df + damping_weight * dz + (1.0 - mac(&a.shape, &b.shape))
}

/// Average-linkage agglomerative clustering of `items` (indices into
/// `poles`); returns clusters as lists of pole indices.  O(n²) memory,
/// O(n³) time in the worst case; n is at most a few hundred poles.
fn average_linkage(poles: &[Pole], items: &[usize], settings: &ClusterSettings) -> Vec<Vec<usize>> {
    let n = items.len();
    let mut dist = vec![0.0; n * n];
    for i in 0..n {
        for j in (i + 1)..n {
            let d = distance(&poles[items[i]], &poles[items[j]], settings.damping_weight);
            dist[i * n + j] = d;
            dist[j * n + i] = d;
        }
    }
    let mut members: Vec<Vec<usize>> = (0..n).map(|i| vec![i]).collect();
    let mut alive = vec![true; n];
    loop {
        let mut best: Option<(usize, usize, f64)> = None;
        for i in 0..n {
            if !alive[i] {
                continue;
            }
            for j in (i + 1)..n {
                if alive[j] && best.is_none_or(|b| dist[i * n + j] < b.2) {
                    best = Some((i, j, dist[i * n + j]));
                }
            }
        }
        let Some((i, j, d)) = best else { break };
        if d > settings.threshold {
            break;
        }
        // Lance–Williams update for average linkage.
        let (ni, nj) = (members[i].len() as f64, members[j].len() as f64);
        for k in 0..n {
            if alive[k] && k != i && k != j {
                let v = (ni * dist[i * n + k] + nj * dist[j * n + k]) / (ni + nj);
                dist[i * n + k] = v;
                dist[k * n + i] = v;
            }
        }
        let moved = std::mem::take(&mut members[j]);
        members[i].extend(moved);
        alive[j] = false;
    }
    (0..n)
        .filter(|&i| alive[i])
        .map(|i| members[i].iter().map(|&m| items[m]).collect())
        .collect()
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

/// Merges clusters describing the same mode: mean frequencies within
/// `merge_frequency_tolerance` and medoid shapes with MAC ≥ `merge_mac_min`.
/// Two modes of a structure cannot share a shape (they are mass-orthogonal),
/// so such clusters are one mode split by damping scatter between orders.
fn merge_same_mode(
    poles: &[Pole],
    mut clusters: Vec<Vec<usize>>,
    settings: &ClusterSettings,
) -> Vec<Vec<usize>> {
    let mean_f =
        |c: &[usize]| c.iter().map(|&i| poles[i].frequency_hz).sum::<f64>() / c.len().max(1) as f64;
    loop {
        let mut merge: Option<(usize, usize)> = None;
        'search: for a in 0..clusters.len() {
            for b in (a + 1)..clusters.len() {
                let (fa, fb) = (mean_f(&clusters[a]), mean_f(&clusters[b]));
                if (fa - fb).abs() / fa.max(fb) > settings.merge_frequency_tolerance {
                    continue;
                }
                let ma = medoid(poles, &clusters[a], settings.damping_weight);
                let mb = medoid(poles, &clusters[b], settings.damping_weight);
                if mac(&poles[ma].shape, &poles[mb].shape) >= settings.merge_mac_min {
                    merge = Some((a, b));
                    break 'search;
                }
            }
        }
        let Some((a, b)) = merge else { break };
        let moved = clusters.remove(b);
        clusters[a].extend(moved);
    }
    clusters
}

/// Medoid of a cluster: the member with the smallest summed distance to the others.
fn medoid(poles: &[Pole], cluster: &[usize], damping_weight: f64) -> usize {
    let total = |i: usize| {
        cluster
            .iter()
            .map(|&j| distance(&poles[i], &poles[j], damping_weight))
            .sum::<f64>()
    };
    cluster
        .iter()
        .copied()
        .min_by(|&a, &b| total(a).total_cmp(&total(b)).then(a.cmp(&b)))
        .unwrap_or(0)
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
    }
}

/// Automatic selection: clusters the stable physical poles, keeps clusters
/// spanning enough orders, returns modes in ascending frequency and sets
/// `Pole::mode` of the poles used.
pub fn select_automatic(
    poles: &mut [Pole],
    orders_swept: usize,
    settings: &ClusterSettings,
) -> Vec<Mode> {
    let candidates: Vec<usize> = (0..poles.len())
        .filter(|&i| {
            let p = &poles[i];
            p.physical
                && p.stable_frequency
                && p.stable_shape
                && (!settings.require_damping_stability || p.stable_damping)
        })
        .collect();
    let clusters = merge_same_mode(
        poles,
        average_linkage(poles, &candidates, settings),
        settings,
    );
    let min_size = ((settings.min_cluster_fraction * orders_swept as f64).ceil() as usize).max(2);
    let mut kept: Vec<Vec<usize>> = clusters
        .into_iter()
        .map(|c| {
            // Noise poles sometimes sit beside a physical pole of the same
            // order; keep the one nearest the cluster's medoid (f, ζ and shape).
            let centre = medoid(poles, &c, settings.damping_weight);
            one_per_order_by(poles, &c, |i| {
                distance(&poles[i], &poles[centre], settings.damping_weight)
            })
        })
        .filter(|c| c.len() >= min_size)
        .collect();
    kept.sort_by(|a, b| {
        let fa = a.iter().map(|&i| poles[i].frequency_hz).sum::<f64>() / a.len() as f64;
        let fb = b.iter().map(|&i| poles[i].frequency_hz).sum::<f64>() / b.len() as f64;
        fa.total_cmp(&fb)
    });
    let modes: Vec<Mode> = kept.iter().map(|c| summarise(poles, c, false)).collect();
    for (m, c) in kept.iter().enumerate() {
        for &i in c {
            poles[i].mode = Some(m);
        }
    }
    modes
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
