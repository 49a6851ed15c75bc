#![no_main]
//! Pipeline files, built with every stage kind.

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::pipeline(data);
});
