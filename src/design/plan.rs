//! The whole test design, from a twin, a PS node set and a base motion to an actuator layout,
//! a validated reduction and a hybrid prototype (METHODS §5–6; thesis ch. 5–7). I/O free: the
//! design file, the event and the output tables live at the edges (`design::file`, the `design`
//! stage, `sinks::design_tables`).
//!
//! Steps:
//! 1. partition the twin (PS node set → PS elements, interface DoFs);
//! 2. reference response of the full twin to the base motion (Newmark), PS deformation
//!    snapshots after rigid-body removal (Eq. 50–51), POD (Eq. 56–58, 83–84);
//! 3. interface super-element (thesis ch. 5): the distributed interface is driven through a few
//!    control nodes, the rest of the interface follows piecewise-affinely; control nodes are
//!    inserted greedily where the retained POMs are worst interpolated, until the reduced model
//!    reproduces the reference PS response within the WNRMSE target;
//! 4. Guyan + rigid-body basis of the PS onto the control DoFs (Eq. 85–87), actuators on the
//!    control DoFs outside the constrained set, control modes and nominal gravity forces;
//! 5. Craig–Bampton prototype (Eq. 60–68), hybrid bandwidth and time scale λ.

use std::collections::{BTreeMap, BTreeSet};

use faer::Mat;

use super::craig_bampton::{recommend_hybrid, HybridRecommendation, HybridSettings};
use super::interface::{interface_chains, interface_nodes, InterfaceKinematics};
use super::layout::{
    compare_responses, congruence, interface_gravity_forces, reduction_basis, Actuator,
    ActuatorSettings, ControlMode, ReducedTwin, ReductionBasis, ReductionValidation,
};
use super::partition::{partition_by_node_ids, Partition};
use super::pod::{pod, reconstruction_quality, Pod, PodCurve};
use super::recorded::{expand_recorded_deformation, RecordedResponse};
use super::rigid::{
    rigid_body_modes, ConstrainedSet, RigidBodyModes, KERNEL_RELATIVE_TOLERANCE,
    MAX_CONSTRAINT_CONDITION,
};
use crate::error::{Error, Location};
use crate::twin::newmark::{newmark_base_excitation, rayleigh_coefficients, NewmarkSettings};
use crate::twin::objective::mac;
use crate::twin::sparse::CscMatrix;
use crate::twin::Twin;
use crate::Result;

/// One component of the base motion: twin axis (0 = x, 1 = y, 2 = z) and accelerations (m/s²)
/// at a common step.
#[derive(Debug, Clone)]
pub struct BaseComponent {
    pub axis: usize,
    pub acceleration: Vec<f64>,
}

/// The recorded (or prescribed) base motion driving the twin.
#[derive(Debug, Clone)]
pub struct BaseMotion {
    pub dt: f64,
    pub components: Vec<BaseComponent>,
    /// Where it came from (file, channel), for the outputs' metadata.
    pub source: String,
}

/// Settings of the design (the design file's `[pod]`, `[interface]`, `[actuators]`,
/// `[hybrid]`, `[damping]` tables).
#[derive(Debug, Clone)]
pub struct DesignSettings {
    /// Retain the fewest POMs whose cumulative energy reaches this (Eq. 56–58).
    pub energy_target: f64,
    /// POMs listed in `pod/pod.parquet` (at most).
    pub max_poms: usize,
    /// The reduced model must reproduce the reference PS response within this WNRMSE (Eq. 83).
    pub wnrmse_target: f64,
    /// Upper bound on interface control nodes (the search stops there with an error).
    pub max_control_nodes: usize,
    /// User-fixed control nodes (node ids) added before the greedy search (chain ends always are).
    pub control_nodes: Vec<i64>,
    /// Followers tried per refinement step (the worst interpolated ones); each costs one
    /// reduced-twin simulation. 1 = insert the worst interpolated node without trying.
    pub refinement_candidates: usize,
    /// Constrained set override: (node id, DoF name), one per rigid-body mode.
    pub constrained: Option<Vec<(i64, String)>>,
    /// Rayleigh damping ratio, fitted at the first and fourth full-model frequencies.
    pub damping_ratio: f64,
    /// Include the gravity state (nominal forces, static offsets).
    pub gravity: bool,
    pub actuators: ActuatorSettings,
    pub hybrid: HybridSettings,
}

