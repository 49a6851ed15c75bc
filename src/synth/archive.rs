//! A synthetic continuous-monitoring archive with known truth
//! (`quaketwin synth-archive`, issue 17 item 3): the sample building
//! ([`super::event::sample_building`], 4 storeys, X and Y) under ambient
//! excitation for several days, recorded by two horizontal accelerometers
//! per floor into an SDS MiniSEED archive with its StationXML.
//!
//! Environment and damage act on every storey stiffness through one factor
//! (docs/monitoring.md, "The synthetic archive", Eqs. A1–A2):
//!
//! (A1) s(t) = [1 + a_T sin(2π (τ/D − 0.375))] · [1 − a_L (L(t) − L̄)] · d(t)
//!
//! with τ the time since the start, D the day length (24 h), a_T = 0.01 the
//! temperature-driven daily variation (peak stiffness at 15:00), a_L = 0.004
//! the softening with the ambient level L (small-amplitude nonlinearity:
//! busier hours, slightly lower frequencies), L̄ = 0.65 the middle of L's
//! range and d(t) = 0.98 from the damage time on (start of day 2), 1 before.
//! Scaling K by s leaves the mass-normalised mode shapes unchanged, so the
//! modal equations stay decoupled with ω_j(t) = ω_j(0)·√s(t) and, with a
//! constant modal damping ratio, 2ζ_j ω_j(t) as damping: the true frequency
//! of mode j at t is f_j √s(t) (A2).
//!
//! The ambient level (traffic): L(t) = 0.3 + 0.7 · g_d · w(h), w(h) the
//! smooth working-day window ½(1 + tanh(h − 7)) · ½(1 + tanh(20 − h)) of
//! the hour of day h, g_d a seeded day-to-day factor in [0.8, 1.2].  Floor
//! forces: independent white noise of standard deviation L(t)·σ_F.
//!
//! Simulation: piecewise-constant parameters over blocks of 1 s with the
//! state carried across blocks; within a block each mode advances by the
//! exact zero-order-hold recursion of [`super::sdof_zoh`] for that block's
//! ω_j (the same one integrator as every synthetic event).  The parameters
//! change by less than 1e-6 relative between blocks (the damage step is a
//! single jump at a block boundary), far below what identification
//! resolves.  The truth of a window is the mean of f_j √s(t) over its blocks.
//!
//! Recording: absolute floor acceleration plus sensor noise (white, σ_n),
//! in counts at a gain G (INT32 MiniSEED records, `mseed_writer`); the
//! StationXML gives G (counts per m/s²) and the orientation: `HNE` azimuth
//! 90° measures X, `HNN` azimuth 0° measures Y; location code `0i` = floor i.
//! Seeded: same settings, same bytes.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::event::sample_building;
use super::{sdof_zoh, BuildingModes};
use crate::error::{Error, Result};
use crate::readers::mseed::StreamCodes;
use crate::readers::sds::day_file;
use crate::rng::Rng;
use crate::sinks::atomic::AtomicFile;
use crate::sinks::mseed_writer::{RecordEncoder, SampleEncoding};
use crate::vocab::format_epoch_ns;

/// Network and station codes of the synthetic building.
pub const NETWORK: &str = "QT";
pub const STATION: &str = "BLD";
/// Length of one simulation block with constant parameters, s.
const BLOCK_S: f64 = 1.0;
/// Middle of the ambient level's range (L̄ of Eq. A1).
const LEVEL_MEAN: f64 = 0.65;

/// Settings of the synthetic archive.
#[derive(Debug, Clone, PartialEq)]
pub struct ArchiveSettings {
    /// First sample, ns since the epoch (default 2026-01-01T00:00:00Z).
    pub start_ns: i64,
    pub days: usize,
    /// Length of a "day" (period of the daily cycles; damage at the start
    /// of the second), s.  86 400 except in shortened test archives.
    pub day_length_s: f64,
    /// Channels: two per floor (X, Y), top floors first; even, 2..=8.
    pub channels: usize,
    pub rate_hz: f64,
    pub seed: u64,
    /// a_T of Eq. A1.
    pub temperature_amplitude: f64,
    /// a_L of Eq. A1.
    pub level_softening: f64,
    /// d after the damage (0.98: a 2 % stiffness drop).
    pub damage_factor: f64,
    /// Day (0-based) from whose start the damage acts.
    pub damage_day: usize,
    /// σ_F at L = 1, N.
    pub force_std_n: f64,
    /// σ_n, m/s².
    pub sensor_noise_m_s2: f64,
    /// G, counts per m/s².
    pub gain_counts_per_m_s2: f64,
}

