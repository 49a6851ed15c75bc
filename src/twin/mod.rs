//! The finite-element digital twin and its ensemble updating (thesis ch. 3, METHODS.md §3).
//!
//! - `file`: the twin file (TOML) → `model::Model` → `assembly::TwinSystem`
//!   (K(θ) = K0 + Σ θ_g K_g, M(θ) likewise);
//! - `elements`: Timoshenko beams (2D/3D), Q4 membrane, MITC4 flat shell;
//! - `eigen` (dense and shift-invert Lanczos), `guyan`, `newmark`, `statics`;
//! - `objective` (MAC pairing, Eq. 3 and Eq. 5), `optimisers` (GA, PSO, SA, pattern search),
//!   `plackett_luce` (Eq. 1–2, 4), `ensemble` (Table 1).

pub mod assembly;
pub mod benchmark;
pub mod eigen;
pub mod elements;
pub mod ensemble;
pub mod file;
pub mod guyan;
pub mod matrix_market;
pub mod model;
pub mod newmark;
pub mod objective;
pub mod optimisers;
pub mod plackett_luce;
pub mod sparse;
pub mod statics;
pub mod tridiagonal;
pub mod update;

pub use assembly::{assemble, DofMap, ParameterInfo, SensorDof, TwinSystem};
pub use eigen::{dense_modes, lanczos_modes, LanczosOptions, Modes};
pub use file::{load_twin, parse_twin, updated_twin_toml, Twin, TwinFile};
pub use model::{Dimension, ElementKind, Model, ParameterKind};
