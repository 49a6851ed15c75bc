//! Global modes only (issue 31 item 4): after the selection, a mode whose
//! shape lives on one channel is a LOCAL mode (a sensor's mount, a deck
//! panel, a noise line of one channel), listed apart and never reported as
//! a structural mode; near-duplicates of one mode are merged into the
//! better-converged estimate.
//!
//! Energy measure: on the normalised complex shape φ (largest component
//! 1 + 0i), the share of channel k is |φ_k|² / Σ_j |φ_j|² — the fraction of
//! the shape's squared modulus (its "energy") on that channel, independent
//! of the shape's scale and phase.

use super::poles::mac;
use super::selection::Mode;

/// A mode with more than this share of its shape's energy on one channel
/// is local (> 96.5 %: every other channel together moves by less than
/// about 19 % of the dominant one).  Measured on the CESMD bridge corpus:
/// the 8 "modes" 11–20 Hz of one bridge event held 97–100 % on one deck
/// channel, while the Ridgecrest bridge's real transverse mode (3.07–3.46 Hz
/// in all three events, mid-span deck channel beside abutment channels
/// that barely move) holds 94.9–95.9 %, and the Lake Crowley one 91 %: a
/// 90 % bound withdrew real deck modes whose other sensors sit near the
/// supports.
pub const LOCAL_ENERGY_SHARE: f64 = 0.965;

/// Two modes are one when their shapes agree (MAC ≥ this) …
pub const DUPLICATE_MAC: f64 = 0.95;
/// … and their frequencies lie within this relative distance (5 %: the
/// twins seen on the bridge records were 4 % apart with MAC 0.998; two
/// distinct modes with the same shape within 5 % do not occur in a
/// structure's global modes, whose shapes are orthogonal through the mass).
pub const DUPLICATE_FREQUENCY: f64 = 0.05;

/// The channel holding the largest share of `shape`'s energy, and that share.
pub fn dominant_channel(shape: &[faer::c64]) -> Option<(usize, f64)> {
    let total: f64 = shape.iter().map(|z| z.norm_sqr()).sum();
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    shape
        .iter()
        .enumerate()
        .map(|(k, z)| (k, z.norm_sqr() / total))
        .fold(None, |best: Option<(usize, f64)>, (k, s)| match best {
            Some((_, b)) if b >= s => best,
            _ => Some((k, s)),
        })
}

/// A mode withdrawn as local: where it lives.
#[derive(Debug, Clone, PartialEq)]
pub struct LocalMode {
    pub frequency_hz: f64,
    pub damping_ratio: f64,
    /// The output channel holding the shape.
    pub channel: String,
    /// Its share of the shape's energy (module doc).
    pub energy_share: f64,
}

/// Why each mode of `modes` is withdrawn (`None` = kept): local modes
/// (returned apart too) and the less converged of each pair of
/// near-duplicates.  With one output channel every shape is on one channel:
/// nothing is called local then.
pub fn screen(modes: &[Mode], output_ids: &[String]) -> (Vec<Option<String>>, Vec<LocalMode>) {
    let mut reasons: Vec<Option<String>> = vec![None; modes.len()];
    let mut local = Vec::new();
    if output_ids.len() >= 2 {
        for (m, reason) in modes.iter().zip(reasons.iter_mut()) {
            if let Some((k, share)) = dominant_channel(&m.shape) {
                if share > LOCAL_ENERGY_SHARE {
                    let channel = output_ids.get(k).cloned().unwrap_or_default();
                    *reason = Some(format!(
                        "local mode: {:.0} % of the shape's energy on channel {channel} (> {:.0} %), not a structural mode",
                        100.0 * share,
                        100.0 * LOCAL_ENERGY_SHARE
                    ));
                    local.push(LocalMode {
                        frequency_hz: m.frequency_hz,
                        damping_ratio: m.damping_ratio,
                        channel,
                        energy_share: share,
                    });
                }
            }
        }
    }
    // Near-duplicates among the modes kept: the better converged (more
    // poles behind it, then the smaller relative frequency scatter, then
    // the lower frequency) stays.
    let better = |a: &Mode, b: &Mode| {
        a.pole_count
            .cmp(&b.pole_count)
            .then(
                (b.frequency_std_hz / b.frequency_hz)
                    .total_cmp(&(a.frequency_std_hz / a.frequency_hz)),
            )
            .then(b.frequency_hz.total_cmp(&a.frequency_hz))
            .is_gt()
    };
    let mut order: Vec<usize> = (0..modes.len()).collect();
    order.sort_by(|&a, &b| {
        if better(&modes[a], &modes[b]) {
            std::cmp::Ordering::Less
        } else if better(&modes[b], &modes[a]) {
            std::cmp::Ordering::Greater
        } else {
            a.cmp(&b)
        }
    });
    let mut kept: Vec<usize> = Vec::new();
    for i in order {
        if reasons[i].is_some() {
            continue;
        }
        let twin = kept.iter().copied().find(|&k| {
            let (a, b) = (&modes[k], &modes[i]);
            (a.frequency_hz - b.frequency_hz).abs() / a.frequency_hz.max(b.frequency_hz)
                <= DUPLICATE_FREQUENCY
                && mac(&a.shape, &b.shape) >= DUPLICATE_MAC
        });
        match twin {
            Some(k) => {
                reasons[i] = Some(format!(
                    "duplicate of the {:.3} Hz mode (MAC {:.3}, {:.1} % apart; that estimate is better converged: {} poles)",
                    modes[k].frequency_hz,
                    mac(&modes[k].shape, &modes[i].shape),
                    100.0 * (modes[k].frequency_hz - modes[i].frequency_hz).abs()
                        / modes[k].frequency_hz.max(modes[i].frequency_hz),
                    modes[k].pole_count
                ))
            }
            None => kept.push(i),
        }
    }
    (reasons, local)
}
