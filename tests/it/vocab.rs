//! The shared vocabulary (`vocab`): time instants as nanoseconds since the
//! Unix epoch.

use quaketwin::vocab::{
    epoch_ns_from_civil, epoch_ns_from_ordinal, format_epoch_ns, parse_iso8601_ns,
};

#[test]
fn round_trip_known_instants() {
    let ns = epoch_ns_from_civil(2018, 11, 30, 17, 28, 59.3345).unwrap();
    assert_eq!(format_epoch_ns(ns), "2018-11-30T17:28:59.334500000Z");
    assert_eq!(epoch_ns_from_civil(1970, 1, 1, 0, 0, 0.0), Some(0));
    // 2000-03-01 is day 11017 since the epoch.
    assert_eq!(
        epoch_ns_from_civil(2000, 3, 1, 0, 0, 0.0),
        Some(11_017 * 86_400 * 1_000_000_000)
    );
    assert_eq!(parse_iso8601_ns("2018-11-30T17:28:59.3345Z"), Some(ns));
    // 2019 day 187 = 6 July.
    assert_eq!(
        epoch_ns_from_ordinal(2019, 187, 3, 19, 52.0),
        epoch_ns_from_civil(2019, 7, 6, 3, 19, 52.0)
    );
    assert_eq!(format_epoch_ns(-1), "1969-12-31T23:59:59.999999999Z");
}
