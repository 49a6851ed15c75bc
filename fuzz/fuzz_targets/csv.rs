#![no_main]
//! CSV reader, as sniffed and with a time column (resampling).

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::csv(data);
});
