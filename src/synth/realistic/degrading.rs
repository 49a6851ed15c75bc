//! Benchmark (c): a 6-storey commercial frame whose ground storey yields and
//! loses stiffness ([`YieldingShearBuilding`]: degrading bilinear storey 1,
//! linear storeys above, Rayleigh damping 3 %, central differences at
//! 4000 Hz), one chain per direction, under a strong 50 s synthetic record,
//! instrumented at the ground floor (X, Y, up), the 3rd floor (level 2) and
//! the roof (level 6) in both directions, written as a CESMD-style zip of
//! CSMIP V2 files (`CHAN001.V2` …), no manifest, `truth.toml` beside it.
//! X points to azimuth 360°, Y to 270°.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::{
    civil, level_label, storey_and_segment_drifts, v2_processed, weekday, write_file, zip_bytes,
};
use crate::error::{Error, Result};
use crate::synth::csmip_writer::{csmip_v2_text, CsmipChannel, CsmipOrientation};
use crate::synth::yielding::{YieldingResponse, YieldingShearBuilding};
use crate::synth::{synthetic_ground_motion, Envelope, GroundMotionSpec};

pub const FOLDER: &str = "synthetic-6storey-yielding";
pub const ZIP_NAME: &str = "ce99906p.zip";
pub const STOREYS: usize = 6;
pub const STATION: u32 = 99906;
pub const STOREY_HEIGHTS_M: [f64; STOREYS] = [4.5, 3.8, 3.8, 3.8, 3.8, 3.8];
pub const LEVELS: [usize; 3] = [0, 2, 6];
const RATE_HZ: f64 = 100.0;
const SUBSTEPS: usize = 40;
const PRE_EVENT_S: f64 = 5.0;
const POST_EVENT_S: f64 = 20.0;
const BAND_HZ: (f64, f64) = (0.10, 40.0);
/// Peak ground acceleration along X (Y: 80 % of it), m/s².
const PGA_M_S2: f64 = 4.0;

/// The frame per direction (X, Y): the X ground storey is the weak one.
pub fn buildings() -> [YieldingShearBuilding; 2] {
    let masses = vec![6.5e5, 6.5e5, 6.5e5, 6.5e5, 6.5e5, 5.5e5];
    [
        YieldingShearBuilding {
            masses_kg: masses.clone(),
            storey_stiffness_n_per_m: vec![4.0e8, 7.0e8, 6.5e8, 6.0e8, 5.0e8, 4.0e8],
            yield_force_n: 3.6e6,
            hardening_ratio: 0.1,
            degradation_exponent: 0.5,
            damping_ratio: 0.03,
        },
        YieldingShearBuilding {
            masses_kg: masses,
            storey_stiffness_n_per_m: vec![5.5e8, 8.5e8, 8.0e8, 7.0e8, 6.0e8, 5.0e8],
            yield_force_n: 8.0e6,
            hardening_ratio: 0.1,
            degradation_exponent: 0.5,
            damping_ratio: 0.03,
        },
    ]
}

/// How a degrading-frame event is generated.  [`EventOptions::sample`] is the
/// bundled `synthetic-6storey-yielding`; [`Intensity`] gives the three
/// intensities of the apparent-frequency validation (issue 32).
#[derive(Debug, Clone, PartialEq)]
pub struct EventOptions {
    /// Peak ground acceleration of the strong motion along X (Y: 80 %, up: 50 %), m/s².
    pub pga_x_m_s2: f64,
    /// Zero-motion pad before the 50-s strong record, s.
    pub pre_event_s: f64,
    /// Zero-motion pad after it, s.
    pub post_event_s: f64,
    /// Peak of a stationary ambient ground motion (same Kanai–Tajimi filter,
    /// constant envelope) added over the whole record on every axis, m/s²;
    /// 0: none.  It makes the pre- and post-event pads identifiable, as
    /// microtremors do in real records.
    pub ambient_pga_m_s2: f64,
}