impl Default for ArchiveSettings {
    fn default() -> Self {
        ArchiveSettings {
            start_ns: 1_767_225_600_000_000_000,
            days: 3,
            day_length_s: 86_400.0,
            channels: 8,
            rate_hz: 100.0,
            seed: 1,
            temperature_amplitude: 0.01,
            level_softening: 0.004,
            damage_factor: 0.98,
            damage_day: 1,
            force_std_n: 2.0e3,
            sensor_noise_m_s2: 2.0e-5,
            gain_counts_per_m_s2: 4.0e5,
        }
    }
}

impl ArchiveSettings {
    pub fn validate(&self) -> Result<()> {
        if !(2..=8).contains(&self.channels) || self.channels % 2 != 0 {
            return Err(Error::usage(format!(
                "synth-archive: --channels must be 2, 4, 6 or 8 (two per floor of the 4-storey building), got {}",
                self.channels
            )));
        }
        if self.days == 0 || self.days > 366 {
            return Err(Error::usage("synth-archive: --days must be 1..=366"));
        }
        if !(self.rate_hz.is_finite() && self.rate_hz >= 10.0 && self.rate_hz <= 1000.0) {
            return Err(Error::usage(format!(
                "synth-archive: --rate must be 10..=1000 Hz, got {}",
                self.rate_hz
            )));
        }
        if (1e4 / self.rate_hz).fract() != 0.0 {
            return Err(Error::usage(format!(
                "synth-archive: the sample interval of {} Hz is not a multiple of 100 µs (MiniSEED BTIME)",
                self.rate_hz
            )));
        }
        if !(self.day_length_s >= 600.0 && self.day_length_s <= 86_400.0) {
            return Err(Error::usage(format!(
                "synth-archive: --day-length {} s must lie in [600 s, 24h]",
                self.day_length_s
            )));
        }
        Ok(())
    }

    fn duration_s(&self) -> f64 {
        self.days as f64 * self.day_length_s
    }

    /// Floors recorded (top floors first), 1-based.
    pub fn floors(&self) -> Vec<usize> {
        (0..self.channels / 2).map(|k| 4 - k).collect()
    }

    /// The recorded streams: per floor `HNE` (X) then `HNN` (Y).
    pub fn streams(&self) -> Vec<(StreamCodes, usize, &'static str)> {
        let mut floors = self.floors();
        floors.sort();
        floors
            .into_iter()
            .flat_map(|f| {
                [("HNE", "X"), ("HNN", "Y")].map(|(cha, axis)| {
                    (
                        StreamCodes {
                            network: NETWORK.into(),
                            station: STATION.into(),
                            location: format!("{f:02}"),
                            channel: cha.into(),
                        },
                        f,
                        axis,
                    )
                })
            })
            .collect()
    }

    /// Day-to-day traffic factor g_d of day `day` (seeded).
    fn day_factor(&self, day: i64) -> f64 {
        Rng::derived(self.seed, 1_000 + day.max(0) as u64).uniform_in(0.8, 1.2)
    }

    /// Ambient level L(τ), τ seconds after the start.
    pub fn level(&self, tau_s: f64) -> f64 {
        let day = (tau_s / self.day_length_s).floor();
        let h = 24.0 * (tau_s / self.day_length_s - day);
        let window = 0.25 * (1.0 + (h - 7.0).tanh()) * (1.0 + (20.0 - h).tanh());
        0.3 + 0.7 * self.day_factor(day as i64) * window
    }

    /// Stiffness factor s(τ) (Eq. A1).
    pub fn stiffness_factor(&self, tau_s: f64) -> f64 {
        let phase = tau_s / self.day_length_s - 0.375;
        let temperature = 1.0 + self.temperature_amplitude * (std::f64::consts::TAU * phase).sin();
        let level = 1.0 - self.level_softening * (self.level(tau_s) - LEVEL_MEAN);
        let damaged = tau_s >= self.damage_day as f64 * self.day_length_s;
        temperature * level * if damaged { self.damage_factor } else { 1.0 }
    }

