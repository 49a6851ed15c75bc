//! Proper orthogonal decomposition of a snapshot matrix and the quality of its truncated
//! reconstruction (METHODS §5, Eq. 56–58, 79–81, 83–84).

use faer::{Mat, MatRef};

use crate::error::Error;
use crate::Result;

/// X = U Σ Vᵀ (thin SVD, X is n DoFs × n_t snapshots). Columns of U are the POMs.
#[derive(Debug, Clone)]
pub struct Pod {
    pub modes: Mat<f64>,
    pub singular_values: Vec<f64>,
    /// Right singular vectors (n_t × rank): the POMs' time histories, σ_i v_i.
    pub time_coefficients: Mat<f64>,
    /// E_i = σ_i² / Σ σ² (Eq. 58, 81).
    pub energy_fraction: Vec<f64>,
    /// Σ_{j ≤ i} E_j.
    pub cumulative_energy: Vec<f64>,
}

/// Reconstruction quality with POMs 1..=k for each k of the curve.
#[derive(Debug, Clone)]
pub struct PodCurve {
    /// WNRMSE of the reconstruction with the first k POMs, k = 1..=len (Eq. 84).
    pub wnrmse: Vec<f64>,
    /// Number of POMs retained: the fewest whose cumulative energy ≥ the energy target and
    /// whose WNRMSE ≤ the WNRMSE target (when given).
    pub retained: usize,
}

/// POD by thin SVD (Eq. 56–57). Errors on an empty or non-finite snapshot matrix.
pub fn pod(snapshots: MatRef<'_, f64>) -> Result<Pod> {
    let (n, nt) = (snapshots.nrows(), snapshots.ncols());
    if n == 0 || nt == 0 {
        return Err(Error::usage("POD: the snapshot matrix is empty"));
    }
    for j in 0..nt {
        for i in 0..n {
            if !snapshots[(i, j)].is_finite() {
                return Err(Error::numerical(format!(
                    "POD: snapshot {j} has a non-finite value at DoF {i}"
                )));
            }
        }
    }
    let svd = snapshots
        .thin_svd()
        .map_err(|e| Error::numerical(format!("POD: SVD failed ({e:?})")))?;
    let rank = n.min(nt);
    let s = svd.S().column_vector();
    let singular_values: Vec<f64> = (0..rank).map(|i| s[i]).collect();
    let total: f64 = singular_values.iter().map(|v| v * v).sum();
    if total == 0.0 {
        return Err(Error::numerical("POD: the snapshots are all zero"));
    }
    let energy_fraction: Vec<f64> = singular_values.iter().map(|v| v * v / total).collect();
    let mut acc = 0.0;
    let cumulative_energy = energy_fraction
        .iter()
        .map(|e| {
            acc += e;
            acc
        })
        .collect();
    let v = svd.V();
    let time_coefficients = Mat::from_fn(nt, rank, |k, i| singular_values[i] * v[(k, i)]);
    Ok(Pod {
        modes: svd.U().to_owned(),
        singular_values,
        time_coefficients,
        energy_fraction,
        cumulative_energy,
    })
}

/// NRMSE of one history (Eq. 83): sqrt(mean((x − x̃)²)) / (max x − min x). A constant history
/// has no range: its NRMSE is 0 when reproduced exactly, else +∞.
pub fn nrmse(x: &[f64], approx: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let mse = x
        .iter()
        .zip(approx)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        / x.len() as f64;
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let range = hi - lo;
    if range > 0.0 {
        mse.sqrt() / range
    } else if mse == 0.0 {
        0.0
    } else {
        f64::INFINITY
    }
}

/// Weight of a history in the WNRMSE: max_k |x_k − μ| (Eq. 84).
pub fn wnrmse_weight(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let mu = x.iter().sum::<f64>() / x.len() as f64;
    x.iter().fold(0.0_f64, |m, v| m.max((v - mu).abs()))
}

/// WNRMSE over DoFs (Eq. 84): Σ_i NRMSE_i w_i / Σ_i w_i with w_i = max|x_i − μ_i|; rows of
/// `x` and `approx` are DoFs. Returns (WNRMSE, NRMSE per DoF, weight per DoF). DoFs with zero
/// weight do not count; when every weight is zero the WNRMSE is 0.
pub fn wnrmse(x: MatRef<'_, f64>, approx: MatRef<'_, f64>) -> (f64, Vec<f64>, Vec<f64>) {
    let n = x.nrows();
    let (mut num, mut den) = (0.0, 0.0);
    let mut per = Vec::with_capacity(n);
    let mut weights = Vec::with_capacity(n);
    for i in 0..n {
        let a: Vec<f64> = (0..x.ncols()).map(|k| x[(i, k)]).collect();
        let b: Vec<f64> = (0..x.ncols()).map(|k| approx[(i, k)]).collect();
        let e = nrmse(&a, &b);
        let w = wnrmse_weight(&a);
        if w > 0.0 {
            num += e * w;
            den += w;
        }
        per.push(e);
        weights.push(w);
    }
    (if den > 0.0 { num / den } else { 0.0 }, per, weights)
}

/// WNRMSE of X ≈ Σ_{i ≤ k} σ_i u_i v_iᵀ for k = 1..=max_modes (built incrementally), and the
/// retained count: the fewest POMs with cumulative energy ≥ `energy_target` and (if given)
/// WNRMSE ≤ `wnrmse_target`. Errors when no count up to `max_modes` meets the targets.
pub fn reconstruction_quality(
    snapshots: MatRef<'_, f64>,
    pod: &Pod,
    max_modes: usize,
    energy_target: f64,
    wnrmse_target: Option<f64>,
) -> Result<PodCurve> {
    if !(energy_target > 0.0 && energy_target <= 1.0) {
        return Err(Error::usage(format!(
            "POD: energy target {energy_target} must lie in (0, 1]"
        )));
    }
    let (n, nt) = (snapshots.nrows(), snapshots.ncols());
    let kmax = max_modes.min(pod.singular_values.len());
    let mut approx = Mat::<f64>::zeros(n, nt);
    let mut curve = Vec::with_capacity(kmax);
    let mut retained = None;
    for k in 0..kmax {
        for t in 0..nt {
            let c = pod.time_coefficients[(t, k)];
            for i in 0..n {
                approx[(i, t)] += pod.modes[(i, k)] * c;
            }
        }
        let (w, _, _) = wnrmse(snapshots, approx.as_ref());
        curve.push(w);
        // Tolerate the round-off of the running sum at the target.
        let energy_ok = pod.cumulative_energy[k] >= energy_target - 1e-12;
        if retained.is_none() && energy_ok && wnrmse_target.is_none_or(|t| w <= t) {
            retained = Some(k + 1);
        }
    }
    let Some(retained) = retained else {
        return Err(Error::numerical(format!(
            "POD: no count of POMs up to {kmax} reaches energy {energy_target} {}",
            wnrmse_target
                .map(|t| format!("and WNRMSE ≤ {t}"))
                .unwrap_or_default()
        )));
    };
    Ok(PodCurve {
        wnrmse: curve,
        retained,
    })
}
