//! `quaketwin track`: continuous monitoring from an SDS MiniSEED archive
//! (issue 17 item 3).  The edges of [`crate::monitor`]: reads the archive
//! window by window ([`crate::readers::sds`]), applies the StationXML,
//! identifies the windows in parallel (rayon; each window independent, so
//! the output does not depend on the thread count), then tracks, fits the
//! anomaly band and writes `modal_tracking.parquet` and `tracking.html`
//! (docs/monitoring.md).

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::modal::change_test::ChangeTestResult;
use crate::modal::{ModalSettings, Mode};
use crate::monitor::anomaly::{self, BandModel, BandSettings};
use crate::monitor::compensation::compensate;
use crate::monitor::environment::{ChartSettings, EnvironmentSeries};
use crate::monitor::tracking::{Reference, TrackSettings, TrackedMode};
use crate::monitor::window::{parse_duration, WindowGrid, NS_PER_S};
use crate::monitor::{analyse, identify_window, Tracking, WindowModes, WindowSignals};
use crate::readers::mseed::StreamCodes;
use crate::readers::sds::{SdsArchive, StreamPattern, DAMAGE_NOTE};
use crate::sinks::parquet::{write_parquet, TableBuilder};
use crate::sinks::provenance::Provenance;
use crate::vocab::tables::{modal_tracking as col, CONTROL_CHART, MODAL_TRACKING};
use crate::vocab::{format_epoch_ns, parse_iso8601_ns};

mod chart_table;
pub mod response;
pub mod temperature;
use chart_table::{chart_batch, chart_metadata};
use response::Calibration;

pub const TABLE_FILE: &str = MODAL_TRACKING.file;
pub const REPORT_FILE: &str = "tracking.html";
pub const CHART_FILE: &str = CONTROL_CHART.file;

/// The command's flags, as typed (checked by [`TrackOptions::plan`] before any work).
/// Unknown fields are refused (a misspelt option from Python, `windw`,
/// must not silently run the whole archive with the default window).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackOptions {
    pub archive: PathBuf,
    pub out: PathBuf,
    pub start: Option<String>,
    pub end: Option<String>,
    /// `NET.STA.LOC.CHAN` patterns; empty = every stream.
    pub channels: Vec<String>,
    pub stationxml: Option<PathBuf>,
    pub window: String,
    /// Default: the window length (no overlap).
    pub step: Option<String>,
    pub training: String,
    pub reference: Option<PathBuf>,
    /// Windows with a smaller share of recorded samples are skipped.
    pub min_present: f64,
    /// Period of the environmental cycle of the band (default 24 h); also
    /// the length of the control chart's subgroups.
    pub cycle: String,
    /// Measured temperature, a CSV of time, value (Eq. E1).
    pub temperature: Option<PathBuf>,
    /// Measured temperature, a stream of the archive (`NET.STA.LOC.CHAN`).
    pub temperature_channel: Option<String>,
}

impl Default for TrackOptions {
    fn default() -> Self {
        TrackOptions::new(Path::new(""), Path::new(""))
    }
}

impl TrackOptions {
    pub fn new(archive: &Path, out: &Path) -> Self {
        TrackOptions {
            archive: archive.to_path_buf(),
            out: out.to_path_buf(),
            start: None,
            end: None,
            channels: Vec::new(),
            stationxml: None,
            window: "1h".into(),
            step: None,
            training: "24h".into(),
            reference: None,
            min_present: 0.9,
            cycle: "24h".into(),
            temperature: None,
            temperature_channel: None,
        }
    }
}

/// One mode's line of the summary.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ModeSummary {
    pub mode: usize,
    pub direction: String,
    pub reference_frequency_hz: f64,
    /// Windows where the mode was found.
    pub windows: usize,
    pub band: Option<BandModel>,
    /// Flagged windows after the training period.
    pub flagged_windows: usize,
    /// Mean of `deviation_percent` over the flagged windows after training.
    pub mean_flagged_deviation_percent: Option<f64>,
    /// First flagged window after training.
    pub first_flagged: Option<String>,
}

