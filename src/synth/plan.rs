//! A shear building that also twists: rigid floors moving in plan, three
//! degrees of freedom per floor — the translations x, y of the floor's
//! centre of mass and the rotation θ about the vertical — so that sensors
//! at the corners of a floor see torsion (issue 13: a weakly excited
//! torsional mode).
//!
//! Model: storey s (between levels s−1 and s) is a lateral spring k_x,s,
//! k_y,s and a torsional spring k_θ,s acting at the storey's centre of
//! stiffness, the plan origin; the floors' centre of mass lies at the
//! eccentricity e = (e_x, e_y) from it.  With the degrees of freedom at the
//! centre of mass the mass matrix is diagonal, M = diag(m, m, J) per floor
//! (J the polar moment of inertia about the centre of mass), and a floor point
//! P moves as
//!   u_x(P) = u_x − θ (P_y − e_y),   u_y(P) = u_y + θ (P_x − e_x)
//! (rigid floor, small rotation).  At the stiffness centre (P = 0) this is
//! u_sc = T u with T = [[1, 0, e_y], [0, 1, −e_x], [0, 0, 1]], so
//! K = Tᵀ K_sc T, K_sc the shear chains of k_x, k_y and k_θ (each the
//! tridiagonal matrix of [`ShearBuilding::stiffness_matrix`]).  Eccentricity
//! couples translation and rotation: a torsional mode then carries a little
//! translation and is excited, weakly, by translational forces and by base
//! motion, neither of which has a torque of its own.
//!
//! Modal damping and the simulation are those of the shear building
//! ([`super::diagonal_mass_modes`], [`super::simulate_modal`]: the exact
//! zero-order-hold recursion of each mode).

use super::{
    ambient_response, check_dt, diagonal_mass_modes, simulate_modal, synthetic_channel,
    BuildingModes, ShearBuilding,
};
use crate::error::{Error, Result};
use crate::rng::Rng;
use crate::vocab::{Axis, Direction, Record};

/// Degrees of freedom per floor: x, y (m) and θ (rad), in this order.
pub const DOFS_PER_FLOOR: usize = 3;

/// Shear building with rigid floors moving in plan (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct PlanBuilding {
    /// Mass of floors 1..n, kg, bottom to top.
    pub masses_kg: Vec<f64>,
    /// Polar moment of inertia of each floor about its centre of mass, kg·m².
    pub rotational_inertia_kg_m2: Vec<f64>,
    /// Centre of mass of every floor relative to the storeys' centre of
    /// stiffness (the plan origin), m.
    pub mass_eccentricity_m: [f64; 2],
    /// Lateral stiffness of storeys 1..n along X and along Y, N/m.
    pub storey_stiffness_x_n_per_m: Vec<f64>,
    pub storey_stiffness_y_n_per_m: Vec<f64>,
    /// Torsional stiffness of storeys 1..n about the centre of stiffness, N·m/rad.
    pub storey_torsional_stiffness_n_m_per_rad: Vec<f64>,
    /// Modal damping ratio of each mode in ascending frequency order, or one
    /// value for all.
    pub damping_ratios: Vec<f64>,
}

/// Truth modal properties of a [`PlanBuilding`].
#[derive(Debug, Clone, PartialEq)]
pub struct PlanModes {
    /// Frequencies, damping ratios and mass-normalised shapes over the 3n
    /// degrees of freedom (floor i+1 at 3i + 0 = x, 3i + 1 = y, 3i + 2 = θ;
    /// each shape signed so that the roof rotation is non-negative);
    /// `participation` is for base motion along X.
    pub modes: BuildingModes,
    /// Participation factors for base motion along Y.
    pub participation_y: Vec<f64>,
    /// Share of each mode's kinetic energy in floor rotation, Σ J_i θ_ij²
    /// (shapes mass-normalised, so the total is 1): near 1 for a torsional
    /// mode, near 0 for a translational one.
    pub rotation_share: Vec<f64>,
}

