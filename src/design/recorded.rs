//! Snapshots from recorded response (issue 6, snapshot source (b); METHODS §5): displacement
//! histories measured at a few PS DoFs (accelerometers at twin nodes, integrated and taken
//! relative to the base) become full-field PS deformation snapshots.
//!
//! 1. Rigid-body removal on the sensors alone (Eq. 50–51): the constrained set c is chosen
//!    among the sensed DoFs (QR with column pivoting on R at those rows), so
//!    λ_k = −(R^c)⁻¹ u_k^c uses measured values only, and ū_k = u_k + R λ_k at every sensor.
//! 2. Static expansion to the whole PS: the sensed DoFs outside c are the masters of a Guyan
//!    condensation of the floating PS with c fixed (Eq. 85–86), ū_r = T_d ū_m. This is exact
//!    when the PS is loaded at the sensed DoFs only (the interface, quasi-static), and the
//!    best static estimate otherwise.
//!
//! Why not fit the twin's modes instead: a floating PS in a hybrid test is loaded through its
//! interface, slowly; its deformation lies in the static span of the interface loads, which
//! the Guyan basis is, while free-free or fixed-interface modes of the PS are not measurable
//! and not imposable (METHODS §6).

use super::layout::reduction_basis;
use super::partition::Partition;
use super::rigid::{ConstrainedSet, RigidBodyModes, MAX_CONSTRAINT_CONDITION};
use crate::error::Error;
use crate::twin::model::Model;
use crate::Result;

/// Displacements (m, relative to the base, at a common step) measured at twin DoFs.
#[derive(Debug, Clone)]
pub struct RecordedResponse {
    /// (node id, DoF name such as "ux") per measured history.
    pub dofs: Vec<(i64, String)>,
    /// `displacement[i][k]`: DoF `dofs[i]` at step k.
    pub displacement: Vec<Vec<f64>>,
    /// Where the histories came from (event, channels), for the outputs' metadata.
    pub source: String,
}

/// Full-field deformation snapshots derived from a recorded response.
#[derive(Debug, Clone)]
pub struct ExpandedRecords {
    /// PS positions of the sensed DoFs, in `RecordedResponse::dofs` order.
    pub sensed: Vec<usize>,
    /// The constrained set chosen among the sensed DoFs.
    pub set: ConstrainedSet,
    /// `history[k][p]`: deformation of PS position p at step k (zero at c).
    pub history: Vec<Vec<f64>>,
}

/// Map the recorded DoFs to PS positions, remove the rigid-body motion on the sensors and
/// expand statically to the whole PS (see the module notes). Errors: a DoF outside the PS,
/// repeated, unequal lengths, non-finite samples, or too few sensors to remove the rigid-body
/// motion and still see deformation (more sensed DoFs than rigid-body modes are needed).
pub fn expand_recorded_deformation(
    model: &Model,
    partition: &Partition,
    rigid: &RigidBodyModes,
    recorded: &RecordedResponse,
) -> Result<ExpandedRecords> {
    let names = model.dimension.dof_names();
    let mut sensed = Vec::with_capacity(recorded.dofs.len());
    for (id, dof) in &recorded.dofs {
        let position = model.node_index(*id).and_then(|n| {
            let d = names.iter().position(|x| x == dof)?;
            partition.position(n, d)
        });
        match position {
            Some(p) if !sensed.contains(&p) => sensed.push(p),
            Some(_) => {
                return Err(Error::usage(format!(
                    "{}: DoF {id}-{dof} is measured twice",
                    recorded.source
                )))
            }
            None => {
                return Err(Error::usage(format!(
                    "{}: measured DoF {id}-{dof} is not a DoF of the PS",
                    recorded.source
                )))
            }
        }
    }
    if recorded.displacement.len() != sensed.len() {
        return Err(Error::usage(format!(
            "{}: {} histories for {} measured DoFs",
            recorded.source,
            recorded.displacement.len(),
            sensed.len()
        )));
    }
    let steps = recorded.displacement.first().map(|h| h.len()).unwrap_or(0);
    if steps == 0 {
        return Err(Error::usage(format!("{}: no samples", recorded.source)));
    }
    for (i, h) in recorded.displacement.iter().enumerate() {
        if h.len() != steps {
            return Err(Error::usage(format!(
                "{}: DoF {}-{} has {} samples, the first has {steps}",
                recorded.source,
                recorded.dofs[i].0,
                recorded.dofs[i].1,
                h.len()
            )));
        }
        if let Some(k) = h.iter().position(|v| !v.is_finite()) {
            return Err(Error::usage(format!(
                "{}: DoF {}-{} has a non-finite sample at step {k}",
                recorded.source, recorded.dofs[i].0, recorded.dofs[i].1
            )));
        }
    }
    if sensed.len() <= rigid.count() {
        return Err(Error::usage(format!(
            "{}: {} measured PS DoFs cannot separate deformation from {} rigid-body modes; at least {} are needed",
            recorded.source,
            sensed.len(),
            rigid.count(),
            rigid.count() + 1
        )));
    }
    let set =
        ConstrainedSet::propose_among(rigid, &sensed, MAX_CONSTRAINT_CONDITION).map_err(|e| {
            Error::usage(format!(
                "{}: the measured DoFs do not restrain the PS's rigid-body motion ({e})",
                recorded.source
            ))
        })?;
    let masters: Vec<usize> = sensed
        .iter()
        .copied()
        .filter(|p| !set.constrained.contains(p))
        .collect();
    let basis = reduction_basis(
        partition.ps_stiffness.as_ref(),
        partition.ps_mass.as_ref(),
        rigid,
        &set,
        &masters,
    )?;
    let n_ps = partition.n_ps();
    let history = (0..steps)
        .map(|k| {
            let mut u = vec![0.0; n_ps];
            for (i, &p) in sensed.iter().enumerate() {
                u[p] = recorded.displacement[i][k];
            }
            // λ uses u^c only, so the unsensed zeros do not matter; read ū at the masters.
            let (bar, _) = set.remove(rigid, &u);
            let um: Vec<f64> = masters.iter().map(|&p| bar[p]).collect();
            let mut full = vec![0.0; n_ps];
            for (row, &p) in set.retained.iter().enumerate() {
                full[p] = (0..um.len()).map(|a| basis.guyan[(row, a)] * um[a]).sum();
            }
            full
        })
        .collect();
    Ok(ExpandedRecords {
        sensed,
        set,
        history,
    })
}
