//! Instantaneous Bouc-Wen identification in the time–frequency domain and the
//! seismic damage index (METHODS.md §4, thesis Ch. 4). I/O free.
//!
//! - [`forward`]: the in-series degrading Bouc-Wen shear chain (Eq. 21–23), RK4.
//! - [`stft`]: Hamming STFT layout and the integrated products of Eq. 15/20
//!   (Parseval time-domain form and explicit FFT form).
//! - [`solve`]: bounded least squares under Eq. 47.
//! - [`basis`]: records → relative kinematics, forces (Eq. 46), energies,
//!   basis functions (integral form Eq. 27–30, jerk form A7–A10).
//! - [`identify`]: DoF-by-DoF identification from the top (Table 15), with
//!   [`settings`], [`dof`] (one DoF: scalar estimate, non-identifiability
//!   checks), the N search (`exponent_search`), [`instantaneous`] estimates
//!   and their stability, and the F-test of [`significance`].
//! - [`energy`]: work of a storey force along its drift (loop energy).
//! - [`damage`]: ι(t), ω_s(t), c_s(t) (Eq. 32–34).
//! - [`reduced_mass`]: reduced lumped masses (Eq. 35–36).
//! - [`lumping`]: Eq. 35–36 generalised to any instrumented levels
//!   (tributary lumping, segments `L<a>-L<b>`).
//! - [`storey_masses`]: storey masses and Eq. 35–36 targets from the twin.
//! - [`window`]: the part of a record identified (the strong motion of a
//!   long record, with margins; a triggered record whole).
//!
//! Processing is explicit: the stage takes minimally processed absolute
//! accelerations (by default it integrates them itself with no filtering) and
//! echoes the caller's declared processing plus its own steps in
//! `DirectionIdentification::processing`.
//!
//! The Parquet tables (`bouc_wen`, `bouc_wen_instantaneous`,
//! `hysteresis_fit`, `damage`) are declared in `crate::vocab::tables` and
//! written by `crate::sinks::hysteresis_tables`.

// Numerical kernels index several arrays in lock-step, and the
// `!(x > 0.0)` checks deliberately reject NaN as well.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

pub mod basis;
pub mod damage;
pub mod dof;
pub mod energy;
pub mod event;
mod exponent_search;
pub mod forward;
pub mod identify;
pub mod instantaneous;
pub mod lumping;
pub mod mass_resolution;
pub mod reduced_mass;
pub mod settings;
pub mod significance;
pub mod solve;
pub mod stft;
pub mod storey_masses;
pub mod window;

pub use basis::{
    BaseRecord, BasisForm, DirectionKinematics, DirectionRecords, DofParameters, FloorRecord,
    StiffnessPattern, VelocityDrift,
};
pub use damage::{damage_index, damage_index_of_chain, DamageSeries};
pub use dof::{DofIdentification, FitSeries, HystereticTerms};
pub use event::{
    auto_directions, identify_event, DirectionOutcome, DirectionSpec, EventSettings,
    MeasuredResponse, Verdict,
};
pub use forward::{BoucWenChain, ChainResponse};
pub use identify::{
    identify_direction, identify_directions, identify_kinematics, identify_kinematics_outcome,
    DirectionIdentification, KinematicsOutcome, F_TEST_BLIND_SPOTS,
};
pub use instantaneous::{InstantaneousEstimate, ParameterStability};
pub use lumping::{segment_label, tributary_masses, LumpedMasses};
pub use mass_resolution::{MassLumping, MassResolution, ReducedMassRecord};
pub use reduced_mass::{
    first_pulsation_2dof, reduced_lumped_masses, ReducedMassTarget, ReducedMasses,
};
pub use settings::IdentifySettings;
pub use significance::Significance;
pub use solve::{bounded_lsq_columns, bounded_lsq_gram, BoundedSolution};
pub use stft::{hamming_symmetric, FrequencyBand, StftLayout, Transform};
pub use window::{identification_window, IdentificationWindow, WindowRule, WindowSettings};
