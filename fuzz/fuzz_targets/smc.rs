#![no_main]
//! USGS SMC reader.

use quaketwin::readers::Format;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::reader(Format::Smc, "0111b.smc", data);
});
