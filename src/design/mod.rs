//! Hybrid-test design from the twin (thesis ch. 5–7, METHODS.md §5–6). I/O free.
//!
//! - `partition`: numerical (NS) / physical (PS) substructures by node sets, interface DoFs,
//!   the floating PS's own stiffness and mass (assembled from its elements only);
//! - `rigid`: rigid-body modes R = ker(K_P) (Eq. 49, 73), a statically determined
//!   constrained set c, rigid-body removal per time step (Eq. 50–51, 74–75);
//! - `pod`: proper orthogonal decomposition by thin SVD, energy fractions (Eq. 56–58, 79–81),
//!   NRMSE / WNRMSE of the reconstruction (Eq. 83–84);
//! - `layout`: actuator placement (QR with column pivoting on the retained POMs), control
//!   modes, nominal gravity forces, Guyan + rigid-body basis T (Eq. 85–87) and its validation;
//! - `craig_bampton`: reduced hybrid prototype (Eq. 60–68), hybrid bandwidth and the
//!   recommendation of NS mode count and time scale λ (METHODS §6).
//!
//! Output tables the lead writes from these results (Parquet):
//! - `actuator_layout.parquet` ← [`layout::Actuator`]: actuator, node (id), direction (DoF
//!   name), control mode, nominal force (N), participation in each retained POM (`pom_1` …);
//! - `pod.parquet` ← [`pod::Pod`] + [`pod::PodCurve`]: pom, singular value, energy fraction,
//!   cumulative energy, WNRMSE of the reconstruction with POMs 1..=pom, retained (bool);
//! - `reduction_validation.parquet` ← [`layout::ReductionValidation`]: node, direction,
//!   NRMSE, weight max|x − μ|, master (bool); the overall WNRMSE in the metadata.

pub mod craig_bampton;
pub mod layout;
pub mod partition;
pub mod pod;
pub mod rigid;

pub use craig_bampton::{
    craig_bampton_prototype, hybrid_bandwidth_hz, recommend_hybrid, HybridRecommendation,
    HybridSettings, Prototype,
};
pub use layout::{
    place_actuators, reduction_basis, validate_reduction, Actuator, ActuatorSettings, ControlMode,
    ReductionBasis, ReductionValidation,
};
pub use partition::{partition_by_node_ids, partition_by_nodes, Partition};
pub use pod::{nrmse, pod, reconstruction_quality, wnrmse, Pod, PodCurve};
pub use rigid::{rigid_body_modes, ConstrainedSet, RigidBodyModes};
