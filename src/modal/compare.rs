//! Helpers for later stages: MAC matrix between two mode sets, pairing of
//! modes, and frequency shifts between two events of the same structure
//! (pre/post earthquake) as a damage indicator.

use super::poles::mac;
use super::selection::Mode;
use faer::c64;

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

/// Greedy pairing by decreasing MAC: repeatedly takes the unpaired pair with
/// the highest MAC (ties broken by the smaller indices, so the result is
/// deterministic) until no pair reaches `min_mac`.  Greedy rather than the
/// Hungarian assignment because mode sets are small and a high-MAC pair is
/// almost never worth sacrificing for the global sum.
pub fn pair_modes(a: &[Vec<c64>], b: &[Vec<c64>], min_mac: f64) -> Vec<ModePair> {
    let m = mac_matrix(a, b);
    let mut candidates: Vec<(usize, usize, f64)> = m
        .iter()
        .enumerate()
        .flat_map(|(i, row)| row.iter().enumerate().map(move |(j, &v)| (i, j, v)))
        .collect();
    candidates.sort_by(|x, y| y.2.total_cmp(&x.2).then(x.0.cmp(&y.0)).then(x.1.cmp(&y.1)));
    let (mut used_a, mut used_b) = (vec![false; a.len()], vec![false; b.len()]);
    let mut pairs = Vec::new();
    for (i, j, v) in candidates {
        if v < min_mac {
            break;
        }
        if !used_a[i] && !used_b[j] {
            used_a[i] = true;
            used_b[j] = true;
            pairs.push(ModePair {
                reference: i,
                other: j,
                mac: v,
            });
        }
    }
    pairs.sort_by_key(|p| p.reference);
    pairs
}

/// Frequency and damping change of one paired mode between two events.
#[derive(Debug, Clone, PartialEq)]
pub struct FrequencyShift {
    pub reference_mode: usize,
    pub other_mode: usize,
    pub frequency_reference_hz: f64,
    pub frequency_other_hz: f64,
    /// (f_other − f_ref) / f_ref; a drop (negative) indicates stiffness loss.
    pub relative_shift: f64,
    /// Shift divided by the combined standard deviation of the two estimates
    /// (0 when both standard deviations are zero).
    pub shift_in_std: f64,
    pub damping_reference: f64,
    pub damping_other: f64,
    pub mac: f64,
}

/// Pairs two identified mode sets by MAC and reports the frequency shifts.
pub fn frequency_shifts(reference: &[Mode], other: &[Mode], min_mac: f64) -> Vec<FrequencyShift> {
    let a: Vec<Vec<c64>> = reference.iter().map(|m| m.shape.clone()).collect();
    let b: Vec<Vec<c64>> = other.iter().map(|m| m.shape.clone()).collect();
    pair_modes(&a, &b, min_mac)
        .into_iter()
        .map(|p| {
            let (r, o) = (&reference[p.reference], &other[p.other]);
            let combined_std = (r.frequency_std_hz.powi(2) + o.frequency_std_hz.powi(2)).sqrt();
            let diff = o.frequency_hz - r.frequency_hz;
            FrequencyShift {
                reference_mode: p.reference,
                other_mode: p.other,
                frequency_reference_hz: r.frequency_hz,
                frequency_other_hz: o.frequency_hz,
                relative_shift: diff / r.frequency_hz,
                shift_in_std: if combined_std > 0.0 {
                    diff / combined_std
                } else {
                    0.0
                },
                damping_reference: r.damping_ratio,
                damping_other: o.damping_ratio,
                mac: p.mac,
            }
        })
        .collect()
}
