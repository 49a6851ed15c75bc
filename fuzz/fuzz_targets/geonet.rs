#![no_main]
//! GeoNet V1A/V2A reader.

use quaketwin::readers::Format;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::reader(Format::GeoNet, "WPWS_20.V2A", data);
});
