//! Signal primitives shared by the method modules (conditioning, hysteresis):
//! small pure functions on sampled series, no I/O.

/// Cumulative trapezoid integral from zero: y[0] = 0,
/// y[i] = y[i−1] + dt (x[i−1] + x[i]) / 2, evaluated as `0.5 * dt * (x[i−1] + x[i])`
/// (the rounding every caller's results were computed with).  Empty in, empty out.
pub fn cumulative_trapezoid(data: &[f64], dt: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(data.len());
    let mut acc = 0.0;
    if let Some(&first) = data.first() {
        out.push(0.0);
        let mut prev = first;
        for &x in &data[1..] {
            acc += 0.5 * dt * (prev + x);
            out.push(acc);
            prev = x;
        }
    }
    out
}