impl EventOptions {
    /// The bundled sample: PGA 4.0 m/s², 5 s before, 20 s after, no ambient motion.
    pub fn sample() -> Self {
        EventOptions {
            pga_x_m_s2: PGA_M_S2,
            pre_event_s: PRE_EVENT_S,
            post_event_s: POST_EVENT_S,
            ambient_pga_m_s2: 0.0,
        }
    }
}

/// The three intensities of the apparent-frequency validation (issue 32):
/// 15 s of pre-event and 20 s of post-event ambient motion (0.02 m/s²)
/// round the strong record, so that whole windows of several periods fit
/// before and after the shaking.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Intensity {
    /// Storey 1 never yields (X or Y).
    Elastic,
    /// Clear yielding: the final X fundamental 5–15 % below the initial one.
    Moderate,
    /// Final X fundamental > 25 % below the initial one, peak storey-1 drift > 2.5 %.
    Severe,
}

impl Intensity {
    pub const ALL: [Intensity; 3] = [Intensity::Elastic, Intensity::Moderate, Intensity::Severe];

    pub fn name(self) -> &'static str {
        match self {
            Intensity::Elastic => "elastic",
            Intensity::Moderate => "moderate",
            Intensity::Severe => "severe",
        }
    }

    /// Peak ground acceleration along X, m/s².
    pub fn pga_x_m_s2(self) -> f64 {
        match self {
            Intensity::Elastic => ELASTIC_PGA,
            Intensity::Moderate => MODERATE_PGA,
            Intensity::Severe => SEVERE_PGA,
        }
    }

    pub fn options(self) -> EventOptions {
        EventOptions {
            pga_x_m_s2: self.pga_x_m_s2(),
            pre_event_s: 15.0,
            post_event_s: 20.0,
            ambient_pga_m_s2: 0.02,
        }
    }
}

const ELASTIC_PGA: f64 = 0.4;
const MODERATE_PGA: f64 = 1.2;
const SEVERE_PGA: f64 = 6.0;

/// A simulated degrading-frame event: the ground motion and each
/// direction's response, before any processing.
#[derive(Debug, Clone)]
pub struct Simulation {
    pub options: EventOptions,
    /// Record interval, s.
    pub dt: f64,
    /// Frames per direction (X, Y): [`buildings`].
    pub frames: [YieldingShearBuilding; 2],
    /// Ground acceleration X, Y, up, m/s².
    pub ground: [Vec<f64>; 3],
    /// Response per direction (X, Y).
    pub response: [YieldingResponse; 2],
}

impl Simulation {
    /// The true instantaneous tangent f₁ per direction (X, Y) at each
    /// sample ([`YieldingShearBuilding::tangent_first_frequency_hz`]).
    pub fn true_first_frequency_hz(&self) -> Result<[Vec<f64>; 2]> {
        Ok([
            self.frames[0].tangent_first_frequency_hz(&self.response[0])?,
            self.frames[1].tangent_first_frequency_hz(&self.response[1])?,
        ])
    }
}