impl Default for DesignSettings {
    fn default() -> Self {
        DesignSettings {
            energy_target: 0.999,
            max_poms: 10,
            wnrmse_target: 1e-2,
            max_control_nodes: 64,
            control_nodes: Vec::new(),
            refinement_candidates: 1,
            constrained: None,
            damping_ratio: 0.05,
            gravity: true,
            actuators: ActuatorSettings::default(),
            hybrid: HybridSettings::default(),
        }
    }
}

/// One step of the interface refinement (the trade-off curve of `interface_refinement/interface_refinement.parquet`).
#[derive(Debug, Clone)]
pub struct RefinementStep {
    pub control_nodes: usize,
    /// Coupled DoFs (control-node DoFs) and actuators (coupled DoFs outside the constrained set).
    pub coupled_dofs: usize,
    pub actuators: usize,
    /// WNRMSE of the reduced vs reference PS response: total displacement and deformation.
    pub wnrmse_total: f64,
    pub wnrmse_deformation: f64,
    /// Relative error of the reduced twin's first frequency, and the largest over the full
    /// twin's frequencies inside the band of interest (paired in ascending order).
    pub first_frequency_error: f64,
    pub band_frequency_error: f64,
}

/// Everything the design produces.
#[derive(Debug, Clone)]
pub struct TestDesign {
    pub partition: Partition,
    /// Rigid-body modes and constrained set in the interface-reduced PS coordinates
    /// (`interface.coordinates`).
    pub rigid: RigidBodyModes,
    pub constrained: ConstrainedSet,
    pub interface: InterfaceKinematics,
    pub pod: Pod,
    pub pod_curve: PodCurve,
    pub basis: ReductionBasis,
    pub actuators: Vec<Actuator>,
    pub validation: ReductionValidation,
    pub refinement: Vec<RefinementStep>,
    pub hybrid: HybridRecommendation,
    /// Full-twin eigenfrequencies used for damping and the prototype check (Hz).
    pub full_frequencies_hz: Vec<f64>,
    /// Where the POD snapshots came from ("twin response" or "records (…)").
    pub snapshot_source: String,
    /// With recorded snapshots: MAC between each recorded POM and the twin's POM of the same
    /// rank (how far the twin predicts the recorded deformation patterns).
    pub pom_mac: Option<Vec<f64>>,
    /// Rayleigh coefficients (a0, a1) of the reference response: C = a0 M + a1 K.
    pub rayleigh: (f64, f64),
}

/// Design a hybrid test of the PS `ps_node_ids` of `twin` under `motion` (see the module
/// notes for the steps), with snapshots from the twin's response. `source` names the design
/// file in errors.
pub fn design_hybrid_test(
    twin: &Twin,
    ps_node_ids: &[i64],
    motion: &BaseMotion,
    settings: &DesignSettings,
    source: &str,
) -> Result<TestDesign> {
    design_hybrid_test_with(twin, ps_node_ids, motion, None, settings, source)
}

