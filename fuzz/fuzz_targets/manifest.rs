#![no_main]
//! The event manifest (event.toml) of the small sample quake, through the event-folder loader.

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    quaketwin_fuzz::manifest(&quaketwin_fuzz::small_quake(), data);
});
