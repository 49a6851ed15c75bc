#![no_main]
//! COSMOS V0/V1/V2 reader.

use quaketwin::readers::Format;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::reader(Format::Cosmos, "NP8040.HNE.01.V0c", data);
});