/// As [`design_hybrid_test`]; when `recorded` is given, the POD snapshots come from the
/// recorded response expanded to the PS (`recorded::expand_recorded_deformation`, snapshot
/// source (b)) instead of the twin's, and the agreement of the two sets of POMs is reported
/// (MAC per retained POM). The reduced twin is still validated against the full twin under
/// `motion`.
pub fn design_hybrid_test_with(
    twin: &Twin,
    ps_node_ids: &[i64],
    motion: &BaseMotion,
    recorded: Option<&RecordedResponse>,
    settings: &DesignSettings,
    source: &str,
) -> Result<TestDesign> {
    let loc = || Location::file(source.to_string());
    let (Some(model), Some(map)) = (twin.model.as_ref(), twin.system.dofs.as_ref()) else {
        return Err(Error::input(
            loc(),
            format!(
                "test design needs a mesh twin (nodes and elements); {} is a matrix twin",
                twin.source
            ),
        ));
    };
    let sys = &twin.system;
    check_settings(settings, motion, source)?;
    let partition = partition_by_node_ids(model, map, ps_node_ids, source)?;
    let (k, m) = (sys.stiffness_at(&[]), sys.mass_at(&[]));

    // Full twin: frequencies (damping, prototype check) and the reference response.
    let want = 12.max(settings.max_poms).min(sys.n);
    let full_modes = sys.modes(&[], want)?;
    let full_frequencies_hz = full_modes.frequencies_hz();
    if full_frequencies_hz.is_empty() {
        return Err(Error::numerical(format!(
            "{}: the twin has no modes",
            twin.source
        )));
    }
    let (f_a, f_b) = (
        full_frequencies_hz[0],
        full_frequencies_hz[3.min(full_frequencies_hz.len() - 1)],
    );
    let rayleigh = if f_b > f_a {
        rayleigh_coefficients(f_a, f_b, settings.damping_ratio, settings.damping_ratio)?
    } else {
        (
            2.0 * settings.damping_ratio * 2.0 * std::f64::consts::PI * f_a,
            0.0,
        )
    };
    let excitations = motion
        .components
        .iter()
        .map(|c| sys.base_excitation(&[], c.axis, c.acceleration.clone()))
        .collect::<Result<Vec<_>>>()?;
    let newmark = NewmarkSettings {
        dt: motion.dt,
        rayleigh,
        record: Some(partition.ps_free.clone()),
    };
    let reference = newmark_base_excitation(&k, &m, &excitations, &newmark)?;
    let reference: Vec<Vec<f64>> = steps_by_position(&reference.displacement);

    // Rigid-body modes of the floating PS, the interface chains and the constrained set,
    // chosen among the chain ends (which every refinement keeps as control nodes).
    let rigid = rigid_body_modes(partition.ps_stiffness.as_ref(), KERNEL_RELATIVE_TOLERANCE)?;
    let chains = interface_chains(model, &partition);
    let on_interface = interface_nodes(&partition);
    let mut control: BTreeSet<usize> = BTreeSet::new();
    for &id in &settings.control_nodes {
        match model.node_index(id) {
            Some(n) if on_interface.binary_search(&n).is_ok() => {
                control.insert(n);
            }
            _ => {
                return Err(Error::input(
                    loc(),
                    format!("control node {id} is not an interface node of the PS"),
                ))
            }
        }
    }
    let initial = InterfaceKinematics::new(model, &partition, &chains, &control);
    let set = match &settings.constrained {
        Some(list) => {
            let mut positions = Vec::with_capacity(list.len());
            for (id, dof) in list {
                let node = model.node_index(*id);
                let d = model.dimension.dof_names().iter().position(|n| n == dof);
                let (Some(node), Some(d)) = (node, d) else {
                    return Err(Error::input(
                        loc(),
                        format!("constrained DoF {id}-{dof}: no such node or DoF in the twin"),
                    ));
                };
                let Some(p) = partition.position(node, d) else {
                    return Err(Error::input(
                        loc(),
                        format!("constrained DoF {id}-{dof} is not a DoF of the PS"),
                    ));
                };
                positions.push(p);
                if on_interface.binary_search(&node).is_ok() {
                    control.insert(node);
                }
            }
            ConstrainedSet::validated(&rigid, positions, MAX_CONSTRAINT_CONDITION)
                .map_err(|e| Error::input(loc(), e.to_string()))?
        }
        None => {
            let candidates: Vec<usize> = initial
                .coupled
                .iter()
                .map(|&j| initial.coordinates[j])
                .collect();
            ConstrainedSet::propose_among(&rigid, &candidates, MAX_CONSTRAINT_CONDITION)?
        }
    };

    // POD of the seismic deformation (gravity excluded, thesis §5.3.3), from the twin's
    // response or from the records expanded to the PS (re-expressed with the design's c).
    let (twin_snapshots, _) = set.deformation_snapshots(&rigid, &reference);
    let (snapshots, snapshot_source, twin_pod) = match recorded {
        None => (twin_snapshots, "twin response".to_string(), None),
        Some(rec) => {
            let expanded = expand_recorded_deformation(model, &partition, &rigid, rec)?;
            let (x, _) = set.deformation_snapshots(&rigid, &expanded.history);
            let label = format!(
                "records ({} DoFs measured: {})",
                expanded.sensed.len(),
                rec.source
            );
            (x, label, Some(pod(twin_snapshots.as_ref())?))
        }
    };
    let pod = pod(snapshots.as_ref())?;
    // With records: how far the twin predicts them (MAC of each POM with the twin's).
    let pom_mac = twin_pod.map(|twin_pod| {
        let rows = snapshots.nrows();
        (0..pod.singular_values.len().min(settings.max_poms))
            .map(|j| {
                let a: Vec<f64> = (0..rows).map(|i| pod.modes[(i, j)]).collect();
                let b: Vec<f64> = (0..rows).map(|i| twin_pod.modes[(i, j)]).collect();
                mac(&a, &b)
            })
            .collect::<Vec<f64>>()
    });
    let pod_curve = reconstruction_quality(
        snapshots.as_ref(),
        &pod,
        settings.max_poms,
        settings.energy_target,
        None,
    )?;
    // POMs over all PS positions, scaled by σ, for the interpolation error of the followers.
    // The full twin's mode shapes inside the band of interest join them (deformation part,
    // scaled to the first POM's weight) so that the refinement also serves the frequencies.
    let n_ps = partition.n_ps();
    let n_weighted = pod.singular_values.len().min(settings.max_poms.max(3));
    let band: Vec<usize> = (0..full_frequencies_hz.len())
        .filter(|&i| full_frequencies_hz[i] <= settings.hybrid.band_of_interest_hz)
        .collect();
    let band_shapes: Vec<Vec<f64>> = band
        .iter()
        .map(|&i| {
            let shape = partition.restrict(&full_modes.shape(i));
            let (bar, _) = set.remove(&rigid, &shape);
            let norm = bar.iter().map(|v| v * v).sum::<f64>().sqrt();
            let scale = if norm > 0.0 {
                pod.singular_values[0] / norm
            } else {
                0.0
            };
            bar.iter().map(|v| v * scale).collect()
        })
        .collect();
    let weighted_poms = Mat::from_fn(n_ps, n_weighted + band.len(), |p, j| {
        if j < n_weighted {
            set.retained
                .binary_search(&p)
                .map(|row| pod.modes[(row, j)] * pod.singular_values[j])
                .unwrap_or(0.0)
        } else {
            band_shapes[j - n_weighted][p]
        }
    });

    // Greedy refinement of the interface super-element: at each step the
    // `refinement_candidates` followers worst interpolated are tried and the one whose
    // reduced twin comes closest to the targets becomes a control node.
    let evaluate_control = |control: &BTreeSet<usize>| -> Result<Candidate> {
        let kin = InterfaceKinematics::new(model, &partition, &chains, control);
        let evaluation = evaluate(
            &k,
            &m,
            &partition,
            &rigid,
            &set,
            &kin,
            &excitations,
            &newmark,
            &reference,
            full_frequencies_hz.len(),
        )?;
        let step = RefinementStep {
            control_nodes: kin.control_nodes.len(),
            coupled_dofs: kin.coupled.len(),
            actuators: evaluation.basis.masters.len(),
            wnrmse_total: evaluation.validation.wnrmse_total,
            wnrmse_deformation: evaluation.validation.wnrmse,
            first_frequency_error: evaluation.frequencies_hz[0] / full_frequencies_hz[0] - 1.0,
            band_frequency_error: band_error(
                &full_frequencies_hz,
                &evaluation.frequencies_hz,
                &settings.hybrid,
            ),
        };
        Ok(Candidate {
            score: step.score(settings),
            kin,
            evaluation,
            step,
        })
    };
    let mut refinement = Vec::new();
    let mut current = evaluate_control(&control)?;
    let (interface, evaluation) = loop {
        refinement.push(current.step.clone());
        if current.score <= 1.0 {
            break (current.kin, current.evaluation);
        }
        let (kin, step) = (&current.kin, &current.step);
        let shortfall = format!(
            "PS deformation WNRMSE {:.3e} (total {:.3e}; target {:.1e}), frequencies below {} Hz within {:.2} % (target {:.2} %)",
            step.wnrmse_deformation,
            step.wnrmse_total,
            settings.wnrmse_target,
            settings.hybrid.band_of_interest_hz,
            100.0 * step.band_frequency_error,
            100.0 * settings.hybrid.accuracy
        );
        let candidates = worst_followers(
            kin,
            &partition,
            &weighted_poms,
            settings.refinement_candidates.max(1),
        );
        if candidates.is_empty() {
            return Err(Error::numerical(format!(
                "test design: every interface node is a control node ({} coupled DoFs) and the reduced twin still misses the targets: {shortfall}. What is left is the Guyan condensation of the PS interior (its inertia is condensed statically): narrow the band of interest or choose a smaller PS",
                kin.coupled.len()
            )));
        }
        if kin.control_nodes.len() >= settings.max_control_nodes {
            return Err(Error::numerical(format!(
                "test design: with {} interface control nodes ({} coupled DoFs) the reduced twin misses the targets: {shortfall}. Raise max_control_nodes or choose a PS with a shorter interface",
                kin.control_nodes.len(),
                kin.coupled.len()
            )));
        }
        let mut best: Option<(usize, Candidate)> = None;
        for node in candidates {
            let mut trial = control.clone();
            trial.insert(node);
            let candidate = evaluate_control(&trial)?;
            // Strictly better only: ties keep the earlier (worse-interpolated) candidate.
            if best.as_ref().is_none_or(|(_, b)| candidate.score < b.score) {
                best = Some((node, candidate));
            }
        }
        let Some((node, next)) = best else {
            return Err(Error::numerical("test design: no refinement candidate"));
        };
        control.insert(node);
        current = next;
    };

    // Actuators on the masters: nominal gravity forces, control modes, POM participation.
    let gravity_state = if settings.gravity {
        let ug = sys.gravity_response(&[])?.displacement;
        let ug_ps = partition.restrict(&ug);
        let fg = partition.ps_gravity_load(sys.gravity, |a| map.dimension.translation_dof(a));
        let f_int = interface_gravity_forces(&partition, &ug_ps, &fg);
        let (ug_bar, _) = set.remove(&rigid, &ug_ps);
        Some((ug_bar, f_int))
    } else {
        None
    };
    let actuators = actuators(
        model,
        &partition,
        &interface,
        &evaluation,
        &set,
        &snapshots,
        &pod,
        pod_curve.retained,
        gravity_state.as_ref(),
        &settings.actuators,
    );

    let ps_basis = &interface.map * &evaluation.basis.transformation;
    let hybrid = recommend_hybrid(
        &k,
        &m,
        &partition,
        ps_basis.as_ref(),
        &full_frequencies_hz,
        &settings.hybrid,
    )?;
    Ok(TestDesign {
        partition,
        rigid: evaluation.rigid.clone(),
        constrained: evaluation.set.clone(),
        interface,
        pod,
        pod_curve,
        basis: evaluation.basis,
        actuators,
        validation: evaluation.validation,
        refinement,
        hybrid,
        full_frequencies_hz,
        snapshot_source,
        pom_mac,
        rayleigh,
    })
}

