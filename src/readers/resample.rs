//! Uneven (time, value) samples onto a uniform grid — the one routine the
//! readers share (digitised-film SMC and CSMIP V1 pairs, CSV time columns),
//! with the bound that keeps a lying time column from allocating gigabytes,
//! and the median time step that gives the grid's interval when no rate is
//! stated.

/// The uniform grid may hold at most this many times the rows read: a time
/// column spanning 1e9 s over 200 rows is refused, not resampled.
pub const MAX_RESAMPLE_GROWTH: usize = 4;

/// Samples on the grid t0 + i·dt, i = 0..=floor(span/dt), as
/// [`resample_linear`] builds it (as f64, so an absurd span does not overflow).
pub fn grid_len(span: f64, dt: f64) -> f64 {
    (span / dt + 1e-9).floor() + 1.0
}

/// Refuses a grid larger than [`MAX_RESAMPLE_GROWTH`] × `rows` (or not
/// finite), with a message saying why; the caller names the file and line.
pub fn check_grid(rows: usize, span: f64, dt: f64) -> Result<usize, String> {
    let grid = grid_len(span, dt);
    let limit = (MAX_RESAMPLE_GROWTH * rows.max(1)) as f64;
    if grid.is_finite() && grid >= 1.0 && grid <= limit {
        Ok(grid as usize)
    } else {
        Err(format!(
            "the times span {span:e} s over {rows} samples: a uniform grid at dt = {dt:e} s would need {grid:e} samples, more than {MAX_RESAMPLE_GROWTH} × the samples read (a time far off the others?)"
        ))
    }
}

/// Linear interpolation of `(times, values)` (times increasing) onto
/// `t0, t0 + dt, …` up to the last time. Bound the grid with [`check_grid`]
/// first.
pub fn resample_linear(times: &[f64], values: &[f64], dt: f64) -> Vec<f64> {
    let (Some(&t0), Some(&t_end)) = (times.first(), times.last()) else {
        return Vec::new();
    };
    let n = grid_len(t_end - t0, dt) as usize;
    let mut out = Vec::with_capacity(n);
    let mut j = 0;
    for k in 0..n {
        let t = t0 + k as f64 * dt;
        while j + 2 < times.len() && times[j + 1] < t {
            j += 1;
        }
        if times.len() == 1 {
            out.push(values[0]);
            continue;
        }
        let (ta, tb) = (times[j], times[j + 1]);
        let w = if tb > ta {
            ((t - ta) / (tb - ta)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push(values[j] + w * (values[j + 1] - values[j]));
    }
    out
}

/// Median of successive differences of increasing times: the sampling
/// interval of uneven times when no rate is stated (NaN for fewer than two).
pub fn median_step(times: &[f64]) -> f64 {
    let mut d: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    if d.is_empty() {
        return f64::NAN;
    }
    d.sort_by(f64::total_cmp);
    let m = d.len() / 2;
    if d.len() % 2 == 1 {
        d[m]
    } else {
        0.5 * (d[m - 1] + d[m])
    }
}
