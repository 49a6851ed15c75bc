//! Updating objective: pair measured modes with model modes by MAC at the sensor DoFs, then
//! J (Eq. 5 of METHODS.md) over frequencies and ideal MAC = 1, and the normalised scatters
//! β (Eq. 3) that the Plackett–Luce voters use.

use super::assembly::TwinSystem;
use super::eigen::{EigenFailure, Modes};
use crate::error::{Error, Location};
use crate::Result;

/// One identified mode: frequency and shape components in `MeasuredModes::channels` order.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredMode {
    pub frequency_hz: f64,
    pub shape: Vec<f64>,
}

/// Measured modes (e.g. from the modal stage's modes/modes.parquet) on a set of channels.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredModes {
    /// Where the modes came from (for messages).
    pub source: String,
    pub channels: Vec<String>,
    pub modes: Vec<MeasuredMode>,
}

/// Modal assurance criterion MAC(a, b) = |aᵀb|² / ((aᵀa)(bᵀb)); 0 for a zero vector.
pub fn mac(a: &[f64], b: &[f64]) -> f64 {
    let ab: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    let aa: f64 = a.iter().map(|x| x * x).sum();
    let bb: f64 = b.iter().map(|x| x * x).sum();
    if aa > 0.0 && bb > 0.0 {
        ab * ab / (aa * bb)
    } else {
        0.0
    }
}

/// One measured mode and the model mode paired with it.
#[derive(Debug, Clone, PartialEq)]
pub struct ModePair {
    pub measured: usize,
    /// Index of the model mode (ascending frequency), None when no model mode was left.
    pub model: Option<usize>,
    pub f_exp: f64,
    pub f_num: f64,
    pub mac: f64,
}

/// Pair each measured mode with a distinct model mode by MAC: repeatedly take the
/// (measured, model) pair with the largest MAC among unpaired ones; ties go to the lower
/// measured index, then the model mode closest in frequency, then the lower model index.
pub fn pair_modes(
    measured: &[MeasuredMode],
    model_freqs: &[f64],
    model_shapes: &[Vec<f64>],
) -> Vec<ModePair> {
    let nm = measured.len();
    let nn = model_freqs.len().min(model_shapes.len());
    let macs: Vec<Vec<f64>> = measured
        .iter()
        .map(|m| (0..nn).map(|j| mac(&m.shape, &model_shapes[j])).collect())
        .collect();
    let mut pairs: Vec<ModePair> = measured
        .iter()
        .enumerate()
        .map(|(i, m)| ModePair {
            measured: i,
            model: None,
            f_exp: m.frequency_hz,
            f_num: 0.0,
            mac: 0.0,
        })
        .collect();
    let mut used_model = vec![false; nn];
    let mut done = vec![false; nm];
    for _ in 0..nm.min(nn) {
        let mut best: Option<(usize, usize)> = None;
        for i in 0..nm {
            if done[i] {
                continue;
            }
            for j in 0..nn {
                if used_model[j] {
                    continue;
                }
                let better = match best {
                    None => true,
                    Some((bi, bj)) => {
                        let (a, b) = (macs[i][j], macs[bi][bj]);
                        if a > b + 1e-12 {
                            true
                        } else if a < b - 1e-12 {
                            false
                        } else if i != bi {
                            false
                        } else {
                            (model_freqs[j] - measured[i].frequency_hz).abs()
                                < (model_freqs[bj] - measured[i].frequency_hz).abs()
                        }
                    }
                };
                if better {
                    best = Some((i, j));
                }
            }
        }
        let Some((i, j)) = best else { break };
        done[i] = true;
        used_model[j] = true;
        pairs[i].model = Some(j);
        pairs[i].f_num = model_freqs[j];
        pairs[i].mac = macs[i][j];
    }
    pairs
}

/// Normalised scatter β = |z_e − z_i| / (|z_e| + 1) (Eq. 3).
pub fn normalised_scatter(z_exp: f64, z_num: f64) -> f64 {
    (z_exp - z_num).abs() / (z_exp.abs() + 1.0)
}

/// J = (1/K) Σ_k (z_k,e − z_k,i)² (Eq. 5).
pub fn objective_eq5(z_exp: &[f64], z_num: &[f64]) -> f64 {
    if z_exp.is_empty() {
        return 0.0;
    }
    z_exp
        .iter()
        .zip(z_num)
        .map(|(e, n)| (e - n) * (e - n))
        .sum::<f64>()
        / z_exp.len() as f64
}

/// Result of evaluating the model at one parameter vector.
#[derive(Debug, Clone, PartialEq)]
pub struct Evaluation {
    /// J (Eq. 5); +∞ when the model could not be solved.
    pub objective: f64,
    /// Model quantities z_i: paired frequencies, then MAC values.
    pub z: Vec<f64>,
    pub pairs: Vec<ModePair>,
}

/// Settings of the modal objective.
#[derive(Debug, Clone)]
pub struct ObjectiveOptions {
    /// Model modes computed beyond the number of measured modes, as pairing candidates.
    pub extra_model_modes: usize,
}

impl Default for ObjectiveOptions {
    fn default() -> Self {
        ObjectiveOptions {
            extra_model_modes: 2,
        }
    }
}

/// Most model modes computed beyond the measured ones (`extra_model_modes`).
pub const MAX_EXTRA_MODEL_MODES: usize = 100;

impl ObjectiveOptions {
    /// Options the objective can use, else a usage error naming the key.
    pub fn validate(&self) -> crate::Result<()> {
        if self.extra_model_modes > MAX_EXTRA_MODEL_MODES {
            return Err(crate::Error::usage(format!(
                "update: extra_model_modes = {}: at most {MAX_EXTRA_MODEL_MODES}",
                self.extra_model_modes
            )));
        }
        Ok(())
    }
}

