//! Writes a benchmark event for whole-process measurements (issue 18):
//! `bench-event pipeline DIR` (the pipeline bench's 20 channels × 60 s × 200 Hz) or
//! `bench-event modal DIR` (5 channels × 600 s × 100 Hz CSV; scripts/modal_whole.sh).

mod bench_events;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (kind, dir) = match args.as_slice() {
        [k, d] => (k.as_str(), std::path::PathBuf::from(d)),
        _ => {
            eprintln!("usage: bench-event pipeline|modal DIR");
            std::process::exit(2);
        }
    };
    std::fs::create_dir_all(&dir).unwrap();
    match kind {
        "pipeline" => bench_events::write_event(&dir),
        "modal" => bench_events::write_modal_event(&dir),
        _ => {
            eprintln!("unknown event {kind:?}: pipeline or modal");
            std::process::exit(2);
        }
    }
}
