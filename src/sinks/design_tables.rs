//! Tables and matrices of the hybrid-test design (schemas in docs/test-design.md and
//! docs/formats.md): `actuator_layout/actuator_layout.parquet`, `pod/pod.parquet`, `reduction_validation/reduction_validation.parquet`,
//! `interface_refinement/interface_refinement.parquet`, `hybrid_prototype/hybrid_prototype.parquet`, and Matrix Market files of the
//! Craig–Bampton prototype (`prototype_stiffness.mtx`, `prototype_mass.mtx`, symmetric) and of
//! the PS basis u_PS = T q (`ps_basis.mtx`, general). Every file is written atomically.

use std::path::{Path, PathBuf};

use super::matrix_market::{write_matrix_market_general, write_matrix_market_symmetric};
use super::parquet::{write_parquet, TableBuilder};
use crate::design::plan::TestDesign;
use crate::error::Result;
use crate::twin::model::Model;
use crate::twin::sparse::CscMatrix;
use crate::vocab::tables::{
    actuator_layout, hybrid_prototype, interface_refinement, pod, reduction_validation,
    ACTUATOR_LAYOUT, HYBRID_PROTOTYPE, INTERFACE_REFINEMENT, POD, REDUCTION_VALIDATION,
};

pub const ACTUATOR_LAYOUT_FILE: &str = ACTUATOR_LAYOUT.file;
pub const POD_FILE: &str = POD.file;
pub const REDUCTION_VALIDATION_FILE: &str = REDUCTION_VALIDATION.file;
pub const INTERFACE_REFINEMENT_FILE: &str = INTERFACE_REFINEMENT.file;
pub const HYBRID_PROTOTYPE_FILE: &str = HYBRID_PROTOTYPE.file;
pub const PROTOTYPE_STIFFNESS_FILE: &str = "prototype_stiffness.mtx";
pub const PROTOTYPE_MASS_FILE: &str = "prototype_mass.mtx";
pub const PS_BASIS_FILE: &str = "ps_basis.mtx";

/// Every file `write_design` writes, in order.
pub const DESIGN_FILES: &[&str] = &[
    ACTUATOR_LAYOUT_FILE,
    POD_FILE,
    REDUCTION_VALIDATION_FILE,
    INTERFACE_REFINEMENT_FILE,
    HYBRID_PROTOTYPE_FILE,
    PROTOTYPE_STIFFNESS_FILE,
    PROTOTYPE_MASS_FILE,
    PS_BASIS_FILE,
];

/// Metadata key of the overall WNRMSE (deformation) in reduction_validation/reduction_validation.parquet.
pub const WNRMSE_KEY: &str = "quaketwin.wnrmse";
/// Metadata key of the overall WNRMSE of the total displacement.
pub const WNRMSE_TOTAL_KEY: &str = "quaketwin.wnrmse_total";

/// Where a design came from: recorded in every table's metadata.
#[derive(Debug, Clone, Default)]
pub struct DesignProvenance {
    pub design_file: String,
    pub twin: String,
    pub motion_source: String,
    /// The design settings as JSON (`design_file::settings_json`).
    pub settings_json: String,
}

/// Metadata of every design table (the schema name comes from the declaration).
fn meta(p: &DesignProvenance) -> Vec<(String, String)> {
    vec![
        ("quaketwin.design_file".into(), p.design_file.clone()),
        ("quaketwin.twin".into(), p.twin.clone()),
        ("quaketwin.motion".into(), p.motion_source.clone()),
        ("quaketwin.settings".into(), p.settings_json.clone()),
    ]
}

/// Node id and DoF name of a PS position.
fn dof_of(model: &Model, d: &TestDesign, p: usize) -> (i64, String) {
    let Some(&(node, dof)) = d.partition.ps_dofs.get(p) else {
        return (-1, "?".into());
    };
    (
        model.nodes.get(node).map(|n| n.id).unwrap_or(-1),
        model
            .dimension
            .dof_names()
            .get(dof)
            .copied()
            .unwrap_or("?")
            .to_string(),
    )
}

/// Metadata key of the node coordinates a drawing of the actuator layout needs.
pub const NODES_KEY: &str = "quaketwin.nodes";

