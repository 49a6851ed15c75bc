#![no_main]
//! The event manifest (event.toml) of the sample facade, through the event-folder loader.

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::manifest(&quaketwin_fuzz::facade_folder(), data);
});
