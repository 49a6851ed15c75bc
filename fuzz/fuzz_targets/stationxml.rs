#![no_main]
//! StationXML metadata.

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::stationxml(data);
});
