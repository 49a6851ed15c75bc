#![no_main]
//! SAC binary reader.

use quaketwin::readers::Format;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::reader(Format::Sac, "T001230.HNE.sac", data);
});