/// Most time scales λ a design or a rehearsal sweeps (each is a simulation
/// of the whole base motion).
pub const MAX_TIME_SCALES: usize = 100;

fn check_settings(settings: &DesignSettings, motion: &BaseMotion, source: &str) -> Result<()> {
    let bad = |what: String| Err(Error::input(Location::file(source.to_string()), what));
    if !(settings.energy_target > 0.0 && settings.energy_target <= 1.0) {
        return bad(format!(
            "energy_target {} must lie in (0, 1]",
            settings.energy_target
        ));
    }
    if !(settings.wnrmse_target > 0.0) {
        return bad(format!(
            "wnrmse_target {} must be positive",
            settings.wnrmse_target
        ));
    }
    if !(settings.damping_ratio >= 0.0 && settings.damping_ratio < 1.0) {
        return bad(format!(
            "damping_ratio {} must lie in [0, 1)",
            settings.damping_ratio
        ));
    }
    // Counts beyond these are typos: each is a mode, node or simulation of
    // the twin (`twin::eigen::MAX_MODES` modes at most are solved for).
    let most = crate::twin::eigen::MAX_MODES;
    for (key, v) in [
        ("max_poms", settings.max_poms),
        ("refinement_candidates", settings.refinement_candidates),
        ("hybrid.max_ns_modes", settings.hybrid.max_ns_modes),
    ] {
        if v > most {
            return bad(format!("{key} = {v}: at most {most}"));
        }
    }
    if settings.max_poms == 0 {
        return bad("max_poms must be at least 1".into());
    }
    let scales = &settings.hybrid.time_scales;
    if scales.len() > MAX_TIME_SCALES || scales.iter().any(|l| !(l.is_finite() && *l > 0.0)) {
        return bad(format!(
            "hybrid.time_scales: at most {MAX_TIME_SCALES} positive finite time scales (got {})",
            scales.len()
        ));
    }
    if motion.components.is_empty() || !(motion.dt > 0.0) {
        return bad(format!(
            "base motion from {} has no samples or no time step",
            motion.source
        ));
    }
    if let Some(c) = motion.components.iter().find(|c| c.axis > 2) {
        return bad(format!("base motion axis {} (0 = x, 1 = y, 2 = z)", c.axis));
    }
    Ok(())
}

