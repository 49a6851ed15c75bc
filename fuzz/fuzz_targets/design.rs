#![no_main]
//! Design files beside the facade twin, with the base motion and recorded response from the facade event.

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::design(data);
});