/// Most twin nodes listed under [`NODES_KEY`]; a larger twin lists its PS nodes only.
const MAX_LISTED_NODES: usize = 20_000;

/// The twin's nodes `[id, x, y, z]` (all, or the PS's beyond
/// [`MAX_LISTED_NODES`]) and the ids of the PS nodes, as JSON: what the
/// report draws the actuator layout on.
fn nodes_json(model: &Model, d: &TestDesign) -> String {
    let mut ps: Vec<usize> = d.partition.ps_dofs.iter().map(|&(n, _)| n).collect();
    ps.sort_unstable();
    ps.dedup();
    let listed: Vec<usize> = if model.nodes.len() <= MAX_LISTED_NODES {
        (0..model.nodes.len()).collect()
    } else {
        ps.clone()
    };
    let node = |i: usize| {
        let n = &model.nodes[i];
        serde_json::json!([n.id, n.coords[0], n.coords[1], n.coords[2]])
    };
    serde_json::json!({
        "nodes": listed.iter().filter(|&&i| i < model.nodes.len()).map(|&i| node(i)).collect::<Vec<_>>(),
        "ps_nodes": ps.iter().filter_map(|&i| model.nodes.get(i).map(|n| n.id)).collect::<Vec<_>>(),
    })
    .to_string()
}

/// `actuator_layout/actuator_layout.parquet`: one row per actuator; `pom_1` … `pom_k` hold each retained
/// POM's component at the actuated DoF; the node coordinates in [`NODES_KEY`].
pub fn write_actuator_layout(
    path: &Path,
    model: &Model,
    d: &TestDesign,
    p: &DesignProvenance,
) -> Result<()> {
    let a = &d.actuators;
    let k = a.iter().map(|x| x.participation.len()).max().unwrap_or(0);
    let mut t = TableBuilder::new(&ACTUATOR_LAYOUT)
        .u32(
            actuator_layout::ACTUATOR,
            a.iter().map(|x| x.actuator as u32).collect(),
        )
        .i64(
            actuator_layout::NODE_ID,
            a.iter().map(|x| x.node_id).collect(),
        )
        .str(
            actuator_layout::DIRECTION,
            &a.iter().map(|x| x.direction.as_str()).collect::<Vec<_>>(),
        )
        .str(
            actuator_layout::CONTROL_MODE,
            &a.iter().map(|x| x.control.name()).collect::<Vec<_>>(),
        )
        .f64(
            actuator_layout::NOMINAL_FORCE_N,
            a.iter().map(|x| x.nominal_force).collect(),
        );
    for j in 0..k {
        t = t.f64(
            actuator_layout::POM.member(&(j + 1).to_string()),
            a.iter()
                .map(|x| x.participation.get(j).copied().unwrap_or(0.0))
                .collect(),
        );
    }
    let mut m = meta(p);
    m.push(("quaketwin.retained_poms".into(), k.to_string()));
    m.push((NODES_KEY.into(), nodes_json(model, d)));
    write_parquet(path, &[t.build()?], &m)
}

/// `pod/pod.parquet`: one row per listed POM.
pub fn write_pod(path: &Path, d: &TestDesign, p: &DesignProvenance) -> Result<()> {
    let pod = &d.pod;
    let n = d.pod_curve.wnrmse.len().min(pod.singular_values.len());
    let batch = TableBuilder::new(&POD)
        .u32(pod::POM, (1..=n as u32).collect())
        .f64(pod::SINGULAR_VALUE, pod.singular_values[..n].to_vec())
        .f64(pod::ENERGY_FRACTION, pod.energy_fraction[..n].to_vec())
        .f64(pod::CUMULATIVE_ENERGY, pod.cumulative_energy[..n].to_vec())
        .f64(pod::WNRMSE, d.pod_curve.wnrmse[..n].to_vec())
        .bool(
            pod::RETAINED,
            (1..=n).map(|i| i <= d.pod_curve.retained).collect(),
        )
        .build()?;
    let mut m = meta(p);
    m.push((
        "quaketwin.retained_poms".into(),
        d.pod_curve.retained.to_string(),
    ));
    m.push((
        "quaketwin.snapshot_dofs".into(),
        d.pod.modes.nrows().to_string(),
    ));
    m.push((
        "quaketwin.snapshot_source".into(),
        d.snapshot_source.clone(),
    ));
    if let Some(mac) = &d.pom_mac {
        // MAC of each recorded POM with the twin's POM of the same rank (JSON array).
        m.push((
            "quaketwin.pom_mac_with_twin".into(),
            serde_json::to_string(mac).unwrap_or_default(),
        ));
    }
    write_parquet(path, &[batch], &m)
}

