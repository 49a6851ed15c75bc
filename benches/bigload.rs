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

/// MiniSEED 2 writer: 4096-byte records, float32 (encoding 4), big-endian,
/// blockette 1000; 1008 samples per record.
struct MseedChannel {
    file: std::io::BufWriter<std::fs::File>,
    channel_code: String,
    sequence: u32,
    /// Samples written so far (the next record's start).
    written: u64,
    pending: Vec<f64>,
}

const MSEED_RECORD: usize = 4096;
const MSEED_PER_RECORD: usize = (MSEED_RECORD - 64) / 4;

impl MseedChannel {
    fn new(path: &Path, channel_code: &str) -> Self {
        let f = std::fs::File::create(path).expect("create MiniSEED file");
        MseedChannel {
            file: std::io::BufWriter::new(f),
            channel_code: channel_code.into(),
            sequence: 0,
            written: 0,
            pending: Vec::new(),
        }
    }
    fn push(&mut self, samples: &[f64]) {
        self.pending.extend_from_slice(samples);
        while self.pending.len() >= MSEED_PER_RECORD {
            self.record(MSEED_PER_RECORD);
        }
    }
    fn finish(mut self) {
        if !self.pending.is_empty() {
            self.record(self.pending.len());
        }
        self.file.flush().expect("flush MiniSEED");
    }
    fn record(&mut self, count: usize) {
        let mut r = vec![0u8; MSEED_RECORD];
        self.sequence += 1;
        r[0..6].copy_from_slice(format!("{:06}", self.sequence).as_bytes());
        r[6] = b'D';
        r[7] = b' ';
        let pad = |s: &str, n: usize| format!("{s:<n$}").into_bytes();
        r[8..13].copy_from_slice(&pad("BIG", 5));
        r[13..15].copy_from_slice(&pad("00", 2));
        r[15..18].copy_from_slice(&pad(&self.channel_code, 3));
        r[18..20].copy_from_slice(&pad("QT", 2));
        // Start time: 2026-02-01 00:00:00 + written / rate (BTIME).
        let t_tenth_ms = self.written * 10_000 / RATE_HZ as u64;
        let secs = t_tenth_ms / 10_000;
        let frac = (t_tenth_ms % 10_000) as u16;
        let day = 32 + (secs / 86_400) as u16; // 1 February = day 32
        let rem = secs % 86_400;
        r[20..22].copy_from_slice(&2026u16.to_be_bytes());
        r[22..24].copy_from_slice(&day.to_be_bytes());
        r[24] = (rem / 3600) as u8;
        r[25] = (rem % 3600 / 60) as u8;
        r[26] = (rem % 60) as u8;
        r[28..30].copy_from_slice(&frac.to_be_bytes());
        r[30..32].copy_from_slice(&(count as u16).to_be_bytes());
        r[32..34].copy_from_slice(&(RATE_HZ as i16).to_be_bytes());
        r[34..36].copy_from_slice(&1i16.to_be_bytes());
        r[39] = 1; // one blockette
        r[44..46].copy_from_slice(&64u16.to_be_bytes()); // data offset
        r[46..48].copy_from_slice(&48u16.to_be_bytes()); // first blockette
                                                         // Blockette 1000 at 48.
        r[48..50].copy_from_slice(&1000u16.to_be_bytes());
        r[52] = 4; // float32
        r[53] = 1; // big-endian
        r[54] = 12; // 2^12 = 4096
        for (k, v) in self.pending.drain(..count).enumerate() {
            r[64 + 4 * k..68 + 4 * k].copy_from_slice(&(v as f32).to_be_bytes());
        }
        self.written += count as u64;
        self.file.write_all(&r).expect("write MiniSEED");
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
