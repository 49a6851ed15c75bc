//! Work of a storey force along the storey drift: the energy the force–drift
//! loops enclose (METHODS.md §4). I/O free.
//!
//! E(t) = ∫₀ᵗ F dΔu, evaluated on the samples by the trapezoid rule on the
//! drift increments, Σ ½ (F_k + F_{k+1}) (Δu_{k+1} − Δu_k): no velocity needed,
//! and exact for a force linear in the drift (an elastic storey returns to
//! zero work when its drift does). Over closed loops the elastic part cancels
//! and E is the dissipated energy; at the end of a record E adds the elastic
//! energy still stored (½ k Δu² of a residual drift).

/// Cumulative work E(t_k) = ∫₀^{t_k} F dΔu, J (E(t_0) = 0).
pub fn cumulative_work(force: &[f64], drift: &[f64]) -> Vec<f64> {
    let n = force.len().min(drift.len());
    let mut out = Vec::with_capacity(n);
    let mut e = 0.0;
    for k in 0..n {
        if k > 0 {
            e += 0.5 * (force[k] + force[k - 1]) * (drift[k] - drift[k - 1]);
        }
        out.push(e);
    }
    out
}

/// Total work ∫ F dΔu over the samples, J (0 for fewer than two samples).
pub fn work(force: &[f64], drift: &[f64]) -> f64 {
    cumulative_work(force, drift).last().copied().unwrap_or(0.0)
}