/// Simulates the event of `options` (no I/O).
pub fn simulate(seed: u64, options: &EventOptions) -> Result<Simulation> {
    let frames = buildings();
    let pga = options.pga_x_m_s2;
    let dt = 1.0 / RATE_HZ;
    let ok = |v: f64| v.is_finite() && v >= 0.0;
    if !(ok(options.pre_event_s)
        && ok(options.post_event_s)
        && ok(options.ambient_pga_m_s2)
        && pga.is_finite()
        && pga > 0.0)
    {
        return Err(Error::usage(
            "degrading event: PGA > 0, pads and ambient level ≥ 0 and finite",
        ));
    }
    let pre = (options.pre_event_s * RATE_HZ).round() as usize;
    let post = (options.post_event_s * RATE_HZ).round() as usize;
    let pad = |mut a: Vec<f64>| {
        let mut v = vec![0.0; pre];
        v.append(&mut a);
        v.extend(std::iter::repeat_n(0.0, post));
        v
    };
    let mut gx = pad(synthetic_ground_motion(&GroundMotionSpec::strong_50s(
        seed.wrapping_add(6001),
        RATE_HZ,
        pga,
    ))?);
    let mut gy = pad(synthetic_ground_motion(&GroundMotionSpec::strong_50s(
        seed.wrapping_add(6002),
        RATE_HZ,
        0.8 * pga,
    ))?);
    let mut vertical = GroundMotionSpec::strong_50s(seed.wrapping_add(6003), RATE_HZ, 0.5 * pga);
    vertical.ground_frequency_hz = 6.0;
    let mut gz = pad(synthetic_ground_motion(&vertical)?);
    if options.ambient_pga_m_s2 > 0.0 {
        let duration_s = gx.len() as f64 / RATE_HZ;
        for (k, g) in [&mut gx, &mut gy, &mut gz].into_iter().enumerate() {
            let mut spec = GroundMotionSpec::strong_50s(
                seed.wrapping_add(6011 + k as u64),
                RATE_HZ,
                options.ambient_pga_m_s2,
            );
            spec.duration_s = duration_s;
            spec.envelope = Envelope::Plateau {
                rise_end_s: 0.5,
                strong_end_s: duration_s,
                decay_per_s: 0.0,
            };
            let ambient = synthetic_ground_motion(&spec)?;
            g.iter_mut().zip(ambient).for_each(|(a, b)| *a += b);
        }
    }
    let rx = frames[0].simulate(&gx, dt, SUBSTEPS)?;
    let ry = frames[1].simulate(&gy, dt, SUBSTEPS)?;
    Ok(Simulation {
        options: options.clone(),
        dt,
        frames,
        ground: [gx, gy, gz],
        response: [rx, ry],
    })
}

/// Writes the bundled sample `out/synthetic-6storey-yielding`.
pub fn write(out: &Path, seed: u64) -> Result<PathBuf> {
    let dir = out.join(FOLDER);
    write_event(&dir, seed, &EventOptions::sample())?;
    Ok(dir)
}

/// Writes the event of `options` into `dir` (the zip of [`ZIP_NAME`] and
/// `truth.toml`, laid out as the bundled sample; any other event than the
/// sample also gets `truth_frequency.csv`: per sample, the true tangent f₁
/// and whether storey 1 took a plastic step, per direction) and returns the
/// simulation.
pub fn write_event(dir: &Path, seed: u64, options: &EventOptions) -> Result<Simulation> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let sim = simulate(seed, options)?;
    let [gx, gy, gz] = &sim.ground;
    let [rx, ry] = &sim.response;
    let frames = &sim.frames;
    let start_utc = civil("2026-08-03T21:47:09.600Z", 0)?;
    let start_local = civil("2026-08-03T21:47:09.600Z", -7)?;
    let mut chans: Vec<(usize, CsmipOrientation, &[f64])> = Vec::new();
    for &level in &LEVELS {
        let (x, y): (&[f64], &[f64]) = if level == 0 {
            (&gx, &gy)
        } else {
            (
                &rx.absolute_acceleration[level - 1],
                &ry.absolute_acceleration[level - 1],
            )
        };
        chans.push((level, CsmipOrientation::AzimuthDeg(360), x));
        chans.push((level, CsmipOrientation::AzimuthDeg(270), y));
        if level == 0 {
            chans.push((level, CsmipOrientation::Up, &gz));
        }
    }
    let total = chans.len() as u32;
    let mut members = Vec::new();
    for (k, (level, orientation, acc)) in chans.iter().enumerate() {
        // Noise-free apart from the processing, as the 2-storey yielding sample.
        let [a, v, d] = v2_processed(acc, RATE_HZ, BAND_HZ)?;
        let text = csmip_v2_text(&CsmipChannel {
            station_number: STATION,
            station_name: "Sample City - 6-story Commercial Bldg".into(),
            latitude: 34.181,
            longitude: -118.592,
            recorder: "Etna2".into(),
            serial: 3817,
            recorder_channel: k as u32 + 1,
            recorder_channels: total,
            station_channel: k as u32 + 1,
            station_channels: total,
            orientation: *orientation,
            location: level_label(*level, STOREYS, "Ground Floor"),
            start_utc,
            start_local,
            local_weekday: weekday(&start_local).into(),
            local_zone: "PDT".into(),
            band_hz: BAND_HZ,
            sampling_rate_hz: RATE_HZ,
            accel_cm_s2: &a,
            veloc_cm_s: &v,
            displ_cm: &d,
        });
        members.push((format!("CHAN{:03}.V2", k + 1), text.into_bytes()));
    }
    write_file(dir, ZIP_NAME, &zip_bytes(&members, &start_utc)?)?;
    write_file(
        dir,
        "truth.toml",
        truth(frames, &[("X", rx), ("Y", ry)], seed, options)?.as_bytes(),
    )?;
    write_file(
        dir,
        TRUTH_FREQUENCY_FILE,
        truth_frequency_csv(&sim)?.as_bytes(),
    )?;
    Ok(sim)
}

