#![no_main]
//! Twin files, parsed and assembled.

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::twin(data);
});