/// Response of a [`PlanBuilding`].
#[derive(Debug, Clone, PartialEq)]
pub struct PlanResponse {
    pub dt: f64,
    /// Base acceleration along X and along Y, m/s² (zeros for ambient excitation).
    pub base_acceleration: [Vec<f64>; 2],
    /// Accelerations of the floors' degrees of freedom relative to the
    /// base, `[3(level − 1) + k][sample]` (k: 0 = x, 1 = y in m/s²; 2 = θ in rad/s²).
    pub relative_acceleration: Vec<Vec<f64>>,
    /// Displacements of the floors' degrees of freedom relative to the base,
    /// laid out as `relative_acceleration` (m; rad for θ).
    pub relative_displacement: Vec<Vec<f64>>,
    /// The building's centre of mass (the point the x, y DoFs refer to), m.
    pub mass_eccentricity_m: [f64; 2],
}

/// One horizontal accelerometer: level (0 = base), plan position and axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    pub id: String,
    pub level: usize,
    pub position_m: [f64; 2],
    /// `Axis::X` or `Axis::Y`.
    pub axis: Axis,
}

impl PlanBuilding {
    pub fn levels(&self) -> usize {
        self.masses_kg.len()
    }

    fn validate(&self) -> Result<()> {
        let n = self.levels();
        let lists = [
            &self.rotational_inertia_kg_m2,
            &self.storey_stiffness_x_n_per_m,
            &self.storey_stiffness_y_n_per_m,
            &self.storey_torsional_stiffness_n_m_per_rad,
        ];
        if n == 0 || lists.iter().any(|l| l.len() != n) {
            return Err(Error::usage(format!(
                "plan building: give masses, inertias and the three storey stiffnesses for every level (masses for {n} levels)"
            )));
        }
        if lists
            .iter()
            .flat_map(|l| l.iter())
            .chain(&self.masses_kg)
            .any(|v| !(v.is_finite() && *v > 0.0))
            || self.mass_eccentricity_m.iter().any(|e| !e.is_finite())
        {
            return Err(Error::usage(
                "plan building: masses, inertias and stiffnesses must be finite and positive, the eccentricity finite",
            ));
        }
        let dofs = DOFS_PER_FLOOR * n;
        if !(self.damping_ratios.len() == 1 || self.damping_ratios.len() == dofs)
            || self
                .damping_ratios
                .iter()
                .any(|z| !(z.is_finite() && (0.0..1.0).contains(z)))
        {
            return Err(Error::usage(format!(
                "plan building: give one damping ratio or one per mode ({dofs}), each in [0, 1)"
            )));
        }
        Ok(())
    }

    /// Diagonal of M: (m, m, J) per floor.
    fn mass_diagonal(&self) -> Vec<f64> {
        self.masses_kg
            .iter()
            .zip(&self.rotational_inertia_kg_m2)
            .flat_map(|(&m, &j)| [m, m, j])
            .collect()
    }

    /// Stiffness matrix K = Tᵀ K_sc T over the 3n DoFs (module doc).
    pub fn stiffness_matrix(&self) -> Vec<Vec<f64>> {
        let n = self.levels();
        let chain = |k: &Vec<f64>| {
            ShearBuilding {
                masses_kg: vec![1.0; n],
                storey_stiffness_n_per_m: k.clone(),
                damping_ratios: vec![0.0],
            }
            .stiffness_matrix()
        };
        let chains = [
            chain(&self.storey_stiffness_x_n_per_m),
            chain(&self.storey_stiffness_y_n_per_m),
            chain(&self.storey_torsional_stiffness_n_m_per_rad),
        ];
        let [ex, ey] = self.mass_eccentricity_m;
        // T per floor, rows = stiffness-centre components (x, y, θ).
        let t = [[1.0, 0.0, ey], [0.0, 1.0, -ex], [0.0, 0.0, 1.0]];
        let d = DOFS_PER_FLOOR;
        let mut kk = vec![vec![0.0; d * n]; d * n];
        for i in 0..n {
            for j in 0..n {
                // Block (i, j) = Tᵀ diag(kx_ij, ky_ij, kθ_ij) T.
                for a in 0..d {
                    for b in 0..d {
                        kk[d * i + a][d * j + b] =
                            (0..d).map(|c| t[c][a] * chains[c][i][j] * t[c][b]).sum();
                    }
                }
            }
        }
        kk
    }

