//! Parquet tables of the Bouc-Wen identification and the damage index
//! (schemas in docs/formats.md): `bouc_wen/bouc_wen.parquet`,
//! `bouc_wen_instantaneous/bouc_wen_instantaneous.parquet`, `hysteresis_fit/hysteresis_fit.parquet`,
//! `damage/damage.parquet`.

use std::path::Path;

use super::parquet::{write_parquet, TableBuilder};
use super::provenance::Provenance;
use crate::error::Result;
pub use crate::hysteresis::DirectionOutcome;
use crate::hysteresis::HystereticTerms;
use crate::vocab::tables::{
    bouc_wen, bouc_wen_instantaneous, damage, hysteresis_fit, BOUC_WEN, BOUC_WEN_INSTANTANEOUS,
    DAMAGE, HYSTERESIS_FIT,
};

/// The provenance of the identification tables: `event`'s history followed
/// by one `bouc_wen_identification` step whose parameters are the processing
/// of each identified direction (band, exponent search, segments).
pub fn identification_provenance(
    event: &crate::vocab::Event,
    outcomes: &[DirectionOutcome],
) -> Provenance {
    let processing: serde_json::Map<String, serde_json::Value> = outcomes
        .iter()
        .filter_map(|o| match o {
            DirectionOutcome::Identified(d) => Some((
                d.direction.clone(),
                serde_json::to_value(&d.processing).unwrap_or_default(),
            )),
            _ => None,
        })
        .collect();
    Provenance::of_event(event).then_step(
        "bouc_wen_identification",
        serde_json::Value::Object(processing),
    )
}

/// `bouc_wen/bouc_wen.parquet`: one row per direction, DoF and parameter (a direction
/// that could not be identified has one row with `status` saying why).
pub fn write_bouc_wen(
    path: &Path,
    outcomes: &[DirectionOutcome],
    extra_meta: &[(String, String)],
) -> Result<()> {
    let mut c = Cols::default();
    for o in outcomes {
        match o {
            DirectionOutcome::NotIdentifiable {
                direction,
                reason,
                f_test,
                measured,
                ..
            } => {
                let verdict = o.verdict().name();
                let energy = measured
                    .as_ref()
                    .map(|m| m.segment_work().iter().sum::<f64>());
                c.push_row(
                    direction,
                    -1,
                    "none",
                    None,
                    f64::NAN,
                    "",
                    None,
                    false,
                    f64::NAN,
                    f64::NAN,
                    f64::NAN,
                    "not_identifiable",
                    reason,
                );
                c.fill_dof(*f_test, None, verdict, (energy, None));
            }
            DirectionOutcome::Identified(d) => {
                let verdict = o.verdict().name();
                for dof in &d.dofs {
                    let st = dof.stability.as_ref();
                    let stable = st.map(|s| s.stable).unwrap_or(false);
                    let level = dof.dof as i32; // 1-based already
                    let (status, reason) = match &dof.hysteresis {
                        HystereticTerms::NotSignificant { reason } => {
                            ("no_significant_hysteresis", reason.as_str())
                        }
                        HystereticTerms::Significant if stable => ("identified", ""),
                        HystereticTerms::Significant => ("identified_unstable", ""),
                    };
                    for (i, r) in dof.coupled.iter().enumerate() {
                        let rs = st.and_then(|s| s.k0_rel_std.get(i).copied());
                        let rds = st.and_then(|s| s.k0_delta_rel_std.get(i).copied());
                        let r1 = *r as i32; // 1-based already
                        c.push_row(
                            &d.direction,
                            level,
                            "K0",
                            Some(r1),
                            dof.k0[i],
                            "N/m",
                            rs,
                            stable,
                            dof.cost,
                            dof.cost_relative,
                            dof.hysteretic_share,
                            status,
                            reason,
                        );
                        c.push_row(
                            &d.direction,
                            level,
                            "K0_delta",
                            Some(r1),
                            dof.k0_delta[i],
                            "N/m",
                            rds,
                            stable,
                            dof.cost,
                            dof.cost_relative,
                            dof.hysteretic_share,
                            status,
                            reason,
                        );
                        c.push_row(
                            &d.direction,
                            level,
                            "delta",
                            Some(r1),
                            dof.delta[i],
                            "1/J",
                            None,
                            stable,
                            dof.cost,
                            dof.cost_relative,
                            dof.hysteretic_share,
                            status,
                            reason,
                        );
                    }
                    c.push_row(
                        &d.direction,
                        level,
                        "beta",
                        None,
                        dof.beta,
                        "N^(1-N)/m",
                        st.map(|s| s.beta_rel_std),
                        stable,
                        dof.cost,
                        dof.cost_relative,
                        dof.hysteretic_share,
                        status,
                        reason,
                    );
                    c.push_row(
                        &d.direction,
                        level,
                        "gamma",
                        None,
                        dof.gamma,
                        "N^(1-N)/m",
                        st.map(|s| s.gamma_rel_std),
                        stable,
                        dof.cost,
                        dof.cost_relative,
                        dof.hysteretic_share,
                        status,
                        reason,
                    );
                    c.push_row(
                        &d.direction,
                        level,
                        "N",
                        None,
                        dof.exponent,
                        "-",
                        st.map(|s| s.exponent_std),
                        stable,
                        dof.cost,
                        dof.cost_relative,
                        dof.hysteretic_share,
                        status,
                        reason,
                    );
                    c.fill_dof(
                        Some((dof.significance.f_statistic, dof.significance.p_value)),
                        d.segments.get(dof.dof - 1).cloned(),
                        verdict,
                        (Some(dof.energy_record_j), Some(dof.energy_hysteretic_j)),
                    );
                }
            }
        }
    }
    let batch = TableBuilder::new(&BOUC_WEN)
        .str(bouc_wen::DIRECTION, &c.direction)
        .i32(bouc_wen::DOF, c.dof)
        .opt_str(bouc_wen::SEGMENT, &c.segment)
        .str(bouc_wen::PARAMETER, &c.parameter)
        .opt_i32(bouc_wen::COUPLED_DOF, c.coupled)
        .f64(bouc_wen::VALUE, c.value)
        .str(bouc_wen::UNIT, &c.unit)
        .opt_f64(bouc_wen::STABILITY_STD, c.stability)
        .bool(bouc_wen::STABLE, c.stable)
        .f64(bouc_wen::COST_J, c.cost)
        .f64(bouc_wen::COST_RELATIVE, c.cost_rel)
        .f64(bouc_wen::HYSTERETIC_SHARE, c.share)
        .str(bouc_wen::STATUS, &c.status)
        .str(bouc_wen::REASON, &c.reason)
        .str(bouc_wen::VERDICT, &c.verdict)
        .opt_f64(bouc_wen::F_STATISTIC, c.f_statistic)
        .opt_f64(bouc_wen::P_VALUE, c.p_value)
        .opt_f64(bouc_wen::ENERGY_RECORD_J, c.energy_record)
        .opt_f64(bouc_wen::ENERGY_HYSTERETIC_J, c.energy_hysteretic)
        .build()?;
    write_parquet(path, &[batch], extra_meta)
}

