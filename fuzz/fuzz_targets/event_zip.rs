#![no_main]
//! A zipped event through the event-folder loader.

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::event_zip(data);
});