/// What `quaketwin track` did (`--json`).  A run that failed is summarised
/// too ([`TrackSummary::failed`]): `ok` false, the error, the rest empty.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct TrackSummary {
    /// Whether the run ended without error.
    pub ok: bool,
    /// The error text when not (printable, capped at
    /// [`crate::error::MAX_PRINTED_ERROR_CHARS`] characters).
    pub error: Option<String>,
    pub archive: PathBuf,
    pub out: PathBuf,
    pub streams: Vec<String>,
    /// `m/s^2`, or `counts` without StationXML.
    pub units: String,
    pub start: String,
    pub end: String,
    pub window_s: f64,
    pub step_s: f64,
    pub windows: usize,
    pub identified_windows: usize,
    /// Windows skipped and why: (start, reason).
    pub skipped: Vec<(String, String)>,
    pub reference: String,
    pub modes: Vec<ModeSummary>,
    pub training_end: String,
    /// First window of the first sustained anomaly (Eq. M5), if any.
    pub anomaly_from: Option<String>,
    /// Anomalous windows after training (Eq. M5).
    pub anomalous_windows: usize,
    /// Environmental compensation: `measured` or `latent` (empty: no chart).
    pub compensation: String,
    /// First subgroup of the control chart's first alarm (Eq. E5), if any.
    pub control_alarm_from: Option<String>,
    /// Out-of-control subgroups after training (Eq. E4).
    pub out_of_control_subgroups: usize,
    pub seconds: f64,
    pub files: Vec<PathBuf>,
}

impl TrackSummary {
    /// The summary of a run of `opts` that failed with `error`: `ok` false,
    /// the error made printable and capped as on stderr, nothing else found.
    pub fn failed(opts: &TrackOptions, error: &Error) -> TrackSummary {
        TrackSummary {
            ok: false,
            error: Some(crate::error::printable(
                &error.to_string(),
                crate::error::MAX_PRINTED_ERROR_CHARS,
            )),
            archive: opts.archive.clone(),
            out: opts.out.clone(),
            ..Default::default()
        }
    }
}

/// Checked plan of a run: everything parsed before any record is read.
struct Plan {
    grid: WindowGrid,
    patterns: Vec<StreamPattern>,
    training_ns: i64,
    cycle_s: f64,
    reference: Option<(Vec<Mode>, Vec<String>, String)>,
    /// The `--temperature` CSV, read.
    temperature: Option<EnvironmentSeries>,
}

fn time_flag(flag: &str, text: &str) -> Result<i64> {
    parse_iso8601_ns(text).ok_or_else(|| {
        Error::usage(format!(
            "{flag} {text:?} is not a UTC time (example: 2026-01-01T00:00:00Z)"
        ))
    })
}

impl TrackOptions {
    /// Checks every flag; `span` gives the archive's span for unset --start/--end.
    fn plan(&self, span: impl FnOnce() -> Result<(i64, i64)>) -> Result<Plan> {
        let length = parse_duration("--window", &self.window)?;
        let step = match &self.step {
            Some(s) => parse_duration("--step", s)?,
            None => length,
        };
        let training_ns = parse_duration("--training", &self.training)?;
        let cycle_s = parse_duration("--cycle", &self.cycle)? as f64 / NS_PER_S as f64;
        if !(self.min_present > 0.0 && self.min_present <= 1.0) {
            return Err(Error::usage(format!(
                "--min-present must lie in (0, 1], got {}",
                self.min_present
            )));
        }
        let patterns = self
            .channels
            .iter()
            .map(|p| StreamPattern::parse(p))
            .collect::<Result<Vec<_>>>()?;
        let start = self
            .start
            .as_deref()
            .map(|t| time_flag("--start", t))
            .transpose()?;
        let end = self
            .end
            .as_deref()
            .map(|t| time_flag("--end", t))
            .transpose()?;
        let reference = match &self.reference {
            None => None,
            Some(p) => {
                let (modes, channels) = crate::sinks::modal_tables::read_modes(p)?;
                if modes.is_empty() {
                    return Err(Error::input(
                        crate::error::Location::file(p.display().to_string()),
                        "the reference holds no mode",
                    ));
                }
                Some((modes, channels, p.display().to_string()))
            }
        };
        if let Some(id) = &self.temperature_channel {
            StreamPattern::parse(id)?;
            if self.temperature.is_some() {
                return Err(Error::usage(
                    "--temperature and --temperature-channel: give one measured temperature",
                ));
            }
        }
        let temperature = self
            .temperature
            .as_deref()
            .map(temperature::read_csv)
            .transpose()?;
        let (start, end) = match (start, end) {
            (Some(s), Some(e)) => (s, e),
            (s, e) => {
                let (a, b) = span()?;
                (s.unwrap_or(a), e.unwrap_or(b))
            }
        };
        Ok(Plan {
            grid: WindowGrid::new(start, end, length, step)?,
            patterns,
            training_ns,
            cycle_s,
            reference,
            temperature,
        })
    }
}

