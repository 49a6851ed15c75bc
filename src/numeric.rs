//! Signal primitives shared by the method modules (conditioning, hysteresis):
//! small pure functions on sampled series, no I/O.

/// Cumulative trapezoid integral from zero: y[0] = 0,
/// y[i] = y[i−1] + dt (x[i−1] + x[i]) / 2, evaluated as `0.5 * dt * (x[i−1] + x[i])`
/// (the rounding every caller's results were computed with).  Empty in, empty out.
pub fn cumulative_trapezoid(data: &[f64], dt: f64) -> Vec<f64> {
    let mut running = RunningTrapezoid::new(dt);
    data.iter().map(|&x| running.next(x)).collect()
}

/// [`cumulative_trapezoid`] a sample at a time: the same operations, so the
/// same values, without the series — for integrals needed only as they go
/// by (a day-long record's velocity, formed twice rather than held).
#[derive(Debug, Clone)]
pub struct RunningTrapezoid {
    dt: f64,
    sum: f64,
    previous: Option<f64>,
}

impl RunningTrapezoid {
    pub fn new(dt: f64) -> Self {
        RunningTrapezoid {
            dt,
            sum: 0.0,
            previous: None,
        }
    }

    /// The integral up to the sample `x` (0 at the first sample).
    #[inline]
    pub fn next(&mut self, x: f64) -> f64 {
        if let Some(previous) = self.previous {
            self.sum += 0.5 * self.dt * (previous + x);
        }
        self.previous = Some(x);
        self.sum
    }
}
