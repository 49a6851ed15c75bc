#![no_main]
//! PEER AT2 reader.

use quaketwin::readers::Format;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::reader(Format::At2, "TAK000.AT2", data);
});
