//! Lumped masses of a partly instrumented building: Eq. 35–36 of METHODS.md
//! §4 generalised to any set of instrumented levels (I/O free).
//!
//! The identified chain has one DoF per instrumented floor level
//! l_1 < … < l_D (the base l_0 = 0 is always instrumented); its "storeys" are
//! the *segments* between consecutive instrumented levels, named `L<a>-L<b>`.
//! The mass m_i of every level i is lumped onto the instrumented levels by
//! the **tributary (linear) rule** — the row sums of the consistent mass of a
//! displacement field interpolated linearly in elevation between the
//! instrumented levels:
//!
//! - an instrumented level keeps its own mass;
//! - a level i strictly between l_{j−1} and l_j (elevations z) gives
//!   ξ = (z_i − z_{l_{j−1}}) / (z_{l_j} − z_{l_{j−1}}) of its mass to l_j and
//!   (1 − ξ) to l_{j−1}; the share lumped onto the base (j = 1) moves with the
//!   ground and leaves the chain (reported as `dropped_to_base_kg`);
//! - a level above the top instrumented one moves with it (rigid extension):
//!   its whole mass goes to l_D.
//!
//! Elevations come from the storey heights when given, else from equal
//! storey heights (ξ by level count), stated in `elevation_source`.
//!
//! Why linear: with the segment's restoring force taken as the shear of the
//! lumped masses above it, a first-mode response gives the segment a
//! stiffness within a few per cent of the series stiffness 1/Σ(1/k_s) of its
//! storeys (tests/it/hysteresis_partial.rs derives the bound from the truth's
//! first mode); lumping each level wholly onto the level above overestimates
//! the top segment's shear by the mass of the levels below it.

use serde::Serialize;

use crate::error::{Error, Result};

/// Masses of the reduced chain and how they were formed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LumpedMasses {
    /// The building's level masses (levels 1..n) that were lumped, kg.
    pub level_masses_kg: Vec<f64>,
    /// Mass per DoF (instrumented floor, lowest first), kg.
    pub masses_kg: Vec<f64>,
    /// `shares[i]` = (DoF index or None for the base, fraction) of level i+1.
    pub shares: Vec<Vec<(Option<usize>, f64)>>,
    /// Mass lumped onto the base (moves with the ground), kg.
    pub dropped_to_base_kg: f64,
    /// `storey_heights_m` or `equal storey heights (no structure.storey_heights_m)`.
    pub elevation_source: String,
}

/// "L0-L4": the segment below DoF `d` (0-based) of a chain on `levels`.
pub fn segment_label(levels: &[i32], d: usize) -> String {
    let lower = if d == 0 { 0 } else { levels[d - 1] };
    format!("L{lower}-L{}", levels[d])
}

/// Tributary lumping (module doc) of `level_masses` (levels 1..n, kg) onto
/// the instrumented floor `levels` (ascending, within 1..n). `storey_heights_m`
/// (levels 1..n) gives the elevations; empty = equal storey heights.
pub fn tributary_masses(
    level_masses: &[f64],
    storey_heights_m: &[f64],
    levels: &[i32],
) -> Result<LumpedMasses> {
    let n = level_masses.len();
    if levels.is_empty() {
        return Err(Error::usage("lumped masses: no instrumented floor level"));
    }
    if levels.windows(2).any(|w| w[0] >= w[1])
        || levels[0] < 1
        || levels[levels.len() - 1] > n as i32
    {
        return Err(Error::usage(format!(
            "lumped masses: instrumented levels {levels:?} must be ascending within 1..{n} (the levels with a mass)"
        )));
    }
    if let Some(i) = level_masses
        .iter()
        .position(|m| !(*m >= 0.0 && m.is_finite()))
    {
        return Err(Error::usage(format!(
            "lumped masses: mass of level {} is {} kg",
            i + 1,
            level_masses[i]
        )));
    }
    let (elevations, elevation_source) =
        if storey_heights_m.len() >= n && storey_heights_m[..n].iter().all(|h| *h > 0.0) {
            let mut z = vec![0.0];
            for h in &storey_heights_m[..n] {
                z.push(z[z.len() - 1] + h);
            }
            (z, "storey_heights_m".to_string())
        } else {
            (
                (0..=n).map(|l| l as f64).collect::<Vec<f64>>(),
                "equal storey heights (no structure.storey_heights_m)".to_string(),
            )
        };
    let mut masses = vec![0.0; levels.len()];
    let mut shares = Vec::with_capacity(n);
    let mut dropped = 0.0;
    for level in 1..=n as i32 {
        let m = level_masses[level as usize - 1];
        // First instrumented level at or above this one.
        let share = match levels.iter().position(|&l| l >= level) {
            Some(j) if levels[j] == level => vec![(Some(j), 1.0)],
            Some(j) => {
                let below = if j == 0 { 0 } else { levels[j - 1] };
                let (za, zb) = (elevations[below as usize], elevations[levels[j] as usize]);
                let xi = (elevations[level as usize] - za) / (zb - za);
                vec![(j.checked_sub(1), 1.0 - xi), (Some(j), xi)]
            }
            None => vec![(Some(levels.len() - 1), 1.0)],
        };
        for &(dof, fraction) in &share {
            match dof {
                Some(j) => masses[j] += fraction * m,
                None => dropped += fraction * m,
            }
        }
        shares.push(share);
    }
    Ok(LumpedMasses {
        level_masses_kg: level_masses.to_vec(),
        masses_kg: masses,
        shares,
        dropped_to_base_kg: dropped,
        elevation_source,
    })
}