/// Reads and identifies the window starting at `t0`.
fn window_modes(
    archive: &SdsArchive,
    calibration: &Calibration,
    t0: i64,
    length: i64,
    min_present: f64,
    settings: &ModalSettings,
) -> WindowModes {
    let t1 = t0 + length;
    let cal = match calibration.at(archive.streams(), t0) {
        Ok(c) => c,
        Err(e) => return WindowModes::skipped(t0, t1, 0.0, e.to_string()),
    };
    let read = match archive.read_window(t0, t1) {
        Ok(Some(w)) => w,
        Ok(None) => {
            return WindowModes::skipped(t0, t1, 0.0, "no samples of some stream".into());
        }
        Err(e) => return WindowModes::skipped(t0, t1, 0.0, e.to_string()),
    };
    if read.present_fraction < min_present {
        return WindowModes::skipped(
            t0,
            t1,
            read.present_fraction,
            format!(
                "{:.1} % of the samples recorded, below --min-present {:.1} %",
                100.0 * read.present_fraction,
                100.0 * min_present
            ),
        );
    }
    let signals = read
        .signals
        .into_iter()
        .zip(&cal.scale)
        .map(|(s, k)| s.into_iter().map(|v| v * k).collect())
        .collect();
    let mut w = identify_window(
        WindowSignals {
            start_ns: t0,
            end_ns: t1,
            rate_hz: read.rate_hz,
            ids: archive.streams().iter().map(StreamCodes::id).collect(),
            directions: cal.directions.clone(),
            groups: cal.groups.clone(),
            signals,
            present_fraction: read.present_fraction,
        },
        settings,
    );
    w.notes.extend(read.notes);
    w.notes
        .extend(calibration.epoch_changes(archive.streams(), t0, t1));
    w
}

/// A checked run, ready to identify windows: flags parsed, archive opened
/// and selected, StationXML applied.  Workers of a cluster each prepare
/// their own and identify their share of [`Prepared::starts`]; one process
/// then [`Prepared::finish`]es with every window.
pub struct Prepared {
    opts: TrackOptions,
    plan: Plan,
    archive: SdsArchive,
    cal: Calibration,
    settings: ModalSettings,
}

