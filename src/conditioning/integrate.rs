//! Integration of acceleration to velocity and displacement with drift
//! control (METHODS §1: "integration to velocity and displacement with
//! drift control"; the nonlinear stage runs on "drift control only").
//!
//! Integration is the cumulative trapezoid rule in the time domain, from
//! rest (v(0) = 0, u(0) = 0). Drift control is one of:
//! - `Polynomial`: after each integration a least-squares polynomial is
//!   fitted to the result and removed, and its derivatives are removed from
//!   the lower derivatives too, so acceleration, velocity and displacement
//!   stay mutually consistent (to trapezoid-rule accuracy). This changes
//!   the acceleration by a low-order polynomial only (a constant for the
//!   default orders), which leaves hysteresis loops undistorted.
//! - `Highpass`: zero-phase Butterworth high-pass of the velocity and then
//!   of the displacement after each integration; acceleration is untouched
//!   (consistent when the acceleration was band-passed with the same corner).
//! - `None`: plain integration (drift grows with time).

use serde::{Deserialize, Serialize};

use super::baseline::{fit_polynomial, for_each_polynomial_value, PolynomialFit};
use super::butterworth::{butter_sos, BandType};
use super::sosfilt::sosfiltfilt;
use crate::error::{Error, Result};
use crate::numeric::{cumulative_trapezoid, RunningTrapezoid};
use crate::vocab::Samples;

/// How integration drift is controlled.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "method", rename_all = "snake_case", deny_unknown_fields)]
pub enum DriftControl {
    None,
    /// Consistent polynomial baseline removal (orders of the polynomials
    /// fitted to velocity and to displacement).
    Polynomial {
        velocity_order: usize,
        displacement_order: usize,
    },
    /// Zero-phase Butterworth high-pass after each integration.
    Highpass {
        corner_hz: f64,
        order: usize,
    },
}

impl DriftControl {
    /// Polynomial orders at most 10; a high-pass corner positive, order 1..=64.
    pub fn validate(&self) -> Result<()> {
        match *self {
            DriftControl::None => Ok(()),
            DriftControl::Polynomial {
                velocity_order,
                displacement_order,
            } if velocity_order > 10 || displacement_order > 10 => Err(Error::usage(format!(
                "drift control polynomial orders {velocity_order}/{displacement_order}: at most 10"
            ))),
            DriftControl::Polynomial { .. } => Ok(()),
            DriftControl::Highpass { corner_hz, order } => {
                if !(corner_hz.is_finite() && corner_hz > 0.0) || order == 0 || order > 64 {
                    Err(Error::usage(format!(
                        "drift control high-pass: corner {corner_hz} Hz must be positive and order {order} within 1..=64"
                    )))
                } else {
                    Ok(())
                }
            }
        }
    }
}

impl Default for DriftControl {
    fn default() -> Self {
        DriftControl::Polynomial {
            velocity_order: 1,
            displacement_order: 2,
        }
    }
}

/// Acceleration (m/s²), velocity (m/s) and displacement (m) of one channel
/// on the same time grid (in memory, or parked in the run's sample store:
/// [`crate::vocab::Samples`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    pub channel_id: String,
    /// Sampling interval, s.
    pub dt: f64,
    pub acceleration: Samples,
    pub velocity: Samples,
    pub displacement: Samples,
}

/// ds/dt of the scaled time s = 2 i/(n−1) − 1 the polynomials are fitted
/// against: 2 / ((n−1) dt).
fn scaled_time_rate(n: usize, dt: f64) -> f64 {
    if n > 1 {
        2.0 / ((n - 1) as f64 * dt)
    } else {
        0.0
    }
}