    fn block_len(&self) -> usize {
        (BLOCK_S * self.rate_hz).round() as usize
    }

    /// Mid-block time τ of block b, s.
    fn block_mid_s(&self, b: usize) -> f64 {
        (b as f64 + 0.5) * BLOCK_S
    }
}

/// The true modes of the building at s = 1, X then Y.
pub fn reference_modes() -> Result<Vec<(&'static str, BuildingModes)>> {
    sample_building()
        .into_iter()
        .map(|(axis, b)| Ok((axis, b.modes()?)))
        .collect()
}

/// One mode's truth over a window.
#[derive(Debug, Clone, PartialEq)]
pub struct TrueMode {
    /// `X` or `Y`, and the mode's rank in that direction (1-based).
    pub axis: &'static str,
    pub rank: usize,
    /// Mean of f_j √s(t) over the window (Eq. A2), Hz.
    pub frequency_hz: f64,
    pub damping_ratio: f64,
}

/// The truth of every mode over `[t0, t1)` (ns): Eq. A2 averaged over the
/// simulation blocks whose middle lies in the window.
pub fn true_modes(settings: &ArchiveSettings, t0_ns: i64, t1_ns: i64) -> Result<Vec<TrueMode>> {
    let tau = |t: i64| (t - settings.start_ns) as f64 * 1e-9;
    let (a, b) = (tau(t0_ns), tau(t1_ns));
    let first = (a / BLOCK_S).floor().max(0.0) as usize;
    let mut sum = 0.0;
    let mut n = 0usize;
    let mut blk = first;
    while settings.block_mid_s(blk) < b {
        if settings.block_mid_s(blk) >= a {
            sum += settings.stiffness_factor(settings.block_mid_s(blk)).sqrt();
            n += 1;
        }
        blk += 1;
    }
    let mean_root = if n > 0 { sum / n as f64 } else { f64::NAN };
    let mut out = Vec::new();
    for (axis, m) in reference_modes()? {
        for (j, f) in m.frequencies_hz.iter().enumerate() {
            out.push(TrueMode {
                axis,
                rank: j + 1,
                frequency_hz: f * mean_root,
                damping_ratio: m.damping_ratios[j],
            });
        }
    }
    Ok(out)
}

/// Modal state of one direction's building, carried across blocks.
struct ModalState {
    modes: BuildingModes,
    q: Vec<f64>,
    qd: Vec<f64>,
    forces: Rng,
}

impl ModalState {
    /// Advances `n` samples at stiffness factor `s` and level `level`,
    /// adding the absolute floor accelerations (rows: floors 1..4) to `acc`
    /// from column `at`.
    fn advance(
        &mut self,
        n: usize,
        dt: f64,
        s: f64,
        force_std: f64,
        acc: &mut [Vec<f64>],
        at: usize,
    ) {
        let floors = self.modes.shapes.len();
        let forces: Vec<Vec<f64>> = (0..floors)
            .map(|_| self.forces.normal_vec(n, force_std))
            .collect();
        for j in 0..self.modes.shapes.len() {
            let omega = self.modes.circular_frequencies[j] * s.sqrt();
            let zeta = self.modes.damping_ratios[j];
            let (ad, bd) = sdof_zoh(omega, zeta, dt);
            let phi = &self.modes.shapes[j];
            let (mut q, mut qd) = (self.q[j], self.qd[j]);
            for k in 0..n {
                // Modal load p_j = φ_jᵀ f (ambient forces on the floors).
                let p: f64 = (0..floors).map(|i| phi[i] * forces[i][k]).sum();
                let qdd = p - 2.0 * zeta * omega * qd - omega * omega * q;
                for i in 0..floors {
                    acc[i][at + k] += phi[i] * qdd;
                }
                let q_next = ad[0][0] * q + ad[0][1] * qd + bd[0] * p;
                qd = ad[1][0] * q + ad[1][1] * qd + bd[1] * p;
                q = q_next;
            }
            self.q[j] = q;
            self.qd[j] = qd;
        }
    }
}

