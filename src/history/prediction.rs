//! Event-to-event prediction (issue 35; the `Prediction` of mdof): the
//! state-space model identified on one event predicts the response of the
//! structure to another event's ground motion, and the normalised error per
//! channel says how far the structure behaved as the model expects.
//! Numerical code only.
//!
//! The model is the modal realisation of the identified modes (docs/history.md,
//! Eqs. H7–H9).  The dataset keeps each event's modes (poles and shapes: A
//! and C of the subspace identification in modal coordinates) and its
//! conditioned records; B and D are not stored, so they are fitted here by
//! least squares on the model event's own records, given its A and C:
//!
//! (H7) ż_m = λ_m z_m + Σ_i β_mi u_i,  y_c = Σ_m 2 Re(φ_mc z_m) + Σ_i D_ci u_i,
//!      λ_m = −ζ_m ω_m + i ω_m √(1 − ζ_m²), ω_m = 2π f_m, φ_m the complex
//!      shape at the output channels, u_i the input (base) accelerations,
//!      y_c the absolute accelerations of the response channels; with a
//!      zero-order hold over a sample Δt: z_{k+1} = μ z_k + γ Σ_i β_mi u_{i,k},
//!      μ = e^{λΔt}, γ = (μ − 1)/λ, from rest (z_0 = 0);
//! (H8) y is linear in Re β, Im β and D: one least-squares problem over
//!      every output channel and sample of the model event (normal
//!      equations, a ridge of 10⁻¹⁰ of the mean diagonal against collinear
//!      inputs);
//! (H9) the model predicts another event from that event's inputs (its own
//!      Δt: the model is continuous in time); per output channel the
//!      normalised error ε_c = ‖y_c − ŷ_c‖₂ / ‖y_c‖₂ (0: a perfect
//!      prediction; 1: no better than predicting zero).
//!
//! What the model leaves out (modes not identified, channels dominated by
//! local motion) shows as a large ε on the model event itself: the model's
//! own error is reported beside the prediction's.

use faer::c64;

/// One event's conditioned records: inputs (base) and outputs (response),
/// sampled together every `dt` seconds.
#[derive(Debug, Clone, PartialEq)]
pub struct IoRecord {
    pub dt: f64,
    pub input_ids: Vec<String>,
    pub inputs: Vec<Vec<f64>>,
    pub output_ids: Vec<String>,
    pub outputs: Vec<Vec<f64>>,
}

/// A mode of the model: frequency, damping and shape at `shape_ids`.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalTerm {
    pub frequency_hz: f64,
    pub damping_ratio: f64,
    pub shape: Vec<c64>,
}

/// The fitted model (H7–H8).
#[derive(Debug, Clone, PartialEq)]
pub struct ModalModel {
    /// Continuous poles λ_m.
    pub poles: Vec<c64>,
    /// φ_m at `output_ids`.
    pub shapes: Vec<Vec<c64>>,
    pub output_ids: Vec<String>,
    pub input_ids: Vec<String>,
    /// β_mi.
    pub b: Vec<Vec<c64>>,
    /// D_ci.
    pub d: Vec<Vec<f64>>,
}

/// Per output channel, ε_c of H9.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelError {
    pub channel_id: String,
    pub normalised_error: f64,
}

fn pole(m: &ModalTerm) -> c64 {
    let w = std::f64::consts::TAU * m.frequency_hz;
    let z = m.damping_ratio.clamp(0.0, 0.999);
    c64::new(-z * w, w * (1.0 - z * z).sqrt())
}

/// (index in `ids`, index in the record's outputs) of each of `ids` the
/// record holds as an output, in the order of `ids`.
fn held_outputs(ids: &[String], record: &IoRecord) -> Vec<(usize, usize)> {
    ids.iter()
        .enumerate()
        .filter_map(|(k, id)| {
            record
                .output_ids
                .iter()
                .position(|o| o == id)
                .map(|o| (k, o))
        })
        .collect()
}