/// Checks the flags (before the archive is walked, except --start/--end
/// defaults, which need it), opens the archive and applies the StationXML.
pub fn prepare(opts: &TrackOptions) -> Result<Prepared> {
    crate::fixed_order_reductions();
    let mut opened: Option<SdsArchive> = None;
    let plan = opts.plan(|| {
        let a = SdsArchive::open(&opts.archive)?;
        let span = a.span();
        opened = Some(a);
        Ok(span)
    })?;
    let archive = match opened {
        Some(a) => a,
        None => SdsArchive::open(&opts.archive)?,
    }
    .select(&plan.patterns)?;
    // The temperature stream is no accelerometer: not identified.
    let archive = match &opts.temperature_channel {
        Some(id) => archive.without(id),
        None => archive,
    };
    if archive.streams().len() < 2 {
        return Err(Error::input(
            crate::error::Location::file(opts.archive.display().to_string()),
            format!(
                "ambient identification needs at least two streams; the selection holds {}",
                archive.streams().len()
            ),
        ));
    }
    let cal = Calibration::new(archive.streams(), opts.stationxml.as_deref())?;
    Ok(Prepared {
        opts: opts.clone(),
        plan,
        archive,
        cal,
        // No data-driven σ per window (docs/statistics.md S1–S5): the tracking
        // table carries each window's scatter over orders and the anomaly band
        // the windows' spread, and the per-window change test forms its own
        // covariance blocks.  It would only cost time on a year of windows.
        settings: ModalSettings {
            uncertainty_blocks: Some(0),
            ..ModalSettings::default()
        },
    })
}

impl Prepared {
    /// Start times of every window of the run, ns.
    pub fn starts(&self) -> Vec<i64> {
        self.plan.grid.starts()
    }

    /// Identifies the windows starting at `starts` (in time order), in
    /// parallel batches; the day-file indexes of days behind a batch are
    /// dropped, so memory stays at a few windows.
    pub fn identify(&self, starts: &[i64], progress: bool) -> Vec<WindowModes> {
        let bar = crate::console::bar(starts.len() as u64, "track", "windows", !progress);
        let batch = (2 * rayon::current_num_threads()).max(4);
        let mut windows: Vec<WindowModes> = Vec::with_capacity(starts.len());
        for chunk in starts.chunks(batch) {
            let done: Vec<WindowModes> = chunk
                .par_iter()
                .map(|&t0| {
                    window_modes(
                        &self.archive,
                        &self.cal,
                        t0,
                        self.plan.grid.length_ns,
                        self.opts.min_present,
                        &self.settings,
                    )
                })
                .collect();
            // Only the training windows' blocks make the change test's
            // reference (monitor::change); the others keep their means.
            let training_end = self.plan.grid.start_ns + self.plan.training_ns;
            let done = done.into_iter().map(|mut w| {
                if w.start_ns >= training_end {
                    w.covariances = w.covariances.map(|c| c.without_blocks());
                }
                w
            });
            bar.inc(chunk.len() as u64);
            windows.extend(done);
            if let Some(&next) = chunk.last() {
                self.archive.forget_before(next + self.plan.grid.step_ns);
            }
        }
        bar.finish_and_clear();
        windows
    }