/// `reduction_validation/reduction_validation.parquet`: one row per retained PS DoF; the overall WNRMSE (deformation
/// and total displacement) in the metadata.
pub fn write_reduction_validation(
    path: &Path,
    model: &Model,
    d: &TestDesign,
    p: &DesignProvenance,
) -> Result<()> {
    let v = &d.validation;
    let dofs: Vec<(i64, String)> = v.positions.iter().map(|&q| dof_of(model, d, q)).collect();
    let batch = TableBuilder::new(&REDUCTION_VALIDATION)
        .i64(
            reduction_validation::NODE_ID,
            dofs.iter().map(|x| x.0).collect(),
        )
        .str(
            reduction_validation::DIRECTION,
            &dofs.iter().map(|x| x.1.as_str()).collect::<Vec<_>>(),
        )
        .f64(reduction_validation::NRMSE, v.nrmse.clone())
        .f64(reduction_validation::WEIGHT, v.weight.clone())
        .bool(reduction_validation::IS_MASTER, v.is_master.clone())
        .build()?;
    let mut m = meta(p);
    m.push((WNRMSE_KEY.into(), format!("{:e}", v.wnrmse)));
    m.push((WNRMSE_TOTAL_KEY.into(), format!("{:e}", v.wnrmse_total)));
    m.push((
        "quaketwin.relative_max_error_total".into(),
        format!("{:e}", v.relative_max_error_total),
    ));
    write_parquet(path, &[batch], &m)
}

/// `interface_refinement/interface_refinement.parquet`: one row per step of the interface refinement.
pub fn write_interface_refinement(path: &Path, d: &TestDesign, p: &DesignProvenance) -> Result<()> {
    let r = &d.refinement;
    let batch = TableBuilder::new(&INTERFACE_REFINEMENT)
        .u32(interface_refinement::STEP, (1..=r.len() as u32).collect())
        .u32(
            interface_refinement::CONTROL_NODES,
            r.iter().map(|x| x.control_nodes as u32).collect(),
        )
        .u32(
            interface_refinement::COUPLED_DOFS,
            r.iter().map(|x| x.coupled_dofs as u32).collect(),
        )
        .u32(
            interface_refinement::ACTUATORS,
            r.iter().map(|x| x.actuators as u32).collect(),
        )
        .f64(
            interface_refinement::WNRMSE_TOTAL,
            r.iter().map(|x| x.wnrmse_total).collect(),
        )
        .f64(
            interface_refinement::WNRMSE_DEFORMATION,
            r.iter().map(|x| x.wnrmse_deformation).collect(),
        )
        .f64(
            interface_refinement::FIRST_FREQUENCY_ERROR,
            r.iter().map(|x| x.first_frequency_error).collect(),
        )
        .build()?;
    write_parquet(path, &[batch], &meta(p))
}