/// Removes a least-squares polynomial of `order` from `target` and its
/// time derivatives from `lower` (first derivative) and `lowest` (second).
fn remove_consistent_polynomial(
    target: &mut [f64],
    lower: &mut [f64],
    lowest: Option<&mut [f64]>,
    order: usize,
    dt: f64,
) -> Result<()> {
    let n = target.len();
    let coefficients = fit_polynomial(target, order)?;
    let ds_dt = scaled_time_rate(n, dt);
    let mut lowest = lowest;
    for_each_polynomial_value(&coefficients, n, |i, value, d1, d2| {
        target[i] -= value;
        lower[i] -= d1 * ds_dt;
        if let Some(lowest) = lowest.as_deref_mut() {
            lowest[i] -= d2 * ds_dt * ds_dt;
        }
    });
    Ok(())
}

/// Integrates acceleration to velocity and displacement with the chosen
/// drift control. Returns the (possibly baseline-corrected) acceleration
/// with the velocity and displacement.
pub fn integrate_motion(
    channel_id: &str,
    acceleration: &[f64],
    dt: f64,
    drift: &DriftControl,
) -> Result<Motion> {
    integrate_motion_of(channel_id, acceleration.to_vec(), dt, drift)
}

/// As [`integrate_motion`], taking the acceleration (no copy of a long record).
pub fn integrate_motion_of(
    channel_id: &str,
    acceleration: Vec<f64>,
    dt: f64,
    drift: &DriftControl,
) -> Result<Motion> {
    integrate_motion_parking(channel_id, acceleration, dt, drift, &|v| {
        Ok(Samples::new(v))
    })
}

/// As [`integrate_motion_of`], each series handed to `park` as soon as it is
/// final (the condition stage parks it in the run's spill file), so that a
/// day-long channel holds two series of its length at a time, not three:
/// with polynomial drift control the displacement's polynomial is fitted to
/// the displacement formed as it goes by (the same values, summed in the
/// same order), the acceleration takes its share of the correction and
/// goes, and only then is the displacement formed.  The values are those of
/// correcting all three series together; `park` returning the series in
/// memory gives [`integrate_motion_of`].
pub fn integrate_motion_parking(
    channel_id: &str,
    acceleration: Vec<f64>,
    dt: f64,
    drift: &DriftControl,
    park: &dyn Fn(Vec<f64>) -> Result<Samples>,
) -> Result<Motion> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(Error::usage(format!(
            "sampling interval must be positive, got {dt}"
        )));
    }
    let mut acc = acceleration;
    let n = acc.len();
    let mut vel = cumulative_trapezoid(&acc, dt);
    let (acceleration, velocity, displacement) = match drift {
        DriftControl::None => {
            let acceleration = park(acc)?;
            let disp = cumulative_trapezoid(&vel, dt);
            (acceleration, park(vel)?, park(disp)?)
        }
        DriftControl::Polynomial {
            velocity_order,
            displacement_order,
        } => {
            remove_consistent_polynomial(&mut vel, &mut acc, None, *velocity_order, dt)?;
            let mut fit = PolynomialFit::new(n, *displacement_order)?;
            let mut running = RunningTrapezoid::new(dt);
            for &v in &vel {
                fit.push(running.next(v));
            }
            let coefficients = fit.solve()?;
            let ds_dt = scaled_time_rate(n, dt);
            for_each_polynomial_value(&coefficients, n, |i, _, _, second| {
                acc[i] -= second * ds_dt * ds_dt;
            });
            let acceleration = park(acc)?;
            let mut disp = cumulative_trapezoid(&vel, dt);
            for_each_polynomial_value(&coefficients, n, |i, value, first, _| {
                disp[i] -= value;
                vel[i] -= first * ds_dt;
            });
            (acceleration, park(vel)?, park(disp)?)
        }
        DriftControl::Highpass { corner_hz, order } => {
            let acceleration = park(acc)?;
            let sos = butter_sos(*order, BandType::Highpass, &[*corner_hz], 1.0 / dt)?;
            vel = sosfiltfilt(&sos, &vel)?;
            let d = cumulative_trapezoid(&vel, dt);
            let velocity = park(vel)?;
            let disp = sosfiltfilt(&sos, &d)?;
            drop(d);
            (acceleration, velocity, park(disp)?)
        }
    };
    Ok(Motion {
        channel_id: channel_id.to_string(),
        dt,
        acceleration,
        velocity,
        displacement,
    })
}
