#![no_main]
//! MiniSEED 2 reader.

use quaketwin::readers::Format;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::reader(Format::MiniSeed, "NP.8040.D0.HNE.mseed", data);
});