/// `hybrid_prototype/hybrid_prototype.parquet`: one row per prototype eigenfrequency, paired in ascending order
/// with the full model's; the recommendation (NS modes, λ, bandwidth) on every row and in the
/// metadata.
pub fn write_hybrid_prototype(path: &Path, d: &TestDesign, p: &DesignProvenance) -> Result<()> {
    let h = &d.hybrid;
    let f = &h.prototype.frequencies_hz;
    let n = f.len();
    let full: Vec<Option<f64>> = (0..n)
        .map(|i| d.full_frequencies_hz.get(i).copied())
        .collect();
    let error: Vec<Option<f64>> = (0..n)
        .map(|i| full[i].filter(|&x| x > 0.0).map(|x| (f[i] - x).abs() / x))
        .collect();
    let batch = TableBuilder::new(&HYBRID_PROTOTYPE)
        .u32(hybrid_prototype::MODE, (1..=n as u32).collect())
        .f64(hybrid_prototype::PROTOTYPE_FREQUENCY_HZ, f.clone())
        .opt_f64(hybrid_prototype::FULL_FREQUENCY_HZ, full)
        .opt_f64(hybrid_prototype::RELATIVE_ERROR, error)
        .bool(
            hybrid_prototype::IN_BAND,
            (0..n).map(|i| i < h.matched.len()).collect(),
        )
        .f64(
            hybrid_prototype::TEST_FREQUENCY_HZ,
            f.iter().map(|x| x / h.time_scale).collect(),
        )
        .u32(
            hybrid_prototype::NS_MODES,
            vec![h.prototype.ns_modes as u32; n],
        )
        .f64(hybrid_prototype::TIME_SCALE, vec![h.time_scale; n])
        .f64(hybrid_prototype::BANDWIDTH_HZ, vec![h.bandwidth_hz; n])
        .build()?;
    let mut m = meta(p);
    m.push((
        "quaketwin.recommendation".into(),
        serde_json::json!({
            "ns_modes": h.prototype.ns_modes,
            "time_scale": h.time_scale,
            "bandwidth_hz": h.bandwidth_hz,
            "highest_frequency_hz": h.prototype.highest_frequency_hz(),
            "matched": h.matched.iter().map(|(a, b, e)| serde_json::json!({
                "full_hz": a, "prototype_hz": b, "relative_error": e
            })).collect::<Vec<_>>(),
        })
        .to_string(),
    ));
    write_parquet(path, &[batch], &m)
}

/// Writes all design outputs into `out_dir`; returns the paths written (order of
/// [`DESIGN_FILES`]).
pub fn write_design(
    out_dir: &Path,
    model: &Model,
    d: &TestDesign,
    p: &DesignProvenance,
) -> Result<Vec<PathBuf>> {
    let path = |name: &str| out_dir.join(name);
    write_actuator_layout(&path(ACTUATOR_LAYOUT_FILE), model, d, p)?;
    write_pod(&path(POD_FILE), d, p)?;
    write_reduction_validation(&path(REDUCTION_VALIDATION_FILE), model, d, p)?;
    write_interface_refinement(&path(INTERFACE_REFINEMENT_FILE), d, p)?;
    write_hybrid_prototype(&path(HYBRID_PROTOTYPE_FILE), d, p)?;
    let proto = &d.hybrid.prototype;
    write_matrix_market_symmetric(
        &CscMatrix::from_dense(proto.stiffness.as_ref()),
        &path(PROTOTYPE_STIFFNESS_FILE),
    )?;
    write_matrix_market_symmetric(
        &CscMatrix::from_dense(proto.mass.as_ref()),
        &path(PROTOTYPE_MASS_FILE),
    )?;
    // u_PS = G T q: the interface kinematics G applied to the Guyan + rigid-body basis T.
    let basis = &d.interface.map * &d.basis.transformation;
    let mut comments = vec![
        format!(
            "PS basis u_PS = T q of the hybrid-test design {} (twin {})",
            p.design_file, p.twin
        ),
        format!(
            "columns 1..{}: actuated master DoFs (actuator order); columns {}..{}: rigid-body amplitudes",
            d.basis.masters.len(),
            d.basis.masters.len() + 1,
            basis.ncols()
        ),
    ];
    for (a, act) in d.actuators.iter().enumerate() {
        comments.push(format!(
            "column {}: actuator {} node {} {}",
            a + 1,
            act.actuator,
            act.node_id,
            act.direction
        ));
    }
    for r in 0..basis.nrows() {
        let (id, dof) = dof_of(model, d, r);
        comments.push(format!("row {}: node {id} {dof}", r + 1));
    }
    write_matrix_market_general(basis.as_ref(), &comments, &path(PS_BASIS_FILE))?;
    Ok(DESIGN_FILES.iter().map(|f| path(f)).collect())
}
