//! The shared vocabulary every stage speaks: channels, records, events,
//! structures, the processing history, and the schemas of the tables we
//! write (`schema`, `tables`).  Nothing here does I/O (parked samples are
//! read through the [`SampleStore`] interface the pipeline implements).

mod channel;
mod event;
mod history;
mod lab;
mod samples;
pub mod schema;
pub mod tables;
mod time;
mod units;

pub use channel::{most_common_station, Axis, Channel, Direction, QaFlag, Role, SourceRef};
pub use event::{Event, Hypocentre, Record, Structure};
pub use history::{ProcessingHistory, ProcessingStep};
pub use lab::{lab_units, LabChannel, LabRecord, LabRole, Quantity, TimeBase};
pub use samples::{SampleStore, Samples};
pub use time::{
    day_start_ns, epoch_ns_from_civil, epoch_ns_from_ordinal, format_epoch_ns,
    ordinal_from_epoch_ns, parse_iso8601_ns, OrdinalTime,
};
pub use units::Units;

/// Standard gravity, m/s² (units conversion from `g`).
pub const STANDARD_GRAVITY: f64 = 9.80665;