    /// Tracks, fits the bands and writes the outputs from every window of
    /// the run (in time order), whoever identified them.
    pub fn finish(
        self,
        windows: Vec<WindowModes>,
        clock: std::time::Instant,
    ) -> Result<(TrackSummary, Tracking)> {
        let Prepared {
            opts,
            plan,
            archive,
            cal,
            settings,
        } = self;
        let opts = &opts;
        let length = plan.grid.length_ns;
        for w in windows.iter().filter(|w| w.skipped.is_some()) {
            crate::console::warn(format!(
                "track: window {} skipped: {}",
                format_epoch_ns(w.start_ns),
                w.skipped.as_deref().unwrap_or("")
            ));
        }
        for w in &windows {
            // Epoch changes and damaged MiniSEED: what a reader of stderr
            // must see (every note is in the table metadata too).
            for n in w
                .notes
                .iter()
                .filter(|n| n.starts_with("StationXML epoch") || n.starts_with(DAMAGE_NOTE))
            {
                crate::console::warn(format!(
                    "track: window {}: {n}",
                    format_epoch_ns(w.start_ns)
                ));
            }
        }
        let reference = plan.reference.map(|(modes, channels, source)| Reference {
            modes,
            channels,
            source,
        });
        let band_settings = BandSettings {
            training_end_ns: plan.grid.start_ns + plan.training_ns,
            cycle_period_s: plan.cycle_s,
            confidence: 0.99,
            min_run: 3,
        };
        let mut tracking = analyse(windows, reference, &TrackSettings::default(), band_settings)?;
        let measured = match (&opts.temperature_channel, plan.temperature) {
            (Some(id), _) => Some(temperature::read_channel(
                &opts.archive,
                id,
                &plan.grid.starts(),
                length,
            )?),
            (None, t) => t,
        };
        let chart_settings = ChartSettings {
            subgroup: ((plan.cycle_s * NS_PER_S as f64 / plan.grid.step_ns as f64).round()
                as usize)
                .max(1),
            ..Default::default()
        };
        tracking.compensation = compensate(
            &tracking.windows,
            &tracking.rows,
            tracking.reference.modes.len(),
            band_settings.training_end_ns,
            measured.as_ref(),
            &chart_settings,
        );
        for w in &tracking.compensation.warnings {
            crate::console::warn(format!("track: {w}"));
        }
        let streams: Vec<String> = archive.streams().iter().map(StreamCodes::id).collect();
        let provenance = Provenance::of_source(serde_json::json!({
            "name": format!("continuous record {}", opts.archive.display()),
            "archive": opts.archive,
            "streams": streams,
            "start": format_epoch_ns(plan.grid.start_ns),
            "end": format_epoch_ns(plan.grid.end_ns),
        }))
        .then_step(
            "units_to_si",
            serde_json::json!({
                "applied": cal.units() != "counts",
                "source": opts.stationxml,
                // At the run's start (null when no epoch holds it); later
                // windows use their own epoch (`track::response`).
                "si_per_count": cal.at(archive.streams(), plan.grid.start_ns).ok().map(|c| streams.iter().zip(&c.scale).map(|(id, k)| (id.clone(), *k)).collect::<std::collections::BTreeMap<_, _>>()),
            }),
        )
        .then_step(
            "track",
            serde_json::json!({
                "window_s": length as f64 / 1e9,
                "step_s": plan.grid.step_ns as f64 / 1e9,
                "min_present": opts.min_present,
                "stationxml": opts.stationxml,
                "units": cal.units(),
                "modal_settings": settings,
                "tracking": TrackSettings::default(),
                "band": band_settings,
                "reference": tracking.reference.source,
                "control_chart": chart_settings,
                "temperature": tracking.compensation.source,
            }),
        );
        let summary_files = vec![
            opts.out.join(TABLE_FILE),
            opts.out.join(CHART_FILE),
            opts.out.join(REPORT_FILE),
        ];
        let out = opts.out.clone();
        crate::pipeline::run_one_shot(
            &out,
            "track",
            &opts.archive,
            &[TABLE_FILE, CHART_FILE, REPORT_FILE],
            || {
                write_table(&out.join(TABLE_FILE), &tracking, cal.units(), &provenance)?;
                write_parquet(
                    &out.join(CHART_FILE),
                    &[chart_batch(&tracking.compensation)?],
                    &chart_metadata(&tracking.compensation, &provenance),
                )?;
                let html = crate::report::tracking::page(&tracking, cal.units(), &streams);
                crate::sinks::atomic::write_bytes_atomically(
                    &out.join(REPORT_FILE),
                    html.as_bytes(),
                )
            },
        )?;
        let summary = summarise(
            opts,
            &plan.grid,
            &tracking,
            streams,
            cal.units().to_string(),
            summary_files,
            clock,
        );
        Ok((summary, tracking))
    }
}

/// Runs `quaketwin track` (module doc) in this process.
pub fn run(opts: &TrackOptions) -> Result<(TrackSummary, Tracking)> {
    let clock = std::time::Instant::now();
    let prepared = prepare(opts)?;
    let windows = prepared.identify(&prepared.starts(), true);
    prepared.finish(windows, clock)
}