/// The per-sample truth of the apparent frequency beside the event
/// ([`truth_frequency_csv`]); the `assess` stage tables it beside its track.
pub const TRUTH_FREQUENCY_FILE: &str = "truth_frequency.csv";

/// The true tangent f₁ per sample and direction, read back from
/// [`TRUTH_FREQUENCY_FILE`].
#[derive(Debug, Clone, PartialEq)]
pub struct TruthFrequency {
    pub dt: f64,
    /// Per direction (X, Y): f₁ at each sample, and whether storey 1 took a
    /// plastic step in the sample interval.
    pub f1_hz: [Vec<f64>; 2],
    pub plastic: [Vec<bool>; 2],
}

impl TruthFrequency {
    /// The true f₁ of `direction` ("X" or "Y") over [t0, t1] when the frame
    /// is linear with one stiffness there (no plastic step), else `None`.
    pub fn defined_over(&self, direction: &str, t0: f64, t1: f64) -> Option<f64> {
        let d = match direction {
            "X" => 0,
            "Y" => 1,
            _ => return None,
        };
        let first = (t0 / self.dt).floor().max(0.0) as usize;
        let last = (t1 / self.dt).ceil() as usize;
        if last >= self.f1_hz[d].len() || first > last {
            return None;
        }
        (!self.plastic[d][first..last].iter().any(|&p| p)).then(|| self.f1_hz[d][first])
    }

    /// Reads the file; an error names the file and line.
    pub fn read(path: &Path) -> Result<TruthFrequency> {
        let text = crate::input_file::read_to_string(path, crate::input_file::MAX_INPUT_BYTES)?;
        let bad = |line: usize, why: &str| {
            Error::usage(format!("{}: line {line}: {why}", path.display()))
        };
        let mut time = Vec::new();
        let (mut fx, mut fy, mut px, mut py) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (i, line) in text.lines().enumerate().skip(1) {
            let cells: Vec<&str> = line.split(',').collect();
            if cells.len() != 5 {
                return Err(bad(i + 1, "expected 5 comma-separated cells"));
            }
            let num = |k: usize| {
                cells[k]
                    .trim()
                    .parse::<f64>()
                    .map_err(|_| bad(i + 1, "not a number"))
            };
            time.push(num(0)?);
            fx.push(num(1)?);
            px.push(num(2)? != 0.0);
            fy.push(num(3)?);
            py.push(num(4)? != 0.0);
        }
        let dt = match time.as_slice() {
            [a, b, ..] if b > a => b - a,
            _ => return Err(bad(1, "fewer than two samples")),
        };
        Ok(TruthFrequency {
            dt,
            f1_hz: [fx, fy],
            plastic: [px, py],
        })
    }
}

/// Per sample: time, the true tangent f₁ per direction and whether storey 1
/// took a plastic step in (t_k, t_{k+1}] (1) or not (0).
fn truth_frequency_csv(sim: &Simulation) -> Result<String> {
    let [fx, fy] = sim.true_first_frequency_hz()?;
    let [rx, ry] = &sim.response;
    let mut s = String::from("time_s,x_true_f1_hz,x_plastic_step,y_true_f1_hz,y_plastic_step\n");
    for k in 0..fx.len() {
        let _ = writeln!(
            s,
            "{:.2},{},{},{},{}",
            k as f64 * sim.dt,
            fx[k],
            u8::from(rx.storey1_plastic_step[k]),
            fy[k],
            u8::from(ry.storey1_plastic_step[k])
        );
    }
    Ok(s)
}

