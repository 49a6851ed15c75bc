//! A hybrid test's own records back in (issue 37, item 3; docs/lab-tests.md, "Comparing a
//! hybrid test with its rehearsal"): the log of a pseudo-dynamic or real-time hybrid test —
//! per actuator the commanded and measured displacement and the restoring force, per step —
//! compared with the rehearsal of the same design and with the twin, and the specimen and
//! actuator models updated from it. Numerical code and text formats, no file access
//! (`stages::compare_test` reads and writes).
//!
//! - `log`: the log's CSV format, parsed and checked;
//! - `tracking`: the actuators' lag and noise identified from command and measured;
//! - `compare`: the comparison and the updated rehearsal.

pub mod compare;
pub mod log;
pub mod tracking;

pub use compare::{compare, CompareSettings, Comparison, RunFigures, SpecimenUpdate};
pub use log::HybridLog;
pub use tracking::{identify_tracking, TrackingIdentification};
