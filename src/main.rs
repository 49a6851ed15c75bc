//! The `quaketwin` command: a thin clap front end over the library.
//! Exit codes: 0 success, 1 bad input or failed processing, 2 usage error.
//! Standard output carries results (`--json` summaries, `inspect`'s table);
//! standard error carries progress, warnings and errors.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use quaketwin::commands;
use quaketwin::console::{self, Verbosity};
use quaketwin::error::Result;
use quaketwin::summary::{to_json, RunSummary};

/// mimalloc, told never to return freed memory to the kernel
/// ([`keep_freed_memory`]), reuses what a channel's work freed for the next
/// channel; glibc's malloc returns channel-sized blocks to the kernel and
/// takes fresh pages, which the kernel zeroes, for the next one.  An hour of
/// 64 channels: 1.29 M page faults → 17 k, ≈ 3 s of system time fewer, peak
/// memory 974 → 1 017 MB (the peak is what is live at once; freed memory is
/// reused, not added to).
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// `mi_option_purge_delay` (the 16th option of mimalloc v3's `mi_option_t`,
/// which libmimalloc-sys names no constant for): the delay before freed
/// memory goes back to the kernel, −1 for never.
const MI_OPTION_PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

fn keep_freed_memory() {
    // SAFETY: sets an option value; mimalloc reads options at each purge.
    unsafe { libmimalloc_sys::mi_option_set(MI_OPTION_PURGE_DELAY, -1) }
}

#[derive(Parser)]
#[command(
    name = "quaketwin",
    version,
    about = "From a building's earthquake records to damage decisions",
    after_help = "Examples:
  quaketwin inspect sample-records/synthetic-4storey-quake
  quaketwin run pipelines/post-earthquake.toml sample-records/synthetic-4storey-quake --out out/quake
  quaketwin run pipelines/post-earthquake.toml sample-records --out out/network --json