fn summarise(
    opts: &TrackOptions,
    grid: &WindowGrid,
    t: &Tracking,
    streams: Vec<String>,
    units: String,
    files: Vec<PathBuf>,
    clock: std::time::Instant,
) -> TrackSummary {
    let training_end = t.band_settings.training_end_ns;
    let modes = (1..=t.reference.modes.len())
        .map(|id| {
            let after: Vec<(&TrackedMode, &anomaly::Band)> = t
                .rows
                .iter()
                .zip(&t.bands)
                .filter(|(r, _)| r.mode_id == id && t.windows[r.window].start_ns >= training_end)
                .filter_map(|(r, b)| b.as_ref().map(|b| (r, b)))
                .filter(|(_, b)| b.flagged)
                .collect();
            let deviations: Vec<f64> = after
                .iter()
                .map(|(r, b)| 100.0 * (r.frequency_hz - b.predicted_hz) / b.predicted_hz)
                .collect();
            let m = &t.reference.modes[id - 1];
            ModeSummary {
                mode: id,
                direction: m.direction.clone(),
                reference_frequency_hz: m.frequency_hz,
                windows: t.rows.iter().filter(|r| r.mode_id == id).count(),
                band: t.models[id - 1].clone(),
                flagged_windows: after.len(),
                mean_flagged_deviation_percent: (!deviations.is_empty())
                    .then(|| deviations.iter().sum::<f64>() / deviations.len() as f64),
                first_flagged: after
                    .first()
                    .map(|(r, _)| format_epoch_ns(t.windows[r.window].start_ns)),
            }
        })
        .collect();
    TrackSummary {
        ok: true,
        error: None,
        archive: opts.archive.clone(),
        out: opts.out.clone(),
        streams,
        units,
        start: format_epoch_ns(grid.start_ns),
        end: format_epoch_ns(grid.end_ns),
        window_s: grid.length_ns as f64 / 1e9,
        step_s: grid.step_ns as f64 / 1e9,
        windows: t.windows.len(),
        identified_windows: t.windows.iter().filter(|w| !w.modes.is_empty()).count(),
        skipped: t
            .windows
            .iter()
            .filter_map(|w| {
                w.skipped
                    .as_ref()
                    .map(|s| (format_epoch_ns(w.start_ns), s.clone()))
            })
            .collect(),
        reference: t.reference.source.clone(),
        modes,
        training_end: format_epoch_ns(training_end),
        anomaly_from: t
            .anomaly_from
            .map(|i| format_epoch_ns(t.windows[i].start_ns)),
        anomalous_windows: t
            .windows
            .iter()
            .zip(&t.anomalous)
            .filter(|(w, a)| **a && w.start_ns >= training_end)
            .count(),
        compensation: t.compensation.model.clone(),
        control_alarm_from: t
            .compensation
            .alarm_from
            .map(|g| format_epoch_ns(t.compensation.subgroups[g].start_ns)),
        out_of_control_subgroups: t
            .compensation
            .subgroups
            .iter()
            .filter(|g| g.out_of_control == Some(true))
            .count(),
        seconds: clock.elapsed().as_secs_f64(),
        files,
    }
}

