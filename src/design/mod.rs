//! Hybrid-test design from the twin (thesis ch. 5–7, METHODS.md §5–6). I/O free.
//!
//! - `partition`: numerical (NS) / physical (PS) substructures by node sets, interface DoFs,
//!   the floating PS's own stiffness and mass (assembled from its elements only);
//! - `rigid`: rigid-body modes R = ker(K_P) (Eq. 49, 73), a statically determined
//!   constrained set c, rigid-body removal per time step (Eq. 50–51, 74–75);
//! - `pod`: proper orthogonal decomposition by thin SVD, energy fractions (Eq. 56–58, 79–81),
//!   NRMSE / WNRMSE of the reconstruction (Eq. 83–84);
//! - `interface`: the interface super-element (control nodes, piecewise-affine followers);
//! - `layout`: Guyan + rigid-body basis T (Eq. 85–87), actuators and control modes, the reduced
//!   twin and its validation against the full twin;
//! - `craig_bampton`: reduced hybrid prototype (Eq. 60–68), hybrid bandwidth and the
//!   recommendation of NS mode count and time scale λ (METHODS §6);
//! - `recorded`: snapshots from recorded response (rigid removal on the sensors, static
//!   expansion to the PS);
//! - `plan`: the whole design (`design_hybrid_test`).
//!
//! Output tables the lead writes from these results (Parquet):
//! - `actuator_layout/actuator_layout.parquet` ← [`layout::Actuator`]: actuator, node (id), direction (DoF
//!   name), control mode, nominal force (N), participation in each retained POM (`pom_1` …);
//! - `pod/pod.parquet` ← [`pod::Pod`] + [`pod::PodCurve`]: pom, singular value, energy fraction,
//!   cumulative energy, WNRMSE of the reconstruction with POMs 1..=pom, retained (bool);
//! - `reduction_validation/reduction_validation.parquet` ← [`layout::ReductionValidation`]: node, direction,
//!   NRMSE, weight max|x − μ|, master (bool); the overall WNRMSE in the metadata.

pub mod craig_bampton;
pub mod file;
pub mod interface;
pub mod layout;
pub mod motion;
pub mod partition;
pub mod plan;
pub mod pod;
pub mod recorded;
pub mod resolve;
pub mod rigid;

pub use craig_bampton::{
    craig_bampton_prototype, hybrid_bandwidth_hz, recommend_hybrid, HybridRecommendation,
    HybridSettings, Prototype,
};
pub use interface::{interface_chains, InterfaceKinematics};
pub use layout::{
    compare_responses, reduction_basis, Actuator, ActuatorSettings, ControlMode, ReducedTwin,
    ReductionBasis, ReductionValidation,
};
pub use partition::{partition_by_node_ids, partition_by_nodes, Partition};
pub use plan::{
    design_hybrid_test, design_hybrid_test_with, BaseComponent, BaseMotion, DesignSettings,
    TestDesign,
};
pub use pod::{nrmse, pod, reconstruction_quality, wnrmse, Pod, PodCurve};
pub use recorded::{expand_recorded_deformation, RecordedResponse};
pub use rigid::{rigid_body_modes, ConstrainedSet, RigidBodyModes};