Documentation: docs/cli.md (commands), docs/pipelines.md, docs/formats.md."
)]
struct Cli {
    /// Only warnings and errors on stderr: no progress bars, no stage lines.
    #[arg(long, short, global = true, conflicts_with = "verbose")]
    quiet: bool,
    /// More on stderr: each stage's start, time and files.
    #[arg(long, short, global = true)]
    verbose: bool,
    /// Print a machine-readable summary (JSON) on stdout when the command
    /// ends, also when a run fails (`"ok": false`); see docs/cli.md.
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List the channels of an event folder (or zip): what was read, inferred, missing.
    #[command(after_help = "Examples:
  quaketwin inspect sample-records/synthetic-4storey-quake
  quaketwin inspect event.zip --json | jq '.channels[].id'")]
    Inspect {
        /// Event folder or zip.
        event: PathBuf,
    },
    /// Write the event.toml of what the headers say: event, structure,
    /// one [[channel]] per channel, the unknowns as commented fields.
    #[command(after_help = "Examples:
  quaketwin init building.zip
  quaketwin init building.zip -o building-event.toml")]
    Init {
        /// Event folder or zip.
        event: PathBuf,
        /// Write to FILE (atomically) instead of standard output; never inside the event.
        #[arg(short = 'o', long = "out", value_name = "FILE")]
        out: Option<PathBuf>,
        /// Replace FILE when it exists.
        #[arg(long)]
        force: bool,
    },
    /// Read an event folder, condition it and compute strong-motion metrics
    /// (channels.parquet, samples.parquet, spectra.parquet, drift.parquet).
    #[command(after_help = "Examples:
  quaketwin ingest sample-records/synthetic-4storey-quake --out out/quake
  quaketwin ingest sample-records/synthetic-4storey-quake --out out/quake --mcap out/quake/event.mcap")]
    Ingest {
        /// Event folder or zip.
        event: PathBuf,
        /// Output directory (created; holds the results of this event only).
        #[arg(long)]
        out: PathBuf,
        /// Also write the conditioned event as MCAP (replay, Foxglove).
        #[arg(long, value_name = "FILE")]
        mcap: Option<PathBuf>,
    },
    /// Update a digital twin against measured modes (ensemble + Plackett–Luce).
    #[command(after_help = "Examples:
  quaketwin update sample-records/synthetic-4storey-quake/twin.toml --modes out/quake/modes.parquet --out out/update
  quaketwin update twin.toml --modes out/quake --out out/update --settings update.toml --json")]
    Update {
        /// Twin file (TOML, docs/twin.md).
        twin: PathBuf,
        /// modes.parquet from the modal stage (or the output directory holding it).
        #[arg(long, value_name = "FILE_OR_DIR")]
        modes: PathBuf,
        /// Output directory for twin_update.parquet, twin_modes.parquet, twin_updated.toml.
        #[arg(long)]
        out: PathBuf,
        /// Update settings (TOML: solvers, seed, max_rounds, tolerance, selection…).
        #[arg(long, value_name = "FILE")]
        settings: Option<PathBuf>,
    },
    /// The digital twin on its own: its matrices for other solvers, its modes, a benchmark model.
    #[command(subcommand)]
    Twin(TwinCommand),
    /// Write DIR/report.html from the outputs of a pipeline run in DIR.
    #[command(after_help = "Examples:
  quaketwin report out/quake
  quaketwin report out/quake --settings report.toml")]
    Report {
        /// Output directory of a run.
        dir: PathBuf,
        /// Report settings (TOML: rating thresholds…), see docs/report.md.
        #[arg(long, value_name = "FILE")]
        settings: Option<PathBuf>,
    },
    /// Subspace modal identification (writes modes.parquet, stabilization.parquet…).
    #[command(after_help = "Examples:
  quaketwin modal sample-records/synthetic-4storey-ambient --out out/ambient
  quaketwin modal EVENT --out out/m --method ssi-cov --band 0.5,15 --orders 2,40
  quaketwin modal EVENT_AFTER --out out/after --reference out/before --json")]
    Modal {
        /// Event folder or zip.
        event: PathBuf,
        /// Output directory (created; holds the results of this event only).
        #[arg(long)]
        out: PathBuf,
        /// auto (input–output when base channels exist), ssi-cov, ssi-data or io.
        #[arg(long, default_value = "auto")]
        method: String,
        /// Band of interest LO,HI in Hz (default: from the structure, else 0.2,20).
        #[arg(long, value_name = "LO,HI")]
        band: Option<String>,
        /// Decimation factor (default: automatic, ≈ 4 × the band's top).
        #[arg(long, value_name = "N")]
        decimate: Option<String>,
        /// Block rows (default: automatic).
        #[arg(long, value_name = "N")]
        block_rows: Option<String>,
        /// Model orders MIN,MAX[,STEP] (default: 2 to what the data support).
        #[arg(long, value_name = "MIN,MAX[,STEP]")]
        orders: Option<String>,
        /// Input channel ids ID,ID,… for io (default: horizontal base channels).
        #[arg(long, value_name = "ID,…")]
        inputs: Option<String>,
        /// An earlier run of the same structure (its output directory, or its
        /// modes.parquet): pair the modes and write frequency_shifts.parquet.
        #[arg(long, value_name = "DIR_OR_FILE")]
        reference: Option<PathBuf>,
    },
    /// Bouc-Wen identification and damage index (bouc_wen.parquet, damage.parquet…).
    #[command(after_help = "Examples:
  quaketwin hysteresis sample-records/synthetic-2storey-yielding --out out/yielding
  quaketwin hysteresis EVENT --out out/h --json | jq '.bouc_wen'")]
    Hysteresis {
        /// Event folder or zip.
        event: PathBuf,
        /// Output directory (created; holds the results of this event only).
        #[arg(long)]
        out: PathBuf,
    },
    /// Hybrid-test design from recorded response: actuator layout (POD), Guyan + rigid-body
    /// reduction, Craig–Bampton prototype (docs/test-design.md).
    #[command(after_help = "Examples:
  quaketwin design sample-records/synthetic-facade/design.toml --out out/design
  quaketwin design design.toml --out out/design --json | jq '.time_scale'")]
    Design {
        /// Design file (TOML: twin, PS node set, base motion, settings).
        design: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Rehearse the hybrid test of a design run before the specimen is loaded: virtual test
    /// with actuator lag, delay and noise, swept over time scales λ (docs/test-design.md).
    #[command(after_help = "Examples:
  quaketwin rehearse out/design --out out/rehearsal
  quaketwin rehearse out/design --out out/r --scheme central-difference --time-scales 100,200,500 --json")]
    Rehearse {
        /// Output directory of a design run (holds rehearsal_model.json).
        design_out: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Rehearsal settings (TOML, the `rehearse` stage's params).
        #[arg(long, value_name = "FILE")]
        settings: Option<PathBuf>,
        /// Integration scheme: alpha-os or central-difference (overrides the settings).
        #[arg(long)]
        scheme: Option<String>,
        /// Time scales λ to sweep, comma-separated (overrides the settings).
        #[arg(long, value_delimiter = ',', value_name = "L1,L2,…")]
        time_scales: Option<Vec<f64>>,
    },
    /// Compare a pseudo-dynamic or real-time hybrid test's log with the rehearsal of its design
    /// and with the twin: tracking error, identified actuator lag and noise, energy error,
    /// response; then update the specimen and actuator models from the log and re-run the
    /// rehearsal (docs/lab-tests.md).
    #[command(after_help = "Examples:
  quaketwin compare-test out/design lab/hybrid_log.csv --out out/compare
  quaketwin synth-hybrid-log out/design --out out/log --duration 2 --substeps 20
  quaketwin compare-test out/design out/log --out out/compare --json")]
    CompareTest {
        /// Output directory of a design run (holds rehearsal_model.json).
        design_out: PathBuf,
        /// The test's log: a CSV file, or a folder holding hybrid_log.csv (format: docs/lab-tests.md).
        test_records: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Rehearsal settings (TOML, the `rehearse` stage's params; default: the design run's).
        #[arg(long, value_name = "FILE")]
        settings: Option<PathBuf>,
        /// Time scale λ of a log without a lab_time_s column.
        #[arg(long, value_name = "LAMBDA")]
        time_scale: Option<f64>,
        /// Longest actuator lag searched (s, laboratory time).
        #[arg(long, default_value_t = 1.0, value_name = "SECONDS")]
        max_lag: f64,
        /// Skip the specimen update and the updated rehearsal.
        #[arg(long)]
        no_update: bool,
    },
    /// Generate a synthetic hybrid-test log of a design run: its rehearsal with a known
    /// actuator (servo, delay, noise; seeded) logged at every step, with truth.json.
    #[command(after_help = "Examples:
  quaketwin synth-hybrid-log out/design --out out/log
  quaketwin synth-hybrid-log out/design --out out/log --duration 2 --substeps 20 --delay 0.008 --noise 2e-8 --seed 7")]
    SynthHybridLog {
        /// Output directory of a design run (holds rehearsal_model.json).
        design_out: PathBuf,
        /// Directory to write hybrid_log.csv and truth.json into.
        #[arg(long)]
        out: PathBuf,
        /// The emulated test's settings (TOML, the `rehearse` stage's params: servo, bouc_wen, …); the flags below override it.
        #[arg(long, value_name = "FILE")]
        settings: Option<PathBuf>,
        /// Time scale λ (default: the design's).
        #[arg(long, value_name = "LAMBDA")]
        time_scale: Option<f64>,
        /// Integration steps per motion step (default: the rehearsal's automatic choice).
        #[arg(long, value_name = "N")]
        substeps: Option<usize>,
        /// Simulation time logged (s; default: the design's whole motion).
        #[arg(long, value_name = "SECONDS")]
        duration: Option<f64>,
        /// Pure delay of the actuators (s, laboratory time).
        #[arg(long, value_name = "SECONDS")]
        delay: Option<f64>,
        /// Servo bandwidth (Hz; default: the design's actuator band).
        #[arg(long, value_name = "HZ")]
        bandwidth: Option<f64>,
        /// Standard deviation of the displacement measurement noise (m).
        #[arg(long, value_name = "METRES")]
        noise: Option<f64>,
        /// Standard deviation of the load-cell noise (N).
        #[arg(long, value_name = "NEWTONS")]
        force_noise: Option<f64>,
        /// Seed of the noise.
        #[arg(long)]
        seed: Option<u64>,
    },
    /// Generate the synthetic sample events (known model, with truth files).
    #[command(after_help = "Examples:
  quaketwin synth
  quaketwin synth --out /tmp/samples --seed 7")]
    Synth {
        /// Directory to write the event folders into.
        #[arg(long, default_value = "sample-records")]
        out: PathBuf,
        /// Random seed (same seed, same files).
        #[arg(long, default_value_t = 2026)]
        seed: u64,
    },
    /// Continuous monitoring from an SDS MiniSEED archive: ambient modal
    /// identification per window, mode tracking, anomaly band
    /// (modal_tracking.parquet, tracking.html; docs/monitoring.md).
    #[command(after_help = "Examples:
  quaketwin synth-archive --out /tmp/arch --days 3
  quaketwin track /tmp/arch/sds --stationxml /tmp/arch/station.xml --out out/track
  quaketwin track ARCHIVE --start 2026-01-01T00:00:00Z --end 2026-01-04T00:00:00Z --channels 'QT.BLD.*.HN?' --window 1h --training 24h --out out/track --json")]
    Track {
        /// Root of the SDS archive (YEAR/NET/STA/CHAN.D/NET.STA.LOC.CHAN.D.YEAR.DAY).
        archive: PathBuf,
        /// Output directory (created; holds the results of this run only).
        #[arg(long)]
        out: PathBuf,
        /// First window start, UTC (default: the start of the archive's first day).
        #[arg(long, value_name = "TIME")]
        start: Option<String>,
        /// End of the span, UTC (default: the end of the archive's last day).
        #[arg(long, value_name = "TIME")]
        end: Option<String>,
        /// Streams NET.STA.LOC.CHAN (wildcards * and ?), comma-separated (default: all).
        #[arg(long, value_delimiter = ',', value_name = "PATTERN,…")]
        channels: Vec<String>,
        /// StationXML with the streams' gains and orientations (without it: counts, no directions).
        #[arg(long, value_name = "FILE")]
        stationxml: Option<PathBuf>,
        /// Window length (s, m, h, d).
        #[arg(long, default_value = "1h")]
        window: String,
        /// Step between window starts (default: the window length).
        #[arg(long)]
        step: Option<String>,
        /// Training period of the anomaly band, from the first window.
        #[arg(long, default_value = "24h")]
        training: String,
        /// Reference modes (a modes.parquet or the directory holding it;
        /// default: the modes confirmed in the first six identified windows).
        #[arg(long, value_name = "FILE_OR_DIR")]
        reference: Option<PathBuf>,
        /// Skip windows with a smaller share of recorded samples.
        #[arg(long, default_value_t = 0.9, value_name = "FRACTION")]
        min_present: f64,
        /// Period of the environmental cycle in the band's regression
        /// (and the length of the control chart's subgroups).
        #[arg(long, default_value = "24h")]
        cycle: String,
        /// Measured temperature for the environmental compensation: a CSV
        /// of time (ISO-8601 UTC or epoch seconds), value (default: the
        /// latent model, nothing measured).
        #[arg(long, value_name = "FILE")]
        temperature: Option<PathBuf>,
        /// Measured temperature: a stream of the archive NET.STA.LOC.CHAN
        /// (not identified with the accelerometers).
        #[arg(long, value_name = "ID")]
        temperature_channel: Option<String>,
    },
    /// Structure history over a many-event dataset: each structure's modes
    /// followed across its events, frequency against intensity with an
    /// amplitude-dependence band, events outside it, permanent shifts, and
    /// event-to-event prediction (history_modes.parquet,
    /// history_events.parquet, history.html; docs/history.md).
    #[command(after_help = "Examples:
  quaketwin run pipelines/post-earthquake.toml EV1.zip EV2.zip EV3.zip --out dataset
  quaketwin history dataset --out dataset-history
  quaketwin history dataset --structure CE.89324 --out out/painter --json")]
    History {
        /// The dataset: the output directory of `quaketwin run PIPELINE EV1 EV2 … --out DIR` (or of the fleet).
        dataset: PathBuf,
        /// Only this structure: its partition name, or NETWORK.STATION for events without a named structure.
        #[arg(long, value_name = "ID")]
        structure: Option<String>,
        /// Output directory (created; holds the results of this run only).
        #[arg(long)]
        out: PathBuf,
        /// Intensity of the amplitude dependence: peak `response` (roof, deck) or `base` acceleration.
        #[arg(long, default_value = "response", value_name = "response|base")]
        intensity: String,
        /// Skip the event-to-event prediction (it reads every event's samples).
        #[arg(long)]
        no_prediction: bool,
    },
    /// Generate a synthetic SDS archive of the 4-storey building under ambient
    /// excitation (daily temperature cycle, a 2 % stiffness drop on day 2),
    /// with StationXML and the true frequencies (truth.csv).
    #[command(after_help = "Examples:
  quaketwin synth-archive --out /tmp/arch --days 3 --channels 8 --rate 100 --seed 1")]
    SynthArchive {
        /// Directory to write sds/, station.xml and truth.csv into.
        #[arg(long)]
        out: PathBuf,
        /// Days of record.
        #[arg(long, default_value_t = 3)]
        days: usize,
        /// Channels: 2, 4, 6 or 8 (two per floor, top floors first).
        #[arg(long, default_value_t = 8)]
        channels: usize,
        /// Sampling rate, Hz.
        #[arg(long, default_value_t = 100.0)]
        rate: f64,
        /// Random seed (same seed, same files).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Length of a simulated day (shortened archives for tests; damage at the start of day 2).
        #[arg(long, default_value = "24h", value_name = "DURATION")]
        day_length: String,
        /// Day (1-based) from whose start the 2 % stiffness drop acts; 0 = no damage.
        #[arg(long, default_value_t = 2, value_name = "DAY")]
        damage_day: usize,
    },
    /// Run a pipeline on many events over a Dask cluster into a table-first
    /// dataset on any fsspec file system (the Python package's
    /// quaketwin.fleet; docs/python.md).
    #[command(after_help = "Examples:
  quaketwin fleet pipelines/post-earthquake.toml sample-records --out out/fleet
  quaketwin fleet pipelines/post-earthquake.toml s3://bucket/events/ev1.zip --out s3://bucket/dataset --scheduler tcp://scheduler:8786")]
    Fleet {
        /// Pipeline file (pipelines/*.toml).
        pipeline: PathBuf,
        /// Event folders, zips or fsspec URLs; a folder of event folders expands.
        #[arg(required = true)]
        events: Vec<String>,
        /// Dataset root: a path or an fsspec URL.
        #[arg(long)]
        out: String,
        /// Address of a running Dask scheduler (default: a local cluster).
        #[arg(long, value_name = "ADDRESS")]
        scheduler: Option<String>,
    },
    /// Unattended intake: process each event folder or zip that lands in
    /// INBOX once its upload is complete, add it to the dataset, notify,
    /// refresh the dashboard (docs/monitoring-network.md).
    #[command(after_help = "Examples:
  quaketwin watch /srv/inbox --pipeline pipelines/post-earthquake.toml --out /srv/dataset --notify http://alerts.local:8080/quake
  quaketwin watch inbox --pipeline pipelines/ingest.toml --out dataset --notify 'cmd:sendmail ops@example.org' --require-done
  quaketwin watch inbox --pipeline pipelines/ingest.toml --out dataset --once --settle 2 --json")]
    Watch {
        /// Folder watched: every folder or .zip directly inside it is an event (only read, never modified).
        inbox: PathBuf,
        /// Pipeline file run on each event.
        #[arg(long)]
        pipeline: PathBuf,
        /// Dataset the events are added to (its state in DATASET/_watch/).
        #[arg(long)]
        out: PathBuf,
        /// Where a notification goes: http://HOST[:PORT]/PATH (POST of the JSON) or cmd:COMMAND (JSON on stdin); repeatable.
        #[arg(long, value_name = "URL|cmd:COMMAND")]
        notify: Vec<String>,
        /// Seconds between two looks at the inbox.
        #[arg(long, default_value_t = quaketwin::watch::flags::DEFAULT_POLL_S, value_name = "SECONDS")]
        poll: f64,
        /// Seconds an entry must rest unchanged to be complete (without a .done marker).
        #[arg(long, default_value_t = quaketwin::watch::flags::DEFAULT_SETTLE_S, value_name = "SECONDS")]
        settle: f64,
        /// Only a marker (NAME.done beside the entry, or NAME/.done inside a folder) completes an entry.
        #[arg(long)]
        require_done: bool,
        /// Process what is complete, deliver the notifications, and exit.
        #[arg(long)]
        once: bool,
        /// Folder of the dashboard (default DATASET/dashboard).
        #[arg(long, value_name = "DIR", conflicts_with = "no_dashboard")]
        dashboard: Option<PathBuf>,
        /// Do not write the dashboard.
        #[arg(long)]
        no_dashboard: bool,
        /// Attempts to deliver a notification before it goes to DATASET/_watch/dead_letter/.
        #[arg(long, default_value_t = quaketwin::watch::flags::DEFAULT_NOTIFY_ATTEMPTS, value_name = "N")]
        notify_attempts: u32,
        /// Seconds before the first retry (doubled after each failure).
        #[arg(long, default_value_t = quaketwin::watch::flags::DEFAULT_NOTIFY_BACKOFF_S, value_name = "SECONDS")]
        notify_backoff: f64,
        /// Longest wait between two attempts, seconds.
        #[arg(long, default_value_t = quaketwin::watch::flags::DEFAULT_NOTIFY_MAX_DELAY_S, value_name = "SECONDS")]
        notify_max_delay: f64,
        /// Seconds one delivery may take (HTTP request, or the command, then killed).
        #[arg(long, default_value_t = quaketwin::watch::flags::DEFAULT_NOTIFY_TIMEOUT_S, value_name = "SECONDS")]
        notify_timeout: f64,
    },
    /// The fleet as a static site: structures by inspection priority, a map,
    /// per structure its events and reports (docs/monitoring-network.md).
    #[command(after_help = "Examples:
  quaketwin dashboard out/network --out out/site
  quaketwin dashboard /srv/dataset --out /var/www/quakes --json")]
    Dashboard {
        /// Dataset (quaketwin run … --out DIR, quaketwin watch … --out DIR, quaketwin fleet).
        dataset: PathBuf,
        /// Folder of the site (index.html, structures/, reports/, site.json).
        #[arg(long)]
        out: PathBuf,
    },
    /// Run a pipeline file on an event folder; several events (or a folder of
    /// event folders) run in parallel into a table-first Hive dataset:
    /// DIR/tables/<table>/structure=…/event=…/part-0.parquet, each event's run
    /// (run.json, event.json, report.html) in DIR/runs/structure=…/event=…/.
    #[command(after_help = "Examples:
  quaketwin run pipelines/post-earthquake.toml sample-records/synthetic-4storey-quake --out out/quake
  quaketwin run pipelines/post-earthquake.toml EVENT_AFTER --out out/after --reference out/before
  quaketwin run pipelines/post-earthquake.toml sample-records --out out/network --json")]
    Run {
        /// Pipeline file (pipelines/*.toml).
        pipeline: PathBuf,
        /// Event folder(s) or zip(s), or one folder of event folders.
        #[arg(required = true)]
        event: Vec<PathBuf>,
        /// Output directory (one event: its results; several: the dataset).
        #[arg(long)]
        out: PathBuf,
        /// An earlier run of the same structure (its output directory, holding
        /// modes.parquet): every modal stage pairs its modes with it and writes
        /// frequency_shifts.parquet.
        #[arg(long, value_name = "DIR")]
        reference: Option<PathBuf>,
    },
}

#[derive(Subcommand)]
enum TwinCommand {
    /// Write the stiffness and mass matrices (free DoFs, start parameters) as Matrix Market.
    #[command(after_help = "Examples:
  quaketwin twin export sample-records/synthetic-4storey-quake/twin.toml --out out/twin
  python3 scripts/eigsh_compare.py   # scipy eigsh on the exported benchmark plate")]
    Export {
        /// Twin file (TOML, docs/twin.md).
        twin: PathBuf,
        /// Output directory (stiffness.mtx, mass.mtx).
        #[arg(long)]
        out: PathBuf,
    },
    /// The lowest modes of the twin at its start parameters, and the solve time.
    #[command(after_help = "Examples:
  quaketwin twin modes sample-records/synthetic-4storey-quake/twin.toml --count 4 --json")]
    Modes {
        /// Twin file (TOML, docs/twin.md).
        twin: PathBuf,
        /// Number of modes.
        #[arg(long, default_value_t = 10)]
        count: usize,
    },
    /// Write the benchmark twin: a clamped concrete shell plate of NX × NY elements.
    #[command(after_help = "Examples:
  quaketwin twin plate --nx 162 --ny 102 --out plate.toml   # 100 116 free DoFs")]
    Plate {
        /// Elements along x.
        #[arg(long)]
        nx: usize,
        /// Elements along y.
        #[arg(long)]
        ny: usize,
        /// Twin file to write.
        #[arg(long)]
        out: PathBuf,
    },
}

/// Prints `value` as JSON on stdout when `--json` was given.
fn print_json<T: serde::Serialize>(json: bool, value: &T) -> Result<()> {
    if json {
        print!("{}", to_json(value)?);
    }
    Ok(())
}

/// A pipeline run's summary on stdout (`--json`), then its result.
fn summarise_run(
    json: bool,
    pipeline: &str,
    event: &Path,
    out: &Path,
    result: Result<Vec<(String, quaketwin::pipeline::StageOutcome)>>,
) -> Result<()> {
    if json {
        print_json(true, &RunSummary::of_run(pipeline, event, out, &result))?;
    }
    result.map(|_| ())
}

fn run_command(cli: &Cli) -> Result<()> {
    let (quiet, json) = (cli.quiet, cli.json);
    match &cli.command {
        Command::Inspect { event } => {
            let text = if json {
                commands::inspect_json(event)?
            } else {
                commands::inspect(event)?
            };
            print!("{text}");
            Ok(())
        }
        Command::Init { event, out, force } => {
            if let Some(text) = commands::init(event, out.as_deref(), *force)? {
                print!("{text}");
            }
            Ok(())
        }
        Command::Ingest { event, out, mcap } => {
            let result = commands::ingest(event, out, mcap.as_deref(), quiet);
            summarise_run(json, "ingest (built-in)", event, out, result)
        }
        Command::Update {
            twin,
            modes,
            out,
            settings,
        } => {
            let s = commands::update(twin, modes, out, settings.as_deref())?;
            console::info(format!(
                "update: {} parameters in {} rounds ({}), objective {:.3e} -> {:.3e}, mean |Δf|/f {:.2} % -> {:.2} %, mean 1−MAC {:.3} -> {:.3}; wrote {}",
                s.parameter_names.len(),
                s.rounds,
                if s.converged { "converged" } else { "not converged" },
                s.objective_initial,
                s.objective_updated,
                100.0 * s.frequency_error_initial,
                100.0 * s.frequency_error_updated,
                s.shape_error_initial,
                s.shape_error_updated,
                out.display()
            ));
            print_json(json, &s)
        }
        Command::Twin(TwinCommand::Export { twin, out }) => {
            let e = commands::twin_export(twin, out)?;
            console::info(format!(
                "twin export: {} free DoFs; wrote {} and {}",
                e.dofs,
                e.stiffness.display(),
                e.mass.display()
            ));
            print_json(json, &e)
        }
        Command::Twin(TwinCommand::Modes { twin, count }) => {
            let m = commands::twin_modes(twin, *count)?;
            if json {
                return print_json(true, &m);
            }
            println!("{} free DoFs, solved in {:.3} s", m.dofs, m.solve_seconds);
            for (i, f) in m.frequencies_hz.iter().enumerate() {
                println!("mode {:>3}  {f:.6} Hz", i + 1);
            }
            Ok(())
        }
        Command::Twin(TwinCommand::Plate { nx, ny, out }) => {
            commands::twin_plate(*nx, *ny, out)?;
            console::info(format!("wrote {}", out.display()));
            print_json(json, &serde_json::json!({ "twin": out }))
        }
        Command::Report { dir, settings } => {
            let path = commands::report(dir, settings.as_deref())?;
            console::info(format!("wrote {}", path.display()));
            print_json(json, &serde_json::json!({ "report": path }))
        }
        Command::Modal {
            event,
            out,
            method,
            band,
            decimate,
            block_rows,
            orders,
            inputs,
            reference,
        } => {
            let flags = commands::ModalFlags {
                method: method.clone(),
                band: band.clone(),
                decimate: decimate.clone(),
                block_rows: block_rows.clone(),
                orders: orders.clone(),
                inputs: inputs.clone(),
                reference: reference.clone(),
            };
            let result = commands::modal(event, out, &flags, quiet);
            summarise_run(json, "modal (built-in)", event, out, result)
        }
        Command::Hysteresis { event, out } => {
            let result = commands::hysteresis(event, out, quiet);
            summarise_run(json, "hysteresis (built-in)", event, out, result)
        }
        Command::Design { design, out } => {
            let s = commands::design(design, out)?;
            console::info(format!(
                "design: {} actuators ({} force-controlled), {} POMs, WNRMSE {:.2e}, {} NS modes, λ = {}, bandwidth {:.3} Hz; wrote {}",
                s.actuators,
                s.force_controlled,
                s.retained_poms,
                s.wnrmse,
                s.ns_modes,
                s.time_scale,
                s.bandwidth_hz,
                out.display()
            ));
            print_json(json, &s)
        }
        Command::Synth { out, seed } => {
            let dirs = commands::synth(out, *seed)?;
            if json {
                print_json(true, &serde_json::json!({ "written": dirs }))
            } else {
                for d in dirs {
                    println!("wrote {}", d.display());
                }
                Ok(())
            }
        }
        Command::Track {
            archive,
            out,
            start,
            end,
            channels,
            stationxml,
            window,
            step,
            training,
            reference,
            min_present,
            cycle,
            temperature,
            temperature_channel,
        } => {
            let opts = quaketwin::track::TrackOptions {
                archive: archive.clone(),
                out: out.clone(),
                start: start.clone(),
                end: end.clone(),
                channels: channels.clone(),
                stationxml: stationxml.clone(),
                window: window.clone(),
                step: step.clone(),
                training: training.clone(),
                reference: reference.clone(),
                min_present: *min_present,
                cycle: cycle.clone(),
                temperature: temperature.clone(),
                temperature_channel: temperature_channel.clone(),
            };
            let s = match commands::track(&opts) {
                Ok(s) => s,
                Err(e) => {
                    // The summary of a failed run on stdout, then the error
                    // on stderr and its exit code (docs/cli.md, `--json`).
                    print_json(json, &quaketwin::track::TrackSummary::failed(&opts, &e))?;
                    return Err(e);
                }
            };
            console::info(format!(
                "track: {} windows ({} identified), {} modes tracked; {}; {:.1} s; wrote {}",
                s.windows,
                s.identified_windows,
                s.modes.len(),
                match &s.anomaly_from {
                    Some(t) => format!("anomaly from {t}"),
                    None => "no sustained anomaly".into(),
                },
                s.seconds,
                out.display()
            ));
            print_json(json, &s)
        }
        Command::History {
            dataset,
            structure,
            out,
            intensity,
            no_prediction,
        } => {
            let mut opts = quaketwin::dataset_history::HistoryOptions::new(dataset, out);
            opts.structure = structure.clone();
            opts.predict = !no_prediction;
            let result = quaketwin::dataset_history::Intensity::from_name(intensity)
                .ok_or_else(|| {
                    quaketwin::error::Error::usage(format!(
                        "--intensity {intensity:?}: expected response or base"
                    ))
                })
                .and_then(|i| {
                    opts.intensity = i;
                    commands::history(&opts)
                });
            let s = match result {
                Ok(s) => s,
                Err(e) => {
                    print_json(
                        json,
                        &quaketwin::dataset_history::HistorySummary::failed(&opts, &e),
                    )?;
                    return Err(e);
                }
            };
            let flagged: usize = s
                .structures
                .iter()
                .flat_map(|st| &st.modes)
                .map(|m| m.flagged.len())
                .sum();
            console::info(format!(
                "history: {} structure(s), {} event(s), {} flagged mode-event(s); {:.1} s; wrote {}",
                s.structures.len(),
                s.structures.iter().map(|st| st.events).sum::<usize>(),
                flagged,
                s.seconds,
                out.display()
            ));
            print_json(json, &s)
        }
        Command::SynthArchive {
            out,
            days,
            channels,
            rate,
            seed,
            day_length,
            damage_day,
        } => {
            let w = commands::synth_archive(
                out,
                *days,
                *channels,
                *rate,
                *seed,
                day_length,
                *damage_day,
            )?;
            console::info(format!(
                "synth-archive: {} streams, {} to {}, {} day files ({:.0} MB); wrote {}",
                w.streams.len(),
                w.start,
                w.end,
                w.day_files,
                w.bytes as f64 / 1e6,
                out.display()
            ));
            print_json(json, &w)
        }
        Command::Fleet {
            pipeline,
            events,
            out,
            scheduler,
        } => commands::fleet(pipeline, events, out, scheduler.as_deref(), quiet),
        Command::CompareTest {
            design_out,
            test_records,
            out,
            settings,
            time_scale,
            max_lag,
            no_update,
        } => {
            let s = commands::compare_test(
                design_out,
                test_records,
                out,
                settings.as_deref(),
                *time_scale,
                *max_lag,
                !*no_update,
            )?;
            console::info(format!(
                "compare-test: λ = {}, {} steps × {} actuators; lag {:.4} s, noise {:.3e} m; tracking RMS logged {:.3e} m, rehearsal {:.3e} m; energy error logged {:.3}, rehearsal {:.3}; wrote {}",
                s.time_scale,
                s.steps,
                s.actuators,
                s.lag_s,
                s.noise_std_m,
                s.logged_tracking_rms_m,
                s.rehearsal_tracking_rms_m,
                s.logged_energy_error,
                s.rehearsal_energy_error,
                out.display()
            ));
            if let Some(f) = &s.specimen_failure {
                console::info(format!("compare-test: specimen not updated: {f}"));
            }
            print_json(json, &s)
        }
        Command::SynthHybridLog {
            design_out,
            out,
            settings,
            time_scale,
            substeps,
            duration,
            delay,
            bandwidth,
            noise,
            force_noise,
            seed,
        } => {
            let flags = commands::HybridLogFlags {
                settings: settings.clone(),
                time_scale: *time_scale,
                substeps: *substeps,
                duration_s: *duration,
                delay_s: *delay,
                bandwidth_hz: *bandwidth,
                noise_m: *noise,
                force_noise_n: *force_noise,
                seed: *seed,
            };
            let (truth, files) = commands::synth_hybrid_log(design_out, out, &flags)?;
            console::info(format!(
                "synth-hybrid-log: λ = {}, {} steps of {} s; lag {:.4} s (servo {} {} Hz, delay {} s), noise {:e} m; wrote {}",
                truth.time_scale,
                truth.steps,
                truth.dt_s,
                truth.lag_s,
                truth.servo,
                truth.bandwidth_hz,
                truth.delay_s,
                truth.displacement_noise_m,
                out.display()
            ));
            print_json(
                json,
                &serde_json::json!({ "truth": truth, "written": files }),
            )
        }
        Command::Rehearse {
            design_out,
            out,
            settings,
            scheme,
            time_scales,
        } => {
            let s = commands::rehearse(
                design_out,
                out,
                settings.as_deref(),
                scheme.as_deref(),
                time_scales.clone(),
            )?;
            console::info(format!(
                "rehearse: {} runs ({} stable), {} NS modes; smallest safe λ {} (design λ = {}); wrote {}",
                s.runs,
                s.stable_runs,
                s.ns_modes,
                s.recommended_time_scale
                    .map(|l| l.to_string())
                    .unwrap_or_else(|| "none".into()),
                s.design_time_scale,
                out.display()
            ));
            print_json(json, &s)
        }
        Command::Watch {
            inbox,
            pipeline,
            out,
            notify,
            poll,
            settle,
            require_done,
            once,
            dashboard,
            no_dashboard,
            notify_attempts,
            notify_backoff,
            notify_max_delay,
            notify_timeout,
        } => {
            let opts = quaketwin::watch::flags::WatchFlags {
                inbox: inbox.clone(),
                pipeline: pipeline.clone(),
                out: out.clone(),
                notify: notify.clone(),
                poll: *poll,
                settle: *settle,
                require_done: *require_done,
                once: *once,
                dashboard: dashboard.clone(),
                no_dashboard: *no_dashboard,
                notify_attempts: *notify_attempts,
                notify_backoff: *notify_backoff,
                notify_max_delay: *notify_max_delay,
                notify_timeout: *notify_timeout,
            }
            .options()?;
            let s = commands::watch(&opts)?;
            print_json(json, &s)?;
            if s.has_failures() {
                return Err(quaketwin::error::Error::numerical(format!(
                    "watch: {} events failed, {} notifications in the dead-letter folder (the log above names them)",
                    s.failed.len(),
                    s.notifications_dead
                )));
            }
            Ok(())
        }
        Command::Dashboard { dataset, out } => {
            let w = commands::dashboard(dataset, out)?;
            console::info(format!(
                "dashboard: {} structures, {} events; wrote {}",
                w.structures,
                w.events,
                out.join("index.html").display()
            ));
            print_json(json, &w)
        }
        Command::Run {
            pipeline,
            event,
            out,
            reference,
        } => {
            let runs = commands::run_events(pipeline, event, out, reference.as_deref(), quiet)?;
            if json {
                print!(
                    "{}",
                    runs.summary_json(&pipeline.display().to_string(), out)?
                );
            }
            runs.into_result()
        }
    }
}

fn main() -> ExitCode {
    keep_freed_memory();
    let cli = Cli::parse();
    console::set_verbosity(if cli.quiet {
        Verbosity::Quiet
    } else if cli.verbose {
        Verbosity::Verbose
    } else {
        Verbosity::Normal
    });
    quaketwin::fixed_order_reductions();
    match run_command(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!(
                "quaketwin: error: {}",
                quaketwin::error::printable(
                    &e.to_string(),
                    quaketwin::error::MAX_PRINTED_ERROR_CHARS
                )
            );
            ExitCode::from(e.exit_code() as u8)
        }
    }
}
