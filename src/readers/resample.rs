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

/// What [`clean_pair_times`] did to a series of (time, value) pairs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PairCleaning {
    /// Pairs whose time repeated the previous kept time: merged into it
    /// (the values averaged).
    pub merged_repeats: usize,
    /// Pairs whose time went back before the previous kept time: dropped.
    pub dropped_backwards: usize,
}

impl PairCleaning {
    pub fn is_clean(&self) -> bool {
        self.merged_repeats == 0 && self.dropped_backwards == 0
    }
    /// The note a reader attaches to the channel (the caller names the file).
    pub fn describe(&self, file: &str) -> String {
        format!(
            "{file}: {} repeated time stamp(s) merged (values averaged) and {} time stamp(s) going back in time dropped before resampling the (time, value) pairs (digitised-film pathology)",
            self.merged_repeats, self.dropped_backwards
        )
    }
}

/// Real digitised-film records (SMC V1, CSMIP V1 pairs) hold repeated and
/// occasionally backwards time stamps.  Makes the times strictly increasing:
/// a pair at the same time as the previous kept one is merged into it (mean
/// of the values, so no reading is preferred), a pair before it is dropped
/// (a digitiser slip: interpolating across it would fold the record).
pub fn clean_pair_times(times: &[f64], values: &[f64]) -> (Vec<f64>, Vec<f64>, PairCleaning) {
    let mut t_out: Vec<f64> = Vec::with_capacity(times.len());
    let mut v_out: Vec<f64> = Vec::with_capacity(times.len());
    let mut counts: Vec<usize> = Vec::with_capacity(times.len());
    let mut report = PairCleaning::default();
    for (&t, &v) in times.iter().zip(values) {
        match t_out.last() {
            Some(&last) if t == last => {
                let k = counts.len() - 1;
                let n = counts[k] as f64;
                v_out[k] = (v_out[k] * n + v) / (n + 1.0);
                counts[k] += 1;
                report.merged_repeats += 1;
            }
            Some(&last) if t < last => report.dropped_backwards += 1,
            _ => {
                t_out.push(t);
                v_out.push(v);
                counts.push(1);
            }
        }
    }
    (t_out, v_out, report)
}

/// Whether `times` read as the time column of (time, value) pairs: finite,
/// not negative at the start, ending after they start, and going forward
/// (or repeating) at nearly every step.  An evenly sampled acceleration
/// series misread as pairs puts accelerations in the time column, whose
/// steps go up and down about equally often.
pub fn looks_like_pair_times(times: &[f64]) -> bool {
    let (Some(&first), Some(&last)) = (times.first(), times.last()) else {
        return false;
    };
    if times.len() < 2 || !(first >= 0.0) || !(last > first) || times.iter().any(|t| !t.is_finite())
    {
        return false;
    }
    let steps = times.len() - 1;
    let forward_or_equal = times.windows(2).filter(|w| w[1] >= w[0]).count();
    let forward = times.windows(2).filter(|w| w[1] > w[0]).count();
    // At most 5 % of the steps backwards, at least half strictly forward.
    forward_or_equal * 20 >= steps * 19 && forward * 2 >= steps
}