/// The rows of `modal_tracking.parquet` as one record batch.
pub fn tracking_batch(t: &Tracking) -> Result<arrow_array::RecordBatch> {
    let w = |r: &TrackedMode| &t.windows[r.window];
    let band = |f: fn(&anomaly::Band) -> f64| -> Vec<Option<f64>> {
        t.bands.iter().map(|b| b.as_ref().map(f)).collect()
    };
    let rows = &t.rows;
    let change = |f: fn(&ChangeTestResult) -> f64| -> Vec<Option<f64>> {
        rows.iter()
            .map(|r| t.change_tests[r.window].as_ref().map(f))
            .collect()
    };
    TableBuilder::new(&MODAL_TRACKING)
        .timestamp_ns(
            col::WINDOW_START.name,
            rows.iter().map(|r| w(r).start_ns).collect(),
        )
        .timestamp_ns(
            col::WINDOW_END.name,
            rows.iter().map(|r| w(r).end_ns).collect(),
        )
        .u32(
            col::MODE.name,
            rows.iter().map(|r| r.mode_id as u32).collect(),
        )
        .str(
            col::DIRECTION.name,
            &rows
                .iter()
                .map(|r| r.direction.as_str())
                .collect::<Vec<_>>(),
        )
        .f64(
            col::FREQUENCY_HZ.name,
            rows.iter().map(|r| r.frequency_hz).collect(),
        )
        .f64(
            col::FREQUENCY_STD_HZ.name,
            rows.iter().map(|r| r.frequency_std_hz).collect(),
        )
        .f64(
            col::DAMPING_RATIO.name,
            rows.iter().map(|r| r.damping_ratio).collect(),
        )
        .opt_f64(
            col::MAC_TO_REFERENCE.name,
            rows.iter()
                .map(|r| r.mac.is_finite().then_some(r.mac))
                .collect(),
        )
        .f64(
            col::REFERENCE_FREQUENCY_HZ.name,
            rows.iter()
                .map(|r| t.reference.modes[r.mode_id - 1].frequency_hz)
                .collect(),
        )
        .f64(col::MPC.name, rows.iter().map(|r| r.mpc).collect())
        .u32(
            col::POLE_COUNT.name,
            rows.iter().map(|r| r.pole_count as u32).collect(),
        )
        .f64(
            col::PRESENT_FRACTION.name,
            rows.iter().map(|r| w(r).present_fraction).collect(),
        )
        .f64(col::RMS_LEVEL.name, rows.iter().map(|r| w(r).rms).collect())
        .bool(
            col::TRAINING.name,
            rows.iter()
                .map(|r| w(r).start_ns < t.band_settings.training_end_ns)
                .collect(),
        )
        .opt_f64(col::PREDICTED_FREQUENCY_HZ.name, band(|b| b.predicted_hz))
        .opt_f64(col::BAND_LOW_HZ.name, band(|b| b.low_hz))
        .opt_f64(col::BAND_HIGH_HZ.name, band(|b| b.high_hz))
        .opt_f64(
            col::DEVIATION_PERCENT.name,
            rows.iter()
                .zip(&t.bands)
                .map(|(r, b)| {
                    b.as_ref()
                        .map(|b| 100.0 * (r.frequency_hz - b.predicted_hz) / b.predicted_hz)
                })
                .collect(),
        )
        .opt_bool(
            col::FLAGGED.name,
            t.bands
                .iter()
                .map(|b| b.as_ref().map(|b| b.flagged))
                .collect(),
        )
        .bool(
            col::ANOMALOUS_WINDOW.name,
            rows.iter().map(|r| t.anomalous[r.window]).collect(),
        )
        .opt_f64(col::CHANGE_STATISTIC.name, change(|c| c.statistic))
        .opt_f64(col::CHANGE_THRESHOLD.name, change(|c| c.threshold))
        .opt_f64(col::CHANGE_P_VALUE.name, change(|c| c.p_value))
        .opt_i32(
            col::CHANGE_DOF.name,
            rows.iter()
                .map(|r| t.change_tests[r.window].as_ref().map(|c| c.dof as i32))
                .collect(),
        )
        .opt_bool(
            col::CHANGE_DETECTED.name,
            rows.iter()
                .map(|r| t.change_tests[r.window].as_ref().map(|c| c.changed))
                .collect(),
        )
        .opt_f64(
            col::ENVIRONMENT_VALUE.name,
            rows.iter()
                .map(|r| t.compensation.environment.get(r.window).copied().flatten())
                .collect(),
        )
        .opt_f64(
            col::COMPENSATED_RESIDUAL.name,
            (0..rows.len())
                .map(|k| t.compensation.residuals.get(k).copied().flatten())
                .collect(),
        )
        .opt_bool(
            col::RESIDUAL_FLAGGED.name,
            (0..rows.len())
                .map(|k| t.compensation.residual_flagged.get(k).copied().flatten())
                .collect(),
        )
        .build()
}