/// The modal updating objective of a twin against measured modes.
#[derive(Debug, Clone)]
pub struct ModalObjective<'a> {
    pub system: &'a TwinSystem,
    pub measured: MeasuredModes,
    /// For each measured channel, the twin sensor index.
    sensor_of_channel: Vec<usize>,
    pub options: ObjectiveOptions,
}

impl<'a> ModalObjective<'a> {
    /// Check that every measured channel is in the twin's sensor map and that shapes have one
    /// component per channel.
    pub fn new(
        system: &'a TwinSystem,
        measured: MeasuredModes,
        options: ObjectiveOptions,
    ) -> Result<Self> {
        if measured.modes.is_empty() {
            return Err(Error::input(
                Location::file(measured.source.clone()),
                "no measured modes to update against",
            ));
        }
        let mut sensor_of_channel = Vec::with_capacity(measured.channels.len());
        for ch in &measured.channels {
            let idx = system.sensor_index(ch).ok_or_else(|| {
                Error::input(
                    Location::file(system.source.clone()).with_channel(ch.clone()),
                    format!(
                        "measured channel {ch} (from {}) is not in the twin's sensor map",
                        measured.source
                    ),
                )
            })?;
            sensor_of_channel.push(idx);
        }
        for (i, m) in measured.modes.iter().enumerate() {
            if m.shape.len() != measured.channels.len() {
                return Err(Error::input(
                    Location::file(measured.source.clone()),
                    format!(
                        "mode {}: {} shape components for {} channels",
                        i + 1,
                        m.shape.len(),
                        measured.channels.len()
                    ),
                ));
            }
            if !(m.frequency_hz.is_finite() && m.frequency_hz > 0.0)
                || m.shape.iter().any(|v| !v.is_finite())
            {
                return Err(Error::input(
                    Location::file(measured.source.clone()),
                    format!(
                        "mode {}: non-finite or non-positive frequency or shape",
                        i + 1
                    ),
                ));
            }
        }
        Ok(ModalObjective {
            system,
            measured,
            sensor_of_channel,
            options,
        })
    }

    /// Measured quantities z_e: frequencies then ones (ideal MAC).
    pub fn measured_z(&self) -> Vec<f64> {
        let mut z: Vec<f64> = self.measured.modes.iter().map(|m| m.frequency_hz).collect();
        z.extend(std::iter::repeat(1.0).take(self.measured.modes.len()));
        z
    }

    /// Names of the voters (objectives), e.g. "f1", "MAC1".
    pub fn voter_names(&self) -> Vec<String> {
        let n = self.measured.modes.len();
        (1..=n)
            .map(|i| format!("f{i}"))
            .chain((1..=n).map(|i| format!("MAC{i}")))
            .collect()
    }

    pub fn model_mode_count(&self) -> usize {
        (self.measured.modes.len() + self.options.extra_model_modes).min(self.system.n)
    }

    /// Model modes at θ (dense or Lanczos by size), no bounds check.
    pub fn model_modes(&self, theta: &[f64]) -> std::result::Result<Modes, EigenFailure> {
        let count = self.model_mode_count();
        // Dense only for tiny models: for a few modes Lanczos is far cheaper.
        if self.system.n <= 4 * count + 20 {
            self.system.modes_unchecked_dense(theta, count)
        } else {
            self.system.modes_lanczos_cached(theta, count)
        }
    }

    /// Mode shapes read at the measured channels.
    pub fn shapes_at_sensors(&self, modes: &Modes) -> Vec<Vec<f64>> {
        (0..modes.count())
            .map(|j| {
                let col = modes.shape(j);
                self.sensor_of_channel
                    .iter()
                    .map(|&s| self.system.sensors[s].read(&col))
                    .collect()
            })
            .collect()
    }

    /// Evaluate J, z and the pairing at θ. A model that cannot be solved gives J = +∞.
    pub fn evaluate(&self, theta: &[f64]) -> Evaluation {
        let n = self.measured.modes.len();
        match self.model_modes(theta) {
            Ok(modes) => {
                let shapes = self.shapes_at_sensors(&modes);
                let pairs = pair_modes(&self.measured.modes, &modes.frequencies_hz(), &shapes);
                let mut z: Vec<f64> = pairs.iter().map(|p| p.f_num).collect();
                z.extend(pairs.iter().map(|p| p.mac));
                let objective = objective_eq5(&self.measured_z(), &z);
                Evaluation {
                    objective,
                    z,
                    pairs,
                }
            }
            Err(_) => Evaluation {
                objective: f64::INFINITY,
                z: vec![f64::NAN; 2 * n],
                pairs: Vec::new(),
            },
        }
    }

    /// J alone (what the optimisers minimise).
    pub fn value(&self, theta: &[f64]) -> f64 {
        self.evaluate(theta).objective
    }
}

/// Per-mode comparison for reporting (twin_modes/twin_modes.parquet): f_exp, f_num, MAC, errors.
#[derive(Debug, Clone, PartialEq)]
pub struct ModeComparison {
    pub pairs: Vec<ModePair>,
    /// Mean over modes of |f_exp − f_num| / f_exp.
    pub frequency_error: f64,
    /// Mean over modes of (1 − MAC).
    pub shape_error: f64,
}

pub fn compare_modes(pairs: &[ModePair]) -> ModeComparison {
    let n = pairs.len().max(1) as f64;
    let frequency_error = pairs
        .iter()
        .map(|p| (p.f_exp - p.f_num).abs() / p.f_exp)
        .sum::<f64>()
        / n;
    let shape_error = pairs.iter().map(|p| 1.0 - p.mac).sum::<f64>() / n;
    ModeComparison {
        pairs: pairs.to_vec(),
        frequency_error,
        shape_error,
    }
}