/// Largest relative error of the reduced frequencies against the full twin's inside the band
/// of interest (paired in ascending order; a missing one counts as +∞).
fn band_error(full: &[f64], reduced: &[f64], hybrid: &HybridSettings) -> f64 {
    full.iter()
        .enumerate()
        .filter(|(_, &f)| f <= hybrid.band_of_interest_hz)
        .map(|(i, &f)| {
            reduced
                .get(i)
                .map(|&r| (r - f).abs() / f)
                .unwrap_or(f64::INFINITY)
        })
        .fold(0.0, f64::max)
}

/// `[DoF][step]` → `[step][DoF]`.
fn steps_by_position(histories: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let steps = histories.first().map(|h| h.len()).unwrap_or(0);
    (0..steps)
        .map(|t| histories.iter().map(|h| h[t]).collect())
        .collect()
}

/// An evaluated interface with its refinement row and its score (≤ 1 meets every target).
struct Candidate {
    kin: InterfaceKinematics,
    evaluation: Evaluation,
    step: RefinementStep,
    score: f64,
}

impl RefinementStep {
    /// The worst ratio of the reduced twin's errors to their targets: ≤ 1 meets them all.
    fn score(&self, settings: &DesignSettings) -> f64 {
        (self.wnrmse_deformation / settings.wnrmse_target)
            .max(self.wnrmse_total / settings.wnrmse_target)
            .max(self.band_frequency_error / settings.hybrid.accuracy)
    }
}

