#![no_main]
//! MCAP reader.

use quaketwin::readers::Format;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::reader(Format::Mcap, "small.mcap", data);
});
