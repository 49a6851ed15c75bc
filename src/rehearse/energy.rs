//! Energy balance of a hybrid test (Mosqueda, Stojadinovic & Mahin 2005, 2007): the
//! spurious energy the actuators' tracking errors put into the hybrid system,
//!
//!   E_s(t) = Σ_k ½ (r_k + r_{k+1}) · [(d^m_{k+1} − d^m_k) − (d^c_{k+1} − d^c_k)],
//!
//! the work of the measured forces r on the difference between the measured (d^m) and the
//! commanded (d^c) displacement increments: the numerical model believes the specimen
//! absorbed Σ r·Δd^c, the specimen absorbed Σ r·Δd^m. E_s > 0 is energy injected (a lagging
//! actuator on an elastic specimen, Shing & Mahin 1987). The input energy of the ground
//! motion, E_in(t) = Σ_k ½ (f_k + f_{k+1}) · (x_{k+1} − x_k), normalises it:
//! energy error = max_t |E_s| / max_t |E_in|.

/// Running sums of the energy balance.
#[derive(Debug, Clone, Default)]
pub struct EnergyBalance {
    pub spurious: f64,
    pub input: f64,
    pub max_spurious: f64,
    pub max_input: f64,
}

impl EnergyBalance {
    /// One step: forces r_k, r_{k+1}, measured and commanded displacements before and after.
    pub fn add_actuators(
        &mut self,
        r0: &[f64],
        r1: &[f64],
        dm0: &[f64],
        dm1: &[f64],
        dc0: &[f64],
        dc1: &[f64],
    ) {
        let mut e = 0.0;
        for a in 0..r0.len() {
            e += 0.5 * (r0[a] + r1[a]) * ((dm1[a] - dm0[a]) - (dc1[a] - dc0[a]));
        }
        self.spurious += e;
        self.max_spurious = self.max_spurious.max(self.spurious.abs());
    }

    /// One step of the ground motion's work: loads f_k, f_{k+1}, displacements x_k, x_{k+1}.
    pub fn add_input(&mut self, f0: &[f64], f1: &[f64], x0: &[f64], x1: &[f64]) {
        let mut e = 0.0;
        for i in 0..f0.len() {
            e += 0.5 * (f0[i] + f1[i]) * (x1[i] - x0[i]);
        }
        self.input += e;
        self.max_input = self.max_input.max(self.input.abs());
    }

    /// max |E_s| / max |E_in| (0 without input energy).
    pub fn error(&self) -> f64 {
        if self.max_input > 0.0 {
            self.max_spurious / self.max_input
        } else {
            0.0
        }
    }
}