/// One candidate interface: its reduced PS, basis, reduced-twin response and validation.
#[derive(Debug, Clone)]
struct Evaluation {
    /// Rigid-body modes and constrained set in the interface coordinates g.
    rigid: RigidBodyModes,
    set: ConstrainedSet,
    basis: ReductionBasis,
    validation: ReductionValidation,
    frequencies_hz: Vec<f64>,
}

/// Build the Guyan + rigid-body basis on the interface coordinates (masters = coupled DoFs
/// outside c) and validate the reduced twin against the reference.
#[allow(clippy::too_many_arguments)]
fn evaluate(
    k: &CscMatrix,
    m: &CscMatrix,
    partition: &Partition,
    rigid_full: &RigidBodyModes,
    set_full: &ConstrainedSet,
    kin: &InterfaceKinematics,
    excitations: &[crate::twin::newmark::BaseExcitation],
    newmark: &NewmarkSettings,
    reference: &[Vec<f64>],
    frequency_count: usize,
) -> Result<Evaluation> {
    let g = kin.map.as_ref();
    let k_g = congruence(partition.ps_stiffness.as_ref(), g);
    let m_g = congruence(partition.ps_mass.as_ref(), g);
    let rigid = rigid_body_modes(k_g.as_ref(), KERNEL_RELATIVE_TOLERANCE)?;
    if rigid.count() != rigid_full.count() {
        return Err(Error::numerical(format!(
            "test design: the interface super-element changes the PS's rigid-body modes ({} instead of {}); add control nodes on curved interfaces",
            rigid.count(),
            rigid_full.count()
        )));
    }
    let c_g = set_full
        .constrained
        .iter()
        .map(|p| kin.coordinates.binary_search(p))
        .collect::<std::result::Result<Vec<usize>, usize>>()
        .map_err(|_| {
            Error::numerical("test design: a constrained DoF follows the interface super-element")
        })?;
    let set = ConstrainedSet::validated(&rigid, c_g, MAX_CONSTRAINT_CONDITION)?;
    let masters: Vec<usize> = kin
        .coupled
        .iter()
        .copied()
        .filter(|j| !set.constrained.contains(j))
        .collect();
    let basis = reduction_basis(k_g.as_ref(), m_g.as_ref(), &rigid, &set, &masters)?;
    let ps_basis = g * &basis.transformation;
    let reduced_twin = ReducedTwin::new(k, m, partition, ps_basis.as_ref())?;
    let reduced = reduced_twin.response(excitations, newmark)?;
    let master_positions: Vec<usize> = masters.iter().map(|&j| kin.coordinates[j]).collect();
    let validation =
        compare_responses(rigid_full, set_full, reference, &reduced, &master_positions);
    let frequencies_hz = reduced_twin.frequencies_hz(frequency_count)?;
    Ok(Evaluation {
        rigid,
        set,
        basis,
        validation,
        frequencies_hz,
    })
}