fn truth(
    frames: &[YieldingShearBuilding; 2],
    resp: &[(&str, &YieldingResponse)],
    seed: u64,
    options: &EventOptions,
) -> Result<String> {
    let mut s = String::new();
    let _ = writeln!(s, "# Truth of a synthetic event generated by `quaketwin synth` (seed {seed}); not a record file.");
    let _ = writeln!(s, "# 6-storey shear frame per direction: storey 1 a degrading bilinear spring (kinematic hardening,");
    let _ = writeln!(s, "# elastic stiffness k0 (dy/dmax)^rho), storeys 2-6 linear; Rayleigh damping on K0 (modes 1 and 3);");
    let _ = writeln!(s, "# central differences at {} Hz, recorded at {RATE_HZ} Hz, noise-free. X at azimuth 360°, Y at 270°.", RATE_HZ * SUBSTEPS as f64);
    let _ = writeln!(
        s,
        "# Levels: 0 = base (Ground Floor), N = floor N+1 (level 2 = 3rd Floor), 6 = Roof."
    );
    let _ = writeln!(s, "# Residual drift: storey 1's plastic drift at the end (its drift at rest); the storeys above end at zero.");
    let _ = writeln!(
        s,
        "model = \"yielding shear building (synth::yielding)\"\nseed = {seed}\nstoreys = {STOREYS}"
    );
    let _ = writeln!(
        s,
        "storey_heights_m = {STOREY_HEIGHTS_M:?}\nrecord_rate_hz = {RATE_HZ}\npga_x_m_s2 = {}",
        options.pga_x_m_s2
    );
    if *options != EventOptions::sample() {
        let _ = writeln!(
            s,
            "pre_event_s = {:?}\npost_event_s = {:?}\nambient_pga_m_s2 = {:?}\ntruth_frequency = \"truth_frequency.csv\"",
            options.pre_event_s, options.post_event_s, options.ambient_pga_m_s2
        );
    }
    for (b, (axis, r)) in frames.iter().zip(resp) {
        let initial = b.initial().modes()?;
        let k_final = r.final_storey1_stiffness_n_per_m;
        let after = b.with_storey1_stiffness(k_final).modes()?;
        let _ = writeln!(
            s,
            "\n[[direction]]\naxis = \"{axis}\"\nazimuth_deg = {}\nmasses_kg = {:?}\nstorey_stiffness_n_per_m = {:?}",
            if *axis == "X" { 360 } else { 270 },
            b.masses_kg, b.storey_stiffness_n_per_m
        );
        let _ = writeln!(s, "yield_force_n = {}\nhardening_ratio = {}\ndegradation_exponent = {}\ndamping_ratio = {}", b.yield_force_n, b.hardening_ratio, b.degradation_exponent, b.damping_ratio);
        let _ = writeln!(
            s,
            "storey1_yield_drift_m = {}\nstorey1_max_drift_m = {}",
            b.yield_force_n / b.storey_stiffness_n_per_m[0],
            r.storey1_max_drift_m
        );
        let _ = writeln!(
            s,
            "storey1_final_stiffness_n_per_m = {k_final}\nstorey1_residual_drift_m = {}",
            r.final_storey1_plastic_drift_m
        );
        let _ = writeln!(
            s,
            "initial_frequencies_hz = {:?}\nfinal_frequencies_hz = {:?}",
            initial.frequencies_hz, after.frequencies_hz
        );
    }
    for (axis, r) in resp {
        // At rest only storey 1 keeps a drift: level l ≥ 1 sits at the plastic drift.
        let rest = |l: usize| {
            if l == 0 {
                0.0
            } else {
                r.final_storey1_plastic_drift_m
            }
        };
        storey_and_segment_drifts(
            &mut s,
            axis,
            &r.relative_displacement,
            &STOREY_HEIGHTS_M,
            &LEVELS,
            rest,
        );
    }
    Ok(s)
}
