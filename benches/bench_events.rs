//! The benchmark events, written to a directory: shared by the criterion
//! benches (`#[path]` module) and the `bench-event` binary, which writes them
//! for whole-process measurements (scripts/modal_whole.sh, profiling `run`).

use std::fmt::Write as _;
use std::path::Path;

use quaketwin::rng::Rng;
use quaketwin::synth::{
    add_measurement_noise, synthetic_ground_motion, GroundMotionSpec, Sampling, ShearBuilding,
};

/// The pipeline bench's event (benches/pipeline.rs): 20 channels × 60 s at 200 Hz, a 9-storey
/// shear building in X and Y plus two base channels, one CSV + manifest.
pub fn write_event(dir: &Path) {
    let dt = 1.0 / 200.0;
    let mut rng = Rng::new(11);
    let mut cols: Vec<(String, Vec<f64>)> = Vec::new();
    let mut manifest =
        String::from("[event]\nname = \"bench 20 channels\"\n[structure]\nname = \"bench\"\n");
    let _ = writeln!(
        manifest,
        "storey_heights_m = {:?}\nmasses_kg = {:?}",
        vec![3.5; 9],
        vec![4e5; 9]
    );
    for (i, dir_name) in ["X", "Y"].iter().enumerate() {
        let b = ShearBuilding::uniform(9, 4e5, 1.2e9 + 2e8 * i as f64, 0.02);
        let gm = GroundMotionSpec {
            duration_s: 60.0,
            sampling: Sampling::IntervalS(dt),
            seed: 3 + i as u64,
            ..Default::default()
        };
        let ag = synthetic_ground_motion(&gm).unwrap();
        let r = b.simulate_base_motion(&ag, dt).unwrap();
        cols.push((
            format!("B_{dir_name}"),
            add_measurement_noise(&ag, 40.0, &mut rng),
        ));
        let _ = writeln!(manifest, "[[channel]]\nfile = \"rec.csv\"\ncolumn = \"B_{dir_name}\"\nid = \"B-{dir_name}\"\nlevel = 0\ndirection = \"{dir_name}\"\nrole = \"input\"\nunits = \"m/s2\"\ntime_column = \"t\"");
        for (l, a) in r.absolute_acceleration.iter().enumerate() {
            cols.push((
                format!("F{}_{dir_name}", l + 1),
                add_measurement_noise(a, 40.0, &mut rng),
            ));
            let _ = writeln!(manifest, "[[channel]]\nfile = \"rec.csv\"\ncolumn = \"F{}_{dir_name}\"\nid = \"F{}-{dir_name}\"\nlevel = {}\ndirection = \"{dir_name}\"\nrole = \"output\"\nunits = \"m/s2\"\ntime_column = \"t\"", l + 1, l + 1, l + 1);
        }
    }
    assert_eq!(cols.len(), 20);
    let n = cols[0].1.len();
    let mut csv = String::from("t");
    for (c, _) in &cols {
        let _ = write!(csv, ",{c}");
    }
    csv.push('\n');
    for k in 0..n {
        let _ = write!(csv, "{:.4}", k as f64 * dt);
        for (_, v) in &cols {
            let _ = write!(csv, ",{:.8e}", v[k]);
        }
        csv.push('\n');
    }
    std::fs::write(dir.join("rec.csv"), csv).unwrap();
    std::fs::write(dir.join("event.toml"), manifest).unwrap();
}

/// The whole-process `modal` event (issue 18): 5 channels × 600 s at 100 Hz in one CSV
/// (≈ 3 MB), the floors of a 5-storey shear building (f₁ ≈ 1.5 Hz, 2 % damping) in X under
/// ambient excitation (white-noise floor forces), 40 dB measurement noise, seeded.
#[allow(dead_code)] // the pipeline bench uses only `write_event`
pub fn write_modal_event(dir: &Path) {
    let (storeys, rate_hz, duration_s) = (5usize, 100.0, 600.0);
    let dt = 1.0 / rate_hz;
    let n = (duration_s * rate_hz) as usize;
    let mut rng = Rng::new(18);
    let b = ShearBuilding::uniform(storeys, 4e5, 6e8, 0.02);
    let r = b.simulate_ambient(n, dt, 2.0e4, &mut rng).unwrap();
    let mut manifest = String::from(
        "[event]\nname = \"modal whole-process bench, 5 channels\"\n[structure]\nname = \"bench\"\n",
    );
    let _ = writeln!(
        manifest,
        "storey_heights_m = {:?}\nmasses_kg = {:?}",
        vec![3.5; storeys],
        vec![4e5; storeys]
    );
    let cols: Vec<Vec<f64>> = r
        .absolute_acceleration
        .iter()
        .map(|a| add_measurement_noise(a, 40.0, &mut rng))
        .collect();
    let mut csv = String::from("t");
    for l in 1..=storeys {
        let _ = write!(csv, ",F{l}_X");
        let _ = writeln!(manifest, "[[channel]]\nfile = \"rec.csv\"\ncolumn = \"F{l}_X\"\nid = \"F{l}-X\"\nlevel = {l}\ndirection = \"X\"\nrole = \"output\"\nunits = \"m/s2\"\ntime_column = \"t\"");
    }
    csv.push('\n');
    for k in 0..n {
        let _ = write!(csv, "{:.4}", k as f64 * dt);
        for c in &cols {
            let _ = write!(csv, ",{:.8e}", c[k]);
        }
        csv.push('\n');
    }
    std::fs::write(dir.join("rec.csv"), csv).unwrap();
    std::fs::write(dir.join("event.toml"), manifest).unwrap();
}
