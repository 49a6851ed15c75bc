//! Big-input load generator (issue 14 item 5): writes a 64-channel event of
//! `--hours` hours at 200 Hz into `--out` (a directory outside the
//! repository): one CSV (`t` + 64 acceleration columns) and its `event.toml`.
//!
//! The building is a 31-storey shear building in X and Y (f₁ ≈ 0.6 / 0.7 Hz,
//! 2 % damping) on a base that carries microtremor (a constant-envelope
//! Kanai–Tajimi/Clough–Penzien ground noise) for the whole record and, in the
//! first hour, an earthquake 20 minutes in.  Channels: base X and Y (level 0,
//! inputs) and every floor in X and Y (levels 1–31, outputs), each with its
//! own measurement noise (40 dB).  Hours are simulated one at a time, each
//! from rest, so the generator's memory is one hour of samples whatever the
//! length.  Deterministic in `--seed`.
//!
//! The manifest states the channels (level, direction, role, units) but, by
//! default, neither storey heights nor masses — as many monitoring set-ups
//! (and the record: the modal stage then works over its default band
//! 0.2–20 Hz, the Bouc-Wen stage reports the masses missing).  `--structure`
//! adds `storey_heights_m` and `masses_kg` (3.5 m, 600 t per storey), which
//! narrows the modal band and lets the Bouc-Wen identification run.
//!
//! `--channels N` keeps the first N channels (base X, base Y, floors in X…):
//! a day of all 64 needs more disk than a small machine has for its outputs,
//! and a run's memory grows with a channel's length, not with their number.
//!
//! Usage: `bigload --hours 1 --out /tmp/big1h [--seed 1] [--format csv|mseed] [--structure] [--channels N]`
//! (see scripts/bigload.sh, which builds it, generates and measures).
//!
//! `--format mseed` writes the same channels as MiniSEED 2 (one file per
//! channel, float32 samples in 4096-byte records, m/s² stated by the
//! manifest) instead of the CSV: 4 bytes per sample instead of ~12.6, for a
//! day of data on a small disk.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use quaketwin::rng::Rng;
use quaketwin::sinks::mseed_writer::{RecordEncoder, SampleEncoding, StreamCodes};
use quaketwin::synth::{
    synthetic_ground_motion, Envelope, GroundMotionSpec, Sampling, Shaping, ShearBuilding,
    WhiteNoise,
};

const RATE_HZ: f64 = 200.0;
const STOREYS: usize = 31;
const STOREY_HEIGHT_M: f64 = 3.5;
const STOREY_MASS_KG: f64 = 6e5;
const SNR_DB: f64 = 40.0;
/// The record starts at 2026-02-01T00:00:00Z (MiniSEED times; the CSV's
/// time column counts seconds from it); the manifest's origin time is the
/// earthquake's.
const QUAKE_AT_S: f64 = 1200.0;

struct Args {
    hours: usize,
    out: PathBuf,
    seed: u64,
    mseed: bool,
    structure: bool,
    channels: usize,
}

fn parse_args() -> Result<Args, String> {
    let mut hours = 1usize;
    let mut out = None;
    let mut seed = 1u64;
    let mut mseed = false;
    let mut structure = false;
    let mut channels = 64;
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut value = || it.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--hours" => hours = value()?.parse().map_err(|e| format!("--hours: {e}"))?,
            "--out" => out = Some(PathBuf::from(value()?)),
            "--seed" => seed = value()?.parse().map_err(|e| format!("--seed: {e}"))?,
            "--format" => {
                mseed = match value()?.as_str() {
                    "csv" => false,
                    "mseed" => true,
                    f => return Err(format!("--format {f}: csv or mseed")),
                }
            }
            "--structure" => structure = true,
            "--channels" => {
                channels = value()?.parse().map_err(|e| format!("--channels: {e}"))?;
                if !(1..=64).contains(&channels) {
                    return Err("--channels must be 1..=64".into());
                }
            }
            _ => return Err(format!("unknown argument {a}")),
        }
    }
    if hours == 0 {
        return Err("--hours must be at least 1".into());
    }
    Ok(Args {
        hours,
        out: out.ok_or("--out DIR is required")?,
        seed,
        mseed,
        structure,
        channels,
    })
}

