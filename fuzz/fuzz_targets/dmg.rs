#![no_main]
//! CSMIP/CDMG V1/V2 reader.

use quaketwin::readers::Format;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::reader(Format::Dmg, "CHAN1.V2", data);
});