/// Samples every channel of `record` holds (the shortest channel).
fn common_length(record: &IoRecord) -> usize {
    record
        .inputs
        .iter()
        .chain(&record.outputs)
        .map(Vec::len)
        .min()
        .unwrap_or(0)
}

/// The unit responses w_mi (H7 with β = 1) of every mode to every input,
/// advanced one sample at a time: `visit(k, w, u_k)` sees w at sample k
/// (w[m][i]) and the inputs at k.
fn unit_responses(
    poles: &[c64],
    dt: f64,
    inputs: &[&[f64]],
    n: usize,
    mut visit: impl FnMut(usize, &[Vec<c64>], &[f64]),
) {
    let mu: Vec<c64> = poles.iter().map(|l| (*l * dt).exp()).collect();
    let gamma: Vec<c64> = poles
        .iter()
        .zip(&mu)
        .map(|(l, m)| (*m - c64::new(1.0, 0.0)) / *l)
        .collect();
    let mut w = vec![vec![c64::new(0.0, 0.0); inputs.len()]; poles.len()];
    let mut u = vec![0.0; inputs.len()];
    for k in 0..n {
        for (i, x) in inputs.iter().enumerate() {
            u[i] = x[k];
        }
        visit(k, &w, &u);
        for m in 0..poles.len() {
            for i in 0..inputs.len() {
                w[m][i] = mu[m] * w[m][i] + gamma[m] * u[i];
            }
        }
    }
}

/// Fits β and D (H8) on `record`, given the modes (A and C) identified on
/// it at `shape_ids`.  Errors say why no model can be fitted.
pub fn fit(
    terms: &[ModalTerm],
    shape_ids: &[String],
    record: &IoRecord,
) -> Result<ModalModel, String> {
    if terms.is_empty() {
        return Err("no mode identified".into());
    }
    if record.inputs.is_empty() {
        return Err("no input (base) channel".into());
    }
    if !(record.dt > 0.0 && record.dt.is_finite()) {
        return Err(format!("sampling interval {} s", record.dt));
    }
    // Outputs: the shape's channels the record holds.
    let outputs = held_outputs(shape_ids, record);
    if outputs.is_empty() {
        return Err("none of the modes' channels is among the record's outputs".into());
    }
    let n = common_length(record);
    let (modes, inputs_n, l) = (terms.len(), record.inputs.len(), outputs.len());
    let params = 2 * modes * inputs_n + l * inputs_n;
    if n < 4 * params {
        return Err(format!("{n} samples: too few for {params} parameters"));
    }
    let poles: Vec<c64> = terms.iter().map(pole).collect();
    let shapes: Vec<Vec<c64>> = terms
        .iter()
        .map(|t| {
            outputs
                .iter()
                .map(|&(s, _)| t.shape.get(s).copied().unwrap_or_default())
                .collect()
        })
        .collect();
    let inputs: Vec<&[f64]> = record.inputs.iter().map(|v| v.as_slice()).collect();
    let mut ata = vec![0.0; params * params];
    let mut aty = vec![0.0; params];
    let modal = 2 * modes * inputs_n;
    let mut row: Vec<(usize, f64)> = Vec::with_capacity(modal + inputs_n);
    unit_responses(&poles, record.dt, &inputs, n, |k, w, u| {
        for (c, &(_, o)) in outputs.iter().enumerate() {
            row.clear();
            for m in 0..modes {
                let phi = shapes[m][c];
                for i in 0..inputs_n {
                    let pw = phi * w[m][i];
                    let col = 2 * (m * inputs_n + i);
                    row.push((col, 2.0 * pw.re));
                    row.push((col + 1, -2.0 * pw.im));
                }
            }
            for (i, &ui) in u.iter().enumerate() {
                row.push((modal + c * inputs_n + i, ui));
            }
            let y = record.outputs[o][k];
            for &(a, va) in &row {
                aty[a] += va * y;
                for &(b, vb) in &row {
                    ata[a * params + b] += va * vb;
                }
            }
        }
    });
    let mean_diagonal = (0..params).map(|i| ata[i * params + i]).sum::<f64>() / params as f64;
    if !(mean_diagonal > 0.0 && mean_diagonal.is_finite()) {
        return Err("the records are zero or not finite".into());
    }
    let matrix = nalgebra::DMatrix::from_fn(params, params, |i, j| {
        ata[i * params + j] + if i == j { 1e-10 * mean_diagonal } else { 0.0 }
    });
    let theta = matrix
        .cholesky()
        .ok_or("the least-squares problem is singular")?
        .solve(&nalgebra::DVector::from_vec(aty));
    let b = (0..modes)
        .map(|m| {
            (0..inputs_n)
                .map(|i| {
                    let col = 2 * (m * inputs_n + i);
                    c64::new(theta[col], theta[col + 1])
                })
                .collect()
        })
        .collect();
    let d = (0..l)
        .map(|c| {
            (0..inputs_n)
                .map(|i| theta[modal + c * inputs_n + i])
                .collect()
        })
        .collect();
    Ok(ModalModel {
        poles,
        shapes,
        output_ids: outputs.iter().map(|&(s, _)| shape_ids[s].clone()).collect(),
        input_ids: record.input_ids.clone(),
        b,
        d,
    })
}