/// Column names, in file order: base X, base Y, floors in X, floors in Y.
fn columns() -> Vec<(String, usize, &'static str)> {
    let mut c = vec![("B_X".to_string(), 0, "X"), ("B_Y".to_string(), 0, "Y")];
    for d in ["X", "Y"] {
        for l in 1..=STOREYS {
            c.push((format!("F{l}_{d}"), l, d));
        }
    }
    c
}

fn manifest(
    file_of: impl Fn(&str) -> String,
    mseed: bool,
    structure: bool,
    channels: usize,
) -> String {
    let mut m = String::new();
    let _ = writeln!(
        m,
        "# Big-input load event (quaketwin-benches bigload): 64 channels at 200 Hz.\n[event]\nname = \"bigload 64 channels\"\norigin_time = \"2026-02-01T00:20:00Z\"\nmagnitude = 5.5\n\n[structure]\nname = \"31-storey shear building\""
    );
    if structure {
        let _ = writeln!(
            m,
            "storey_heights_m = {:?}\nmasses_kg = {:?}",
            vec![STOREY_HEIGHT_M; STOREYS],
            vec![STOREY_MASS_KG; STOREYS]
        );
    }
    m.push('\n');
    for (name, level, dir) in columns().into_iter().take(channels) {
        let role = if level == 0 { "input" } else { "output" };
        let _ = writeln!(
            m,
            "[[channel]]\nfile = \"{}\"\n{}id = \"{}\"\nlevel = {level}\ndirection = \"{dir}\"\nrole = \"{role}\"\nunits = \"m/s2\"\n",
            file_of(&name),
            if mseed {
                String::new()
            } else {
                format!("column = \"{name}\"\ntime_column = \"t\"\n")
            },
            name.replace('_', "-"),
        );
    }
    m
}

/// One hour of the 64 channels, noise-free, `[channel][sample]`.
fn simulate_hour(hour: usize, seed: u64) -> Vec<Vec<f64>> {
    let n = (3600.0 * RATE_HZ) as usize;
    let dt = 1.0 / RATE_HZ;
    let mut base_and_floors: Vec<Vec<Vec<f64>>> = Vec::new();
    for (i, k) in [3.4e9, 2.6e9].iter().enumerate() {
        let building = ShearBuilding::uniform(STOREYS, STOREY_MASS_KG, *k, 0.02);
        let tremor = GroundMotionSpec {
            seed: seed ^ (1000 * hour as u64 + 17 * i as u64 + 1),
            duration_s: 3600.0,
            sampling: Sampling::RateHz(RATE_HZ),
            pga_m_per_s2: 0.004,
            noise: WhiteNoise::SplitMix64,
            shaping: Shaping::Spectral {
                lowpass_frequency_hz: 25.0,
            },
            envelope: Envelope::Plateau {
                rise_end_s: 1.0,
                strong_end_s: 4000.0,
                decay_per_s: 0.0,
            },
            ..GroundMotionSpec::default()
        };
        let mut ag = synthetic_ground_motion(&tremor).expect("microtremor");
        ag.truncate(n);
        if hour == 0 {
            let quake =
                GroundMotionSpec::strong_50s(seed + 7 + i as u64, RATE_HZ, 1.5 - 0.3 * i as f64);
            let q = synthetic_ground_motion(&quake).expect("earthquake");
            let at = (QUAKE_AT_S * RATE_HZ) as usize;
            for (k, v) in q.iter().enumerate() {
                ag[at + k] += v;
            }
        }
        let r = building.simulate_base_motion(&ag, dt).expect("simulation");
        let mut chans = vec![ag];
        chans.extend(r.absolute_acceleration);
        base_and_floors.push(chans);
    }
    let (x, y) = (base_and_floors.remove(0), base_and_floors.remove(0));
    let mut out = Vec::with_capacity(64);
    let mut x = x.into_iter();
    let mut y = y.into_iter();
    out.push(x.next().expect("base X"));
    out.push(y.next().expect("base Y"));
    out.extend(x);
    out.extend(y);
    out
}

/// Adds measurement noise at [`SNR_DB`] to every channel (σ from the
/// channel's RMS over the hour).
fn add_noise(chans: &mut [Vec<f64>], rng: &mut Rng) {
    for c in chans.iter_mut() {
        let rms = (c.iter().map(|v| v * v).sum::<f64>() / c.len() as f64).sqrt();
        let sigma = rms / 10f64.powf(SNR_DB / 20.0);
        for v in c.iter_mut() {
            *v += sigma * rng.normal();
        }
    }
}