#[derive(Default)]
struct Cols {
    direction: Vec<String>,
    dof: Vec<i32>,
    parameter: Vec<String>,
    coupled: Vec<Option<i32>>,
    value: Vec<f64>,
    unit: Vec<String>,
    stability: Vec<Option<f64>>,
    stable: Vec<bool>,
    cost: Vec<f64>,
    cost_rel: Vec<f64>,
    share: Vec<f64>,
    status: Vec<String>,
    reason: Vec<String>,
    f_statistic: Vec<Option<f64>>,
    p_value: Vec<Option<f64>>,
    segment: Vec<Option<String>>,
    verdict: Vec<String>,
    energy_record: Vec<Option<f64>>,
    energy_hysteretic: Vec<Option<f64>>,
}

impl Cols {
    /// The F-test of the hysteretic terms, the segment of the DoF, the
    /// direction's verdict and the DoF's (E_rec, E_h), for the rows pushed
    /// since the last call.
    fn fill_dof(
        &mut self,
        test: Option<(f64, f64)>,
        segment: Option<String>,
        verdict: &str,
        energy: (Option<f64>, Option<f64>),
    ) {
        while self.f_statistic.len() < self.direction.len() {
            self.f_statistic.push(test.map(|t| t.0));
            self.p_value.push(test.map(|t| t.1));
            self.segment.push(segment.clone());
            self.verdict.push(verdict.to_string());
            self.energy_record.push(energy.0);
            self.energy_hysteretic.push(energy.1);
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn push_row(
        &mut self,
        direction: &str,
        dof: i32,
        parameter: &str,
        coupled: Option<i32>,
        value: f64,
        unit: &str,
        stability: Option<f64>,
        stable: bool,
        cost: f64,
        cost_rel: f64,
        share: f64,
        status: &str,
        reason: &str,
    ) {
        self.direction.push(direction.into());
        self.dof.push(dof);
        self.parameter.push(parameter.into());
        self.coupled.push(coupled);
        self.value.push(value);
        self.unit.push(unit.into());
        self.stability.push(stability);
        self.stable.push(stable);
        self.cost.push(cost);
        self.cost_rel.push(cost_rel);
        self.share.push(share);
        self.status.push(status.into());
        self.reason.push(reason.into());
    }
}

/// `bouc_wen_instantaneous/bouc_wen_instantaneous.parquet`: cumulative (t_e → t) estimates per frame.
pub fn write_instantaneous(
    path: &Path,
    outcomes: &[DirectionOutcome],
    metadata: &[(String, String)],
) -> Result<()> {
    let (mut dir, mut dof, mut t, mut inf, mut n, mut cost, mut k0, mut beta, mut gamma) = (
        vec![],
        vec![],
        vec![],
        vec![],
        vec![],
        vec![],
        vec![],
        vec![],
        vec![],
    );
    for o in outcomes {
        let DirectionOutcome::Identified(d) = o else {
            continue;
        };
        for f in &d.dofs {
            for e in &f.instantaneous {
                dir.push(d.direction.clone());
                dof.push(f.dof as i32);
                t.push(e.time_s);
                inf.push(e.informative);
                n.push(e.exponent);
                cost.push(e.cost);
                // K0_dd (own storey) is the last coupled entry (r = d).
                k0.push(e.k0.last().copied().unwrap_or(f64::NAN));
                beta.push(e.beta);
                gamma.push(e.gamma);
            }
        }
    }
    let batch = TableBuilder::new(&BOUC_WEN_INSTANTANEOUS)
        .str(bouc_wen_instantaneous::DIRECTION, &dir)
        .i32(bouc_wen_instantaneous::DOF, dof)
        .f64(bouc_wen_instantaneous::T_S, t)
        .bool(bouc_wen_instantaneous::INFORMATIVE, inf)
        .f64(bouc_wen_instantaneous::N_EXPONENT, n)
        .f64(bouc_wen_instantaneous::COST_J, cost)
        .f64(bouc_wen_instantaneous::K0_OWN_N_M, k0)
        .f64(bouc_wen_instantaneous::BETA, beta)
        .f64(bouc_wen_instantaneous::GAMMA, gamma)
        .build()?;
    write_parquet(path, &[batch], metadata)
}

/// Storey shears V_d = Σ_{r ≥ d} f_r of per-DoF forces f_r.
fn storey_shears(forces: &[&[f64]]) -> Vec<Vec<f64>> {
    let mut shears: Vec<Vec<f64>> = forces.iter().map(|f| f.to_vec()).collect();
    for d in (0..shears.len().saturating_sub(1)).rev() {
        let (lower, upper) = shears.split_at_mut(d + 1);
        for (v, above) in lower[d].iter_mut().zip(&upper[0]) {
            *v += above;
        }
    }
    shears
}

/// `hysteresis_fit/hysteresis_fit.parquet`: storey (segment) shear vs drift from the records
/// and, for identified directions, from the model — the force–drift loops.
/// A direction that is not identified contributes its measured loops when
/// its kinematics could be formed (model column null).
pub fn write_fit(
    path: &Path,
    outcomes: &[DirectionOutcome],
    decimate: usize,
    metadata: &[(String, String)],
) -> Result<()> {
    let step = decimate.max(1);
    let (mut dir, mut dof, mut seg, mut t, mut drift, mut fr, mut fm, mut energy) = (
        vec![],
        vec![],
        vec![],
        vec![],
        vec![],
        vec![],
        vec![],
        vec![],
    );
    for o in outcomes {
        // (direction, rate, start, segments, drifts, record forces, model forces)
        let (direction, fs, start_s, segments, drifts, record, model): (
            _,
            _,
            _,
            _,
            Vec<&[f64]>,
            _,
            _,
        ) = match o {
            DirectionOutcome::Identified(d) => (
                &d.direction,
                d.sampling_rate_hz,
                d.start_s,
                &d.segments,
                d.dofs
                    .iter()
                    .map(|f| f.fit.storey_drift.as_slice())
                    .collect(),
                storey_shears(
                    &d.dofs
                        .iter()
                        .map(|f| f.fit.force_record.as_slice())
                        .collect::<Vec<_>>(),
                ),
                Some(storey_shears(
                    &d.dofs
                        .iter()
                        .map(|f| f.fit.force_model.as_slice())
                        .collect::<Vec<_>>(),
                )),
            ),
            DirectionOutcome::NotIdentifiable {
                direction,
                measured: Some(m),
                ..
            } => (
                direction,
                m.sampling_rate_hz,
                m.start_s,
                &m.segments,
                m.storey_drift.iter().map(|v| v.as_slice()).collect(),
                storey_shears(
                    &m.restoring_force
                        .iter()
                        .map(|v| v.as_slice())
                        .collect::<Vec<_>>(),
                ),
                None,
            ),
            DirectionOutcome::NotIdentifiable { .. } => continue,
        };
        let dt = 1.0 / fs;
        for (d, storey_drift) in drifts.iter().enumerate() {
            let mut len = storey_drift.len().min(record[d].len());
            if let Some(m) = &model {
                len = len.min(m[d].len());
            }
            // E_rec(t) on every sample, decimated with the rows.
            let work =
                crate::hysteresis::energy::cumulative_work(&record[d][..len], &storey_drift[..len]);
            for i in (0..len).step_by(step) {
                dir.push(direction.clone());
                dof.push(d as i32 + 1);
                seg.push(
                    segments
                        .get(d)
                        .cloned()
                        .unwrap_or_else(|| format!("L{d}-L{}", d + 1)),
                );
                t.push(start_s + i as f64 * dt);
                drift.push(storey_drift[i]);
                fr.push(record[d][i]);
                fm.push(model.as_ref().map(|m| m[d][i]));
                energy.push(work[i]);
            }
        }
    }
    let batch = TableBuilder::new(&HYSTERESIS_FIT)
        .str(hysteresis_fit::DIRECTION, &dir)
        .i32(hysteresis_fit::DOF, dof)
        .str(hysteresis_fit::SEGMENT, &seg)
        .f64(hysteresis_fit::T_S, t)
        .f64(hysteresis_fit::DRIFT_M, drift)
        .f64(hysteresis_fit::FORCE_RECORD_N, fr)
        .opt_f64(hysteresis_fit::FORCE_MODEL_N, fm)
        .f64(hysteresis_fit::ENERGY_RECORD_J, energy)
        .build()?;
    write_parquet(path, &[batch], metadata)
}

/// `damage/damage.parquet`: ι(t) and, per mode, ω_s(t)/ω_s(0) and c_s(t) — one row
/// per direction, time and mode (ι repeated on the mode rows of one time).
pub fn write_damage(
    path: &Path,
    outcomes: &[DirectionOutcome],
    decimate: usize,
    metadata: &[(String, String)],
) -> Result<()> {
    let step = decimate.max(1);
    let (mut dir, mut t, mut iota, mut mode, mut omega, mut ratio, mut part) =
        (vec![], vec![], vec![], vec![], vec![], vec![], vec![]);
    let mut indefinite = serde_json::Map::new();
    for o in outcomes {
        let DirectionOutcome::Identified(d) = o else {
            continue;
        };
        let s = &d.damage;
        indefinite.insert(d.direction.clone(), serde_json::json!(s.indefinite_steps));
        let last = s.time_s.len().saturating_sub(1);
        for k in (0..s.time_s.len()).filter(|k| k % step == 0 || *k == last) {
            for m in 0..s.omega.len() {
                dir.push(d.direction.clone());
                t.push(s.time_s[k]);
                iota.push(s.iota[k]);
                mode.push(m as i32 + 1);
                omega.push(s.omega[m].get(k).copied().unwrap_or(f64::NAN));
                ratio.push(s.omega_ratio[m].get(k).copied().unwrap_or(f64::NAN));
                part.push(s.participation[m].get(k).copied().unwrap_or(f64::NAN));
            }
        }
    }
    let batch = TableBuilder::new(&DAMAGE)
        .str(damage::DIRECTION, &dir)
        .f64(damage::T_S, t)
        .f64(damage::IOTA, iota)
        .i32(damage::MODE, mode)
        .f64(damage::OMEGA_RAD_S, omega)
        .f64(damage::OMEGA_RATIO, ratio)
        .f64(damage::PARTICIPATION, part)
        .build()?;
    let mut meta = metadata.to_vec();
    meta.push((
        "quaketwin.indefinite_steps".into(),
        serde_json::Value::Object(indefinite).to_string(),
    ));
    write_parquet(path, &[batch], &meta)
}
