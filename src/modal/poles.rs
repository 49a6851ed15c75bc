//! Poles of a realisation → modal parameters, modal indicators (MAC, MPC,
//! MPD) and stabilisation flags between consecutive model orders (METHODS §2).

use faer::c64;

/// One identified pole of one model order (a point of the stabilisation diagram).
#[derive(Debug, Clone, PartialEq)]
pub struct Pole {
    pub order: usize,
    /// Undamped natural frequency |λ|/2π, Hz, with λ = ln(μ)/Δt.
    pub frequency_hz: f64,
    /// Damping ratio −Re(λ)/|λ|.
    pub damping_ratio: f64,
    /// Complex mode shape at the output channels, scaled so that its
    /// largest-modulus component is 1 + 0i.
    pub shape: Vec<c64>,
    /// Modal phase collinearity (1 = real, mono-phase mode).
    pub mpc: f64,
    /// Mean phase deviation from the best straight line, degrees.
    pub mpd_deg: f64,
    /// Frequency within tolerance of the matched pole of the previous order.
    pub stable_frequency: bool,
    /// Damping within tolerance of the matched pole of the previous order.
    pub stable_damping: bool,
    /// 1 − MAC with the matched pole of the previous order within tolerance.
    pub stable_shape: bool,
    /// Passes the physical filters (damping window, MPC, MPD, band).
    pub physical: bool,
    /// Index into `ModalResult::modes` of the mode this pole was assigned to.
    pub mode: Option<usize>,
}

impl Pole {
    /// Complexity 1 − MPC (0 for a classically damped mode).
    pub fn complexity(&self) -> f64 {
        1.0 - self.mpc
    }
    pub fn is_stable(&self) -> bool {
        self.stable_frequency && self.stable_damping && self.stable_shape
    }
}

/// Modal assurance criterion MAC(a, b) = |aᴴb|² / ((aᴴa)(bᴴb)).
pub fn mac(a: &[c64], b: &[c64]) -> f64 {
    let mut ab = c64::new(0.0, 0.0);
    let (mut aa, mut bb) = (0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        ab += x.conj() * y;
        aa += x.norm_sqr();
        bb += y.norm_sqr();
    }
    if aa <= 0.0 || bb <= 0.0 {
        return 0.0;
    }
    ab.norm_sqr() / (aa * bb)
}

/// MPC (Pappa et al. 1993): with S_xx = ‖Re φ‖², S_yy = ‖Im φ‖², S_xy = Re φ·Im φ,
/// MPC = ((S_xx − S_yy)² + 4 S_xy²) / (S_xx + S_yy)²; and MPD, the
/// modulus-weighted mean angle between the components and the principal
/// direction θ = ½ atan2(2S_xy, S_xx − S_yy), in degrees.
pub fn mpc_mpd(shape: &[c64]) -> (f64, f64) {
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for z in shape {
        sxx += z.re * z.re;
        syy += z.im * z.im;
        sxy += z.re * z.im;
    }
    let total = sxx + syy;
    if total <= 0.0 {
        return (0.0, 90.0);
    }
    let mpc = ((sxx - syy).powi(2) + 4.0 * sxy * sxy) / (total * total);
    let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let (mut weighted, mut weights) = (0.0, 0.0);
    for z in shape {
        let modulus = z.norm();
        if modulus == 0.0 {
            continue;
        }
        // Angle to the line through the origin at θ, folded into [0, π/2].
        let mut dev = (z.arg() - theta).rem_euclid(std::f64::consts::PI);
        if dev > std::f64::consts::FRAC_PI_2 {
            dev = std::f64::consts::PI - dev;
        }
        weighted += modulus * dev;
        weights += modulus;
    }
    (
        mpc,
        if weights > 0.0 {
            (weighted / weights).to_degrees()
        } else {
            90.0
        },
    )
}

/// Scales a shape so that its largest-modulus component is 1 + 0i.
pub fn normalise_shape(shape: &mut [c64]) {
    let mut best = c64::new(0.0, 0.0);
    for z in shape.iter() {
        if z.norm() > best.norm() {
            best = *z;
        }
    }
    if best.norm() > 0.0 {
        let inv = c64::new(1.0, 0.0) / best;
        shape.iter_mut().for_each(|z| *z *= inv);
    }
}

/// Continuous-time modal parameters of discrete eigenvalues: one pole per
/// complex-conjugate pair (Im μ > 0); real eigenvalues carry no oscillation
/// and are dropped.  λ = ln(μ)/Δt, f = |λ|/2π, ζ = −Re λ/|λ|.
pub fn poles_of_order(order: usize, eigen: Vec<(c64, Vec<c64>)>, dt: f64) -> Vec<Pole> {
    let mut poles = Vec::new();
    for (mu, mut shape) in eigen {
        if !(mu.im > 1e-12 * mu.norm().max(1e-300)) || mu.norm() <= 0.0 {
            continue;
        }
        let lambda = c64::new(mu.norm().ln(), mu.arg()) / dt;
        let omega = lambda.norm();
        if !(omega.is_finite() && omega > 0.0) {
            continue;
        }
        normalise_shape(&mut shape);
        let (mpc, mpd_deg) = mpc_mpd(&shape);
        poles.push(Pole {
            order,
            frequency_hz: omega / std::f64::consts::TAU,
            damping_ratio: -lambda.re / omega,
            shape,
            mpc,
            mpd_deg,
            stable_frequency: false,
            stable_damping: false,
            stable_shape: false,
            physical: false,
            mode: None,
        });
    }
    poles.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
    poles
}

/// Stabilisation tolerances (defaults 1 %, 5 %, 2 % as in the thesis).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StabilityTolerances {
    /// |f − f_prev| / f_prev.
    pub frequency: f64,
    /// |ζ − ζ_prev| / ζ_prev.
    pub damping: f64,
    /// 1 − MAC(φ, φ_prev).
    pub mac: f64,
}

impl Default for StabilityTolerances {
    fn default() -> Self {
        StabilityTolerances {
            frequency: 0.01,
            damping: 0.05,
            mac: 0.02,
        }
    }
}

/// Sets the stability flags of `current` against the poles of the previous
/// order: each pole is matched to the previous pole minimising
/// |Δf|/f + (1 − MAC), and each quantity is checked against its tolerance.
pub fn flag_stability(current: &mut [Pole], previous: &[Pole], tol: &StabilityTolerances) {
    for pole in current.iter_mut() {
        let mut best: Option<(&Pole, f64, f64)> = None;
        for prev in previous {
            let df = (pole.frequency_hz - prev.frequency_hz).abs() / prev.frequency_hz;
            if df > 0.2 {
                continue;
            }
            let one_minus_mac = 1.0 - mac(&pole.shape, &prev.shape);
            let score = df + one_minus_mac;
            if best.as_ref().is_none_or(|b| score < b.1 + b.2) {
                best = Some((prev, df, one_minus_mac));
            }
        }
        if let Some((prev, df, one_minus_mac)) = best {
            pole.stable_frequency = df <= tol.frequency;
            pole.stable_shape = one_minus_mac <= tol.mac;
            let dz = (pole.damping_ratio - prev.damping_ratio).abs()
                / prev.damping_ratio.abs().max(1e-12);
            pole.stable_damping = dz <= tol.damping;
        }
    }
}