fn write_csv_hour(w: &mut impl std::io::Write, chans: &[Vec<f64>], hour: usize) {
    let n = chans[0].len();
    let mut line = String::with_capacity(1024);
    for k in 0..n {
        line.clear();
        let t = (hour * n + k) as f64 / RATE_HZ;
        let _ = write!(line, "{t:.3}");
        for c in chans {
            let _ = write!(line, ",{:.6e}", c[k]);
        }
        line.push('\n');
        w.write_all(line.as_bytes()).expect("write CSV");
    }
}

/// One MiniSEED file per channel, float32 records from the library's one
/// encoder (`quaketwin::sinks::mseed_writer`).
struct MseedChannel {
    file: std::io::BufWriter<std::fs::File>,
    encoder: RecordEncoder,
}

impl MseedChannel {
    fn new(path: &Path, channel_code: &str) -> Self {
        let f = std::fs::File::create(path).expect("create MiniSEED file");
        let codes = StreamCodes {
            network: "QT".into(),
            station: "BIG".into(),
            location: "00".into(),
            channel: channel_code.into(),
        };
        // 2026-02-01T00:00:00Z
        let start_ns = 1_769_904_000_000_000_000;
        MseedChannel {
            file: std::io::BufWriter::new(f),
            encoder: RecordEncoder::new(codes, RATE_HZ, start_ns, SampleEncoding::Float32),
        }
    }
    fn push(&mut self, samples: &[f64]) {
        let file = &mut self.file;
        self.encoder
            .push(samples, &mut |_, r| {
                Ok(file.write_all(r).expect("write MiniSEED"))
            })
            .expect("write MiniSEED");
    }
    fn finish(mut self) {
        let file = &mut self.file;
        self.encoder
            .finish(&mut |_, r| Ok(file.write_all(r).expect("write MiniSEED")))
            .expect("write MiniSEED");
        self.file.flush().expect("flush MiniSEED");
    }
}

fn main() {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("bigload: {e}\nusage: bigload --hours H --out DIR [--seed S] [--format csv|mseed] [--structure] [--channels N]");
            std::process::exit(2);
        }
    };
    std::fs::create_dir_all(&args.out).expect("create the output directory");
    // `--channels N`: the first N columns (base X, base Y, floors in X…).
    let cols: Vec<_> = columns().into_iter().take(args.channels).collect();
    let mut rng = Rng::new(args.seed);
    if args.mseed {
        // Channel codes: 3 characters, unique per file (the file name keeps the column name).
        let file_of = |name: &str| format!("{name}.mseed");
        std::fs::write(
            args.out.join("event.toml"),
            manifest(file_of, true, args.structure, args.channels),
        )
        .expect("manifest");
        let mut writers: Vec<MseedChannel> = cols
            .iter()
            .enumerate()
            .map(|(i, (name, _, _))| {
                MseedChannel::new(&args.out.join(file_of(name)), &format!("H{i:02}"))
            })
            .collect();
        for h in 0..args.hours {
            let mut chans = simulate_hour(h, args.seed);
            chans.truncate(args.channels);
            add_noise(&mut chans, &mut rng);
            for (w, c) in writers.iter_mut().zip(&chans) {
                w.push(c);
            }
            eprintln!("bigload: hour {} of {} written", h + 1, args.hours);
        }
        for w in writers {
            w.finish();
        }
    } else {
        std::fs::write(
            args.out.join("event.toml"),
            manifest(|_| "rec.csv".into(), false, args.structure, args.channels),
        )
        .expect("manifest");
        let f = std::fs::File::create(args.out.join("rec.csv")).expect("create rec.csv");
        let mut w = std::io::BufWriter::with_capacity(1 << 20, f);
        let mut header = String::from("t");
        for (name, _, _) in &cols {
            let _ = write!(header, ",{name}");
        }
        header.push('\n');
        w.write_all(header.as_bytes()).expect("write CSV");
        for h in 0..args.hours {
            let mut chans = simulate_hour(h, args.seed);
            chans.truncate(args.channels);
            add_noise(&mut chans, &mut rng);
            write_csv_hour(&mut w, &chans, h);
            eprintln!("bigload: hour {} of {} written", h + 1, args.hours);
        }
        w.flush().expect("flush CSV");
    }
}