/// Simulates the archive's floor accelerations chunk by chunk (`chunk_s`
/// seconds each): calls `sink(first_sample, rows)` with one row per stream
/// of [`ArchiveSettings::streams`], in m/s² with sensor noise.  Memory: one chunk.
pub fn simulate(
    settings: &ArchiveSettings,
    chunk_s: f64,
    mut sink: impl FnMut(usize, &[Vec<f64>]) -> Result<()>,
) -> Result<()> {
    settings.validate()?;
    let dt = 1.0 / settings.rate_hz;
    let mut states: Vec<ModalState> = reference_modes()?
        .into_iter()
        .enumerate()
        .map(|(k, (_, modes))| {
            let n = modes.shapes.len();
            ModalState {
                modes,
                q: vec![0.0; n],
                qd: vec![0.0; n],
                forces: Rng::derived(settings.seed, 1 + k as u64),
            }
        })
        .collect();
    let mut noise = Rng::derived(settings.seed, 3);
    let block = settings.block_len();
    // Start-up: ten of the slowest decay times 1/(ζω) at the first block's
    // parameters, discarded, so the record starts stationary.
    let slowest = states
        .iter()
        .flat_map(|st| {
            st.modes
                .circular_frequencies
                .iter()
                .zip(&st.modes.damping_ratios)
                .map(|(w, z)| 1.0 / (z * w))
        })
        .fold(0.0, f64::max);
    let warm = (10.0 * slowest * settings.rate_hz).ceil() as usize;
    let (s0, l0) = (settings.stiffness_factor(0.0), settings.level(0.0));
    let mut scratch = vec![vec![0.0; warm]; 4];
    for st in states.iter_mut() {
        st.advance(warm, dt, s0, l0 * settings.force_std_n, &mut scratch, 0);
        scratch.iter_mut().for_each(|r| r.fill(0.0));
    }
    let total_blocks = (settings.duration_s() / BLOCK_S).round() as usize;
    let blocks_per_chunk = ((chunk_s / BLOCK_S).round() as usize).max(1);
    let streams = settings.streams();
    let mut b = 0usize;
    while b < total_blocks {
        let nb = blocks_per_chunk.min(total_blocks - b);
        let n = nb * block;
        let mut acc = [vec![vec![0.0; n]; 4], vec![vec![0.0; n]; 4]];
        for k in 0..nb {
            let tau = settings.block_mid_s(b + k);
            let (s, level) = (settings.stiffness_factor(tau), settings.level(tau));
            for (st, a) in states.iter_mut().zip(acc.iter_mut()) {
                st.advance(block, dt, s, level * settings.force_std_n, a, k * block);
            }
        }
        // Ambient case: no base motion, so relative = absolute acceleration.
        let rows: Vec<Vec<f64>> = streams
            .iter()
            .map(|(_, floor, axis)| {
                let a = &acc[usize::from(*axis == "Y")][floor - 1];
                a.iter()
                    .map(|v| v + settings.sensor_noise_m_s2 * noise.normal())
                    .collect()
            })
            .collect();
        sink(b * block, &rows)?;
        b += nb;
    }
    Ok(())
}

/// What `quaketwin synth-archive` wrote.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ArchiveWritten {
    pub archive: PathBuf,
    pub stationxml: PathBuf,
    pub truth: PathBuf,
    pub streams: Vec<String>,
    pub start: String,
    pub end: String,
    pub day_files: usize,
    pub bytes: u64,
}