    /// Undamped modes over the 3n DoFs ([`PlanModes`]).
    pub fn modes(&self) -> Result<PlanModes> {
        self.validate()?;
        let masses = self.mass_diagonal();
        let along = |axis: usize| -> Vec<f64> {
            (0..masses.len())
                .map(|k| if k % DOFS_PER_FLOOR == axis { 1.0 } else { 0.0 })
                .collect()
        };
        let modes = diagonal_mass_modes(
            &masses,
            &self.stiffness_matrix(),
            &self.damping_ratios,
            &along(0),
        )?;
        let r_y = along(1);
        let participation_y = modes
            .shapes
            .iter()
            .map(|phi| (0..masses.len()).map(|k| phi[k] * masses[k] * r_y[k]).sum())
            .collect();
        let rotation_share = modes
            .shapes
            .iter()
            .map(|phi| {
                (0..masses.len())
                    .filter(|k| k % DOFS_PER_FLOOR == 2)
                    .map(|k| masses[k] * phi[k] * phi[k])
                    .sum()
            })
            .collect();
        Ok(PlanModes {
            modes,
            participation_y,
            rotation_share,
        })
    }

    /// Response to base accelerations along X and Y (m/s², equal lengths)
    /// sampled at `dt`, starting at rest: modal loads
    /// p_j = −(Γ_x,j a_gx + Γ_y,j a_gy).
    pub fn simulate_base_motion(
        &self,
        base_x: &[f64],
        base_y: &[f64],
        dt: f64,
    ) -> Result<PlanResponse> {
        check_dt(dt)?;
        if base_x.len() != base_y.len() {
            return Err(Error::usage(format!(
                "plan building: base motions along X and Y differ in length ({} and {})",
                base_x.len(),
                base_y.len()
            )));
        }
        if base_x.iter().chain(base_y).any(|v| !v.is_finite()) {
            return Err(Error::usage("base acceleration contains non-finite values"));
        }
        let truth = self.modes()?;
        let (gx, gy) = (&truth.modes.participation, &truth.participation_y);
        let (disp, acc) = simulate_modal(&truth.modes, dt, base_x.len(), |j, k| {
            -(gx[j] * base_x[k] + gy[j] * base_y[k])
        });
        Ok(PlanResponse {
            dt,
            base_acceleration: [base_x.to_vec(), base_y.to_vec()],
            relative_acceleration: acc,
            relative_displacement: disp,
            mass_eccentricity_m: self.mass_eccentricity_m,
        })
    }

    /// Response to independent Gaussian white-noise forces along X and Y at
    /// every floor's centre of mass, standard deviation `force_std_n` (N),
    /// and torques of standard deviation `torque_std_n_m` (N·m; 0 = none, so
    /// that torsion is excited only through the eccentricity), held over each
    /// sample step; `n_samples` stationary samples at `dt` (the start-up
    /// transient is simulated and discarded, as [`ShearBuilding::simulate_ambient`]).
    pub fn simulate_ambient(
        &self,
        n_samples: usize,
        dt: f64,
        force_std_n: f64,
        torque_std_n_m: f64,
        rng: &mut Rng,
    ) -> Result<PlanResponse> {
        check_dt(dt)?;
        let valid = force_std_n.is_finite()
            && force_std_n > 0.0
            && torque_std_n_m.is_finite()
            && torque_std_n_m >= 0.0;
        if !valid {
            return Err(Error::usage(
                "ambient force standard deviation must be positive, the torque's non-negative",
            ));
        }
        let truth = self.modes()?;
        let load_std: Vec<f64> = (0..self.levels())
            .flat_map(|_| [force_std_n, force_std_n, torque_std_n_m])
            .collect();
        let (disp, acc, _) = ambient_response(&truth.modes, n_samples, dt, &load_std, rng);
        Ok(PlanResponse {
            dt,
            base_acceleration: [vec![0.0; n_samples], vec![0.0; n_samples]],
            relative_acceleration: acc,
            relative_displacement: disp,
            mass_eccentricity_m: self.mass_eccentricity_m,
        })
    }
}