/// ŷ (H7) for `record`'s inputs, at the model's output channels the record
/// holds: (channel, measured, predicted).  An input of the model missing
/// from the record is an error naming it.
pub fn simulate(
    model: &ModalModel,
    record: &IoRecord,
) -> Result<Vec<(String, Vec<f64>, Vec<f64>)>, String> {
    let inputs: Vec<&[f64]> = model
        .input_ids
        .iter()
        .map(|id| {
            record
                .input_ids
                .iter()
                .position(|r| r == id)
                .map(|p| record.inputs[p].as_slice())
                .ok_or_else(|| format!("input channel {id} of the model is not in this event"))
        })
        .collect::<Result<_, _>>()?;
    let outputs = held_outputs(&model.output_ids, record);
    if outputs.is_empty() {
        return Err("none of the model's output channels is in this event".into());
    }
    if !(record.dt > 0.0 && record.dt.is_finite()) {
        return Err(format!("sampling interval {} s", record.dt));
    }
    let n = inputs
        .iter()
        .map(|x| x.len())
        .chain(outputs.iter().map(|&(_, o)| record.outputs[o].len()))
        .min()
        .unwrap_or(0);
    let mut predicted = vec![Vec::with_capacity(n); outputs.len()];
    unit_responses(&model.poles, record.dt, &inputs, n, |_, w, u| {
        for (p, &(c, _)) in predicted.iter_mut().zip(&outputs) {
            let mut y: f64 = model.d[c].iter().zip(u).map(|(d, x)| d * x).sum();
            for (m, wm) in w.iter().enumerate() {
                let z: c64 = wm
                    .iter()
                    .zip(&model.b[m])
                    .map(|(w, b)| *w * *b)
                    .fold(c64::new(0.0, 0.0), |a, x| a + x);
                y += 2.0 * (model.shapes[m][c] * z).re;
            }
            p.push(y);
        }
    });
    Ok(outputs
        .iter()
        .zip(predicted)
        .map(|(&(c, o), p)| {
            (
                model.output_ids[c].clone(),
                record.outputs[o][..n].to_vec(),
                p,
            )
        })
        .collect())
}

/// ε_c of H9 for every output channel of the model the record holds.
pub fn predict(model: &ModalModel, record: &IoRecord) -> Result<Vec<ChannelError>, String> {
    Ok(simulate(model, record)?
        .into_iter()
        .map(|(id, y, p)| ChannelError {
            channel_id: id,
            normalised_error: normalised_error(&y, &p),
        })
        .collect())
}

/// ‖y − ŷ‖₂ / ‖y‖₂ (NaN when y is zero).
pub fn normalised_error(measured: &[f64], predicted: &[f64]) -> f64 {
    let (mut e, mut s) = (0.0, 0.0);
    for (y, p) in measured.iter().zip(predicted) {
        e += (y - p) * (y - p);
        s += y * y;
    }
    if s > 0.0 {
        (e / s).sqrt()
    } else {
        f64::NAN
    }
}