/// Writes the archive under `out`: `out/sds/…` (SDS tree), `out/station.xml`
/// and `out/truth.csv` (true frequency per hour window and mode: the
/// window's start, axis, rank, frequency, damping, stiffness factor).
pub fn write_archive(out: &Path, settings: &ArchiveSettings) -> Result<ArchiveWritten> {
    settings.validate()?;
    let root = out.join("sds");
    std::fs::create_dir_all(&root).map_err(|e| Error::io(&root, e))?;
    let streams = settings.streams();
    let mut encoders: Vec<RecordEncoder> = streams
        .iter()
        .map(|(c, _, _)| {
            RecordEncoder::new(
                c.clone(),
                settings.rate_hz,
                settings.start_ns,
                SampleEncoding::Int32,
            )
        })
        .collect();
    // Open day file per stream (records go to the file of their start day),
    // written through the atomic writer: a link or FIFO at a day file's path
    // is refused, never followed or opened; an error leaves no temporary file.
    let mut open: Vec<Option<AtomicFile>> = (0..streams.len()).map(|_| None).collect();
    let mut day_files = 0usize;
    let mut bytes = 0u64;
    let gain = settings.gain_counts_per_m_s2;
    let mut emit_into = |k: usize,
                         open: &mut Vec<Option<AtomicFile>>,
                         start_ns: i64,
                         record: &[u8]|
     -> Result<()> {
        let path = day_file(&root, &streams[k].0, start_ns);
        if open[k].as_ref().map(|f| f.path() != path).unwrap_or(true) {
            if let Some(f) = open[k].take() {
                f.commit()?;
            }
            open[k] = Some(AtomicFile::create(&path)?);
            day_files += 1;
        }
        if let Some(f) = open[k].as_mut() {
            f.write_all(record).map_err(|e| Error::io(&path, e))?;
        }
        bytes += record.len() as u64;
        Ok(())
    };
    simulate(settings, 3600.0, |_, rows| {
        for (k, row) in rows.iter().enumerate() {
            let counts: Vec<f64> = row.iter().map(|v| v * gain).collect();
            encoders[k].push(&counts, &mut |t, r| emit_into(k, &mut open, t, r))?;
        }
        Ok(())
    })?;
    for (k, enc) in encoders.iter_mut().enumerate() {
        enc.finish(&mut |t, r| emit_into(k, &mut open, t, r))?;
    }
    for f in open.into_iter().flatten() {
        f.commit()?;
    }
    let end_ns = settings.start_ns + (settings.duration_s() * 1e9).round() as i64;
    let stationxml = out.join("station.xml");
    crate::sinks::atomic::write_bytes_atomically(
        &stationxml,
        stationxml_text(settings, end_ns).as_bytes(),
    )?;
    let truth = out.join("truth.csv");
    crate::sinks::atomic::write_bytes_atomically(&truth, truth_csv(settings, end_ns)?.as_bytes())?;
    Ok(ArchiveWritten {
        archive: root,
        stationxml,
        truth,
        streams: streams.iter().map(|(c, _, _)| c.id()).collect(),
        start: format_epoch_ns(settings.start_ns),
        end: format_epoch_ns(end_ns),
        day_files,
        bytes,
    })
}

/// Sensitivity of the synthetic accelerometer (response stage 1), V per
/// m/s²: about the 10 V/g of force-balance accelerometers.  The digitizer
/// (stage 2) has the rest of the gain G, so the stages multiply to G.
pub const SENSOR_V_PER_M_S2: f64 = 1.0;

/// The `<Response>` of a channel: the overall sensitivity G (counts per
/// m/s² at 1 Hz) and the stages it is made of, so that response removal
/// (ObsPy's `remove_response`, evalresp) can evaluate it at every
/// frequency.  The simulation records the floor acceleration itself —
/// samples of the true acceleration at the output rate, no sensor dynamics,
/// no anti-alias filter — so the true response is flat:
///
/// - stage 1, the sensor: poles and zeros, none of either (flat), gain
///   [`SENSOR_V_PER_M_S2`], m/s² → V;
/// - stage 2, the digitizer: a digital filter of one coefficient 1 (no
///   filtering), decimation factor 1 at the archive's rate (no FIR stages:
///   nothing is decimated), gain G / [`SENSOR_V_PER_M_S2`], V → counts.
///
/// Stage gains are given at 1 Hz, the sensitivity's frequency: with a flat
/// response the product of the stage gains is G at every frequency.
fn response_xml(gain_counts_per_m_s2: f64, rate_hz: f64) -> String {
    let sensor = SENSOR_V_PER_M_S2;
    let digitizer = gain_counts_per_m_s2 / sensor;
    let acc = "<Name>m/s**2</Name><Description>acceleration</Description>";
    let volts = "<Name>V</Name><Description>volts</Description>";
    let counts = "<Name>counts</Name><Description>digital counts</Description>";
    format!(
        r#"        <Response>
          <InstrumentSensitivity><Value>{gain_counts_per_m_s2}</Value><Frequency>1</Frequency><InputUnits>{acc}</InputUnits><OutputUnits>{counts}</OutputUnits></InstrumentSensitivity>
          <Stage number="1">
            <PolesZeros name="sensor">
              <InputUnits>{acc}</InputUnits><OutputUnits>{volts}</OutputUnits>
              <PzTransferFunctionType>LAPLACE (RADIANS/SECOND)</PzTransferFunctionType>
              <NormalizationFactor>1</NormalizationFactor><NormalizationFrequency>1</NormalizationFrequency>
            </PolesZeros>
            <StageGain><Value>{sensor}</Value><Frequency>1</Frequency></StageGain>
          </Stage>
          <Stage number="2">
            <Coefficients name="digitizer">
              <InputUnits>{volts}</InputUnits><OutputUnits>{counts}</OutputUnits>
              <CfTransferFunctionType>DIGITAL</CfTransferFunctionType>
              <Numerator>1</Numerator>
            </Coefficients>
            <Decimation><InputSampleRate>{rate_hz}</InputSampleRate><Factor>1</Factor><Offset>0</Offset><Delay>0</Delay><Correction>0</Correction></Decimation>
            <StageGain><Value>{digitizer}</Value><Frequency>1</Frequency></StageGain>
          </Stage>
        </Response>
"#
    )
}

