//! Direction label of a mode shape from what each output channel measures
//! (issue 13): `X`, `Y`, `vertical`, `torsion`, `mixed`, or the channels'
//! own label (an azimuth such as `360deg`) when they are not on building axes.
//!
//! Rules, on the energy |φ_k|² of the shape components:
//! - vertical channels hold ≥ 50 % → `vertical`;
//! - two significant components (≥ 30 % of the largest of their direction)
//!   of ONE horizontal direction at ONE level (group) move in opposite senses
//!   (real parts of the normalised shape of opposite sign), and that direction
//!   holds ≥ 20 % → `torsion` (rotation about the vertical axis: sensors at two
//!   corners of a floor, or the two ends of a bridge deck);
//! - one horizontal direction holds ≥ 70 % → that direction;
//! - channels of unknown direction hold ≥ 50 % → empty label (unknown);
//! - otherwise `mixed`.

use faer::c64;
use std::collections::BTreeMap;

/// Label of a vertical channel in `directions`.
pub const VERTICAL: &str = "vertical";

/// Direction label of `shape` (module doc).  `directions[k]` is channel k's
/// direction label (`X`, `Y`, [`VERTICAL`], an azimuth label, or empty when
/// unknown); `groups[k]` its level or location group (empty = one group).
/// Missing entries count as unknown.
pub fn label(shape: &[c64], directions: &[String], groups: &[String]) -> String {
    let total: f64 = shape.iter().map(|z| z.norm_sqr()).sum();
    if total <= 0.0 {
        return String::new();
    }
    let dir = |k: usize| directions.get(k).map(String::as_str).unwrap_or("");
    let group = |k: usize| groups.get(k).map(String::as_str).unwrap_or("");
    let mut share: BTreeMap<&str, f64> = BTreeMap::new();
    for (k, z) in shape.iter().enumerate() {
        *share.entry(dir(k)).or_default() += z.norm_sqr() / total;
    }
    if share.get(VERTICAL).copied().unwrap_or(0.0) >= 0.5 {
        return VERTICAL.into();
    }
    for (&d, &s) in &share {
        if d.is_empty() || d == VERTICAL || s < 0.2 {
            continue;
        }
        let of_dir: Vec<usize> = (0..shape.len()).filter(|&k| dir(k) == d).collect();
        let peak = of_dir.iter().map(|&k| shape[k].norm()).fold(0.0, f64::max);
        let mut senses: BTreeMap<&str, (bool, bool)> = BTreeMap::new();
        for &k in &of_dir {
            if shape[k].norm() >= 0.3 * peak {
                let e = senses.entry(group(k)).or_default();
                if shape[k].re > 0.0 {
                    e.0 = true;
                } else {
                    e.1 = true;
                }
            }
        }
        if senses.values().any(|&(pos, neg)| pos && neg) {
            return "torsion".into();
        }
    }
    let (best, best_share) = share
        .iter()
        .filter(|(d, _)| **d != VERTICAL)
        .map(|(d, s)| (*d, *s))
        .fold(("", 0.0), |a, b| if b.1 > a.1 { b } else { a });
    if best.is_empty() && best_share >= 0.5 {
        return String::new();
    }
    if best_share >= 0.7 {
        return best.to_string();
    }
    if share.get("").copied().unwrap_or(0.0) >= 0.5 {
        return String::new();
    }
    "mixed".into()
}