impl PlanResponse {
    /// Absolute acceleration a sensor records (m/s²): at the base the base
    /// motion; on floor `level` at plan point P the rigid-floor motion
    /// a_x = ü_x − θ̈ (P_y − e_y) + a_gx, a_y = ü_y + θ̈ (P_x − e_x) + a_gy.
    pub fn sensor_acceleration(&self, sensor: &Sensor) -> Result<Vec<f64>> {
        let base = match sensor.axis {
            Axis::X => &self.base_acceleration[0],
            Axis::Y => &self.base_acceleration[1],
            Axis::Z => &self.base_acceleration[0], // refused below
        };
        let relative = self.rigid_floor_point(&self.relative_acceleration, sensor)?;
        Ok(match relative {
            None => base.clone(),
            Some(r) => r.iter().zip(base).map(|(a, g)| a + g).collect(),
        })
    }

    /// Displacement relative to the base at a sensor's point and axis (m):
    /// u_x − θ (P_y − e_y) or u_y + θ (P_x − e_x); zeros at the base.
    pub fn sensor_relative_displacement(&self, sensor: &Sensor) -> Result<Vec<f64>> {
        let n = self.base_acceleration[0].len();
        Ok(self
            .rigid_floor_point(&self.relative_displacement, sensor)?
            .unwrap_or_else(|| vec![0.0; n]))
    }

    /// The rigid-floor motion of `dofs` (relative to the base) at the
    /// sensor's point along its axis; `None` at the base (level 0).
    fn rigid_floor_point(&self, dofs: &[Vec<f64>], sensor: &Sensor) -> Result<Option<Vec<f64>>> {
        let k = match sensor.axis {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => {
                return Err(Error::usage(format!(
                    "sensor {}: the plan building has no vertical motion",
                    sensor.id
                )))
            }
        };
        if sensor.level == 0 {
            return Ok(None);
        }
        let first = DOFS_PER_FLOOR * (sensor.level - 1);
        let (u, theta) = match (dofs.get(first + k), dofs.get(first + 2)) {
            (Some(u), Some(theta)) => (u, theta),
            _ => {
                return Err(Error::usage(format!(
                    "sensor {}: level {} above the roof",
                    sensor.id, sensor.level
                )))
            }
        };
        let [px, py] = sensor.position_m;
        let [ex, ey] = self.mass_eccentricity_m;
        let arm = if k == 0 { -(py - ey) } else { px - ex };
        Ok(Some(
            u.iter().zip(theta).map(|(a, t)| a + arm * t).collect(),
        ))
    }

    /// Records as the instrumented building delivers them (m/s²): one per
    /// sensor, with its level, plan position and direction; base sensors
    /// (level 0) have role input, floor sensors role output.
    pub fn to_records(&self, sensors: &[Sensor]) -> Result<Vec<Record>> {
        sensors
            .iter()
            .map(|s| {
                let mut ch = synthetic_channel(&s.id, 1.0 / self.dt, s.level);
                ch.position_m = Some(s.position_m);
                ch.direction = Some(Direction::Axis(s.axis));
                Ok(Record::new(ch, self.sensor_acceleration(s)?))
            })
            .collect()
    }
}