/// The `count` follower interface nodes whose σ-weighted POMs (and in-band mode shapes) are
/// worst reproduced by the piecewise-affine interpolation between the current control nodes,
/// worst first (ties: smaller node index first).
fn worst_followers(
    kin: &InterfaceKinematics,
    partition: &Partition,
    weighted_poms: &Mat<f64>,
    count: usize,
) -> Vec<usize> {
    let restricted = Mat::from_fn(kin.coordinates.len(), weighted_poms.ncols(), |j, c| {
        weighted_poms[(kin.coordinates[j], c)]
    });
    let interpolated = &kin.map * &restricted;
    let mut error: BTreeMap<usize, f64> = BTreeMap::new();
    for (p, &(node, _)) in partition.ps_dofs.iter().enumerate() {
        let e: f64 = (0..weighted_poms.ncols())
            .map(|c| (weighted_poms[(p, c)] - interpolated[(p, c)]).powi(2))
            .sum();
        *error.entry(node).or_insert(0.0) += e;
    }
    let mut ranked: Vec<(usize, f64)> = kin
        .followers()
        .into_iter()
        .map(|n| (n, error.get(&n).copied().unwrap_or(0.0)))
        .collect();
    ranked.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    ranked.into_iter().take(count).map(|(n, _)| n).collect()
}

/// Actuators at the masters. Nominal force: the work-equivalent master force of the gravity
/// interface actions, f_m = (G T_d)ᵀ f_int (thesis ch. 7: the vertical actuators carry the
/// dome's weight). Control: force control when the DoF's seismic deformation varies by at
/// most `static_ratio` of its peak total deformation (gravity + seismic) and the nominal
/// force is not negligible; displacement control otherwise.
#[allow(clippy::too_many_arguments)]
fn actuators(
    model: &crate::twin::model::Model,
    partition: &Partition,
    kin: &InterfaceKinematics,
    evaluation: &Evaluation,
    set_full: &ConstrainedSet,
    snapshots: &Mat<f64>,
    pod: &Pod,
    retained: usize,
    gravity: Option<&(Vec<f64>, Vec<f64>)>,
    settings: &ActuatorSettings,
) -> Vec<Actuator> {
    let basis = &evaluation.basis;
    let set = &evaluation.set;
    // T_d over the PS coordinates (zero rows at c), then G T_d over the PS DoFs.
    let n_g = kin.coordinates.len();
    let nm = basis.masters.len();
    let mut t_d = Mat::<f64>::zeros(n_g, nm);
    for (row, &j) in set.retained.iter().enumerate() {
        for a in 0..nm {
            t_d[(j, a)] = basis.guyan[(row, a)];
        }
    }
    let gt_d = &kin.map * &t_d;
    let nt = snapshots.ncols();
    basis
        .masters
        .iter()
        .enumerate()
        .map(|(a, &j)| {
            let p = kin.coordinates[j];
            let row = set_full.retained.binary_search(&p).ok();
            let nominal_force = gravity
                .map(|(_, f_int)| {
                    (0..partition.n_ps())
                        .map(|q| gt_d[(q, a)] * f_int[q])
                        .sum::<f64>()
                })
                .unwrap_or(0.0);
            let static_part = gravity.map(|(ug_bar, _)| ug_bar[p]).unwrap_or(0.0);
            let x: Vec<f64> = row
                .map(|r| (0..nt).map(|t| snapshots[(r, t)]).collect())
                .unwrap_or_default();
            let mean = x.iter().sum::<f64>() / x.len().max(1) as f64;
            let std =
                (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / x.len().max(1) as f64).sqrt();
            let peak = x
                .iter()
                .fold(static_part.abs(), |acc, v| acc.max((static_part + v).abs()));
            let control = if std <= settings.static_ratio * peak
                && nominal_force.abs() > settings.min_force
            {
                ControlMode::Force
            } else {
                ControlMode::Displacement
            };
            let (node, dof) = partition.ps_dofs[p];
            Actuator {
                actuator: a + 1,
                ps_position: p,
                node,
                node_id: model.nodes.get(node).map(|n| n.id).unwrap_or(-1),
                direction: model
                    .dimension
                    .dof_names()
                    .get(dof)
                    .copied()
                    .unwrap_or("?")
                    .to_string(),
                control,
                nominal_force,
                participation: (0..retained)
                    .map(|c| row.map(|r| pod.modes[(r, c)]).unwrap_or(0.0))
                    .collect(),
            }
        })
        .collect()
}