/// Table metadata of `modal_tracking.parquet`: provenance, units, the
/// reference, the band models, the skipped windows and the anomaly.
pub fn tracking_metadata(
    t: &Tracking,
    units: &str,
    provenance: &Provenance,
) -> Vec<(String, String)> {
    let mut m = provenance.metadata();
    let json = |v: serde_json::Value| v.to_string();
    m.extend([
        ("quaketwin.units".to_string(), units.to_string()),
        (
            "quaketwin.reference".into(),
            json(serde_json::json!({
                "source": t.reference.source,
                "channels": t.reference.channels,
                "frequencies_hz": t.reference.modes.iter().map(|m| m.frequency_hz).collect::<Vec<_>>(),
                "directions": t.reference.modes.iter().map(|m| m.direction.clone()).collect::<Vec<_>>(),
            })),
        ),
        (
            "quaketwin.band_models".into(),
            serde_json::to_string(&t.models).unwrap_or_default(),
        ),
        (
            "quaketwin.skipped_windows".into(),
            json(serde_json::Value::Array(
                t.windows
                    .iter()
                    .filter_map(|w| {
                        w.skipped.as_ref().map(|s| {
                            serde_json::json!({"window_start": format_epoch_ns(w.start_ns), "reason": s})
                        })
                    })
                    .collect(),
            )),
        ),
        (
            "quaketwin.window_notes".into(),
            json(serde_json::Value::Array(
                t.windows
                    .iter()
                    .flat_map(|w| {
                        w.notes.iter().map(|n| {
                            serde_json::json!({"window_start": format_epoch_ns(w.start_ns), "note": n})
                        })
                    })
                    .collect(),
            )),
        ),
        (
            "quaketwin.anomaly_from".into(),
            json(serde_json::json!(t
                .anomaly_from
                .map(|i| format_epoch_ns(t.windows[i].start_ns)))),
        ),
    ]);
    m
}

fn write_table(path: &Path, t: &Tracking, units: &str, provenance: &Provenance) -> Result<()> {
    write_parquet(
        path,
        &[tracking_batch(t)?],
        &tracking_metadata(t, units, provenance),
    )
}

/// The options as JSON (the field names of [`TrackOptions`]; unset fields
/// take the command's defaults): how the Python package hands them over.
pub fn options_from_json(text: &str) -> Result<TrackOptions> {
    serde_json::from_str(text).map_err(|e| Error::usage(format!("track options: {e}")))
}

/// Identifies the windows starting at `starts` (ns, a share of
/// [`Prepared::starts`]) and returns them as JSON
/// ([`crate::monitor::windows_to_json`]): one task of a cluster.
pub fn identify_windows_json(opts: &TrackOptions, starts: &[i64]) -> Result<String> {
    let most = crate::monitor::window::MAX_WINDOWS;
    if starts.len() as i64 > most {
        return Err(Error::usage(format!(
            "track: {} window starts given, at most {most}",
            starts.len()
        )));
    }
    let prepared = prepare(opts)?;
    crate::monitor::windows_to_json(&prepared.identify(starts, false))
}

/// Finishes a run from windows identified elsewhere (the JSON parts of
/// [`identify_windows_json`], in any order; sorted by start here): tracks,
/// fits the bands, writes the outputs.
pub fn finish_from_json(opts: &TrackOptions, parts: &[String]) -> Result<TrackSummary> {
    let clock = std::time::Instant::now();
    let prepared = prepare(opts)?;
    let mut windows = Vec::new();
    for p in parts {
        windows.extend(crate::monitor::windows_from_json(p)?);
    }
    windows.sort_by_key(|w| w.start_ns);
    let expected = prepared.starts();
    if windows
        .iter()
        .map(|w| w.start_ns)
        .ne(expected.iter().copied())
    {
        return Err(Error::usage(format!(
            "track: {} windows handed over, the run has {}: every window exactly once",
            windows.len(),
            expected.len()
        )));
    }
    prepared.finish(windows, clock).map(|(s, _)| s)
}