/// StationXML of the archive's streams: response (sensitivity and stages,
/// [`response_xml`]), orientation, floor elevation.
fn stationxml_text(settings: &ArchiveSettings, end_ns: i64) -> String {
    let heights = super::event::STOREY_HEIGHTS_M;
    let mut channels = String::new();
    for (c, floor, axis) in settings.streams() {
        let azimuth = if axis == "X" { 90.0 } else { 0.0 };
        let elevation: f64 = heights[..floor].iter().sum();
        channels += &format!(
            r#"      <Channel code="{cha}" locationCode="{loc}" startDate="{start}">
        <Latitude>0</Latitude><Longitude>0</Longitude><Elevation>{elevation}</Elevation><Depth>0</Depth>
        <Azimuth>{azimuth}</Azimuth><Dip>0</Dip>
        <SampleRate>{rate}</SampleRate>
        <Sensor><Description>synthetic accelerometer, floor {floor} {axis}</Description></Sensor>
{response}      </Channel>
"#,
            cha = c.channel,
            loc = c.location,
            start = format_epoch_ns(settings.start_ns),
            rate = settings.rate_hz,
            response = response_xml(settings.gain_counts_per_m_s2, settings.rate_hz),
        );
    }
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<FDSNStationXML xmlns="http://www.fdsn.org/xml/station/1" schemaVersion="1.1">
  <Source>quaketwin synth-archive (seed {seed})</Source>
  <Created>{created}</Created>
  <Network code="{NETWORK}">
    <Station code="{STATION}" startDate="{start}" endDate="{end}">
      <Latitude>0</Latitude><Longitude>0</Longitude><Elevation>0</Elevation>
      <Site><Name>synthetic 4-storey shear building</Name></Site>
{channels}    </Station>
  </Network>
</FDSNStationXML>
"#,
        seed = settings.seed,
        created = format_epoch_ns(settings.start_ns),
        start = format_epoch_ns(settings.start_ns),
        end = format_epoch_ns(end_ns),
    )
}

/// `truth.csv`: one row per hour window and mode.
fn truth_csv(settings: &ArchiveSettings, end_ns: i64) -> Result<String> {
    let mut s = String::from(
        "window_start,axis,rank,frequency_hz,damping_ratio,stiffness_factor,ambient_level\n",
    );
    let hour = 3_600_000_000_000i64;
    let mut t = settings.start_ns;
    while t < end_ns {
        let tau = (t - settings.start_ns) as f64 * 1e-9 + 1800.0;
        for m in true_modes(settings, t, (t + hour).min(end_ns))? {
            s += &format!(
                "{},{},{},{:.9},{},{:.9},{:.6}\n",
                format_epoch_ns(t),
                m.axis,
                m.rank,
                m.frequency_hz,
                m.damping_ratio,
                settings.stiffness_factor(tau),
                settings.level(tau)
            );
        }
        t += hour;
    }
    Ok(s)
}
