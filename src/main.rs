//! The `quaketwin` command: a thin clap front end over the library.
//! Exit codes: 0 success, 1 bad input or failed processing, 2 usage error.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "quaketwin",
    version,
    about = "From a building's earthquake records to damage decisions"
)]
struct Cli {
    /// No progress output on stderr.
    #[arg(long, short, global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List the channels of an event folder (or zip): what was read, inferred, missing.
    Inspect {
        /// Event folder or zip.
        event: PathBuf,
    },
    /// Read an event folder, condition it and compute strong-motion metrics
    /// (channels.parquet, samples.parquet, spectra.parquet, drift.parquet).
    Ingest {
        /// Event folder or zip.
        event: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Also write the conditioned event as MCAP (replay, Foxglove).
        #[arg(long)]
        mcap: Option<PathBuf>,
    },
    /// Update a digital twin against measured modes (ensemble + Plackett–Luce).
    Update {
        /// Twin file (TOML, docs/twin.md).
        twin: PathBuf,
        /// modes.parquet from the modal stage.
        #[arg(long)]
        modes: PathBuf,
        #[arg(long)]
        out: PathBuf,
        /// Update settings (TOML: solvers, seed, max_rounds, tolerance, selection…).
        #[arg(long)]
        settings: Option<PathBuf>,
    },
    /// Write DIR/report.html from the outputs of a pipeline run in DIR.
    Report {
        /// Output directory of a run.
        dir: PathBuf,
        /// Report settings (TOML: rating thresholds…), see docs/report.md.
        #[arg(long)]
        settings: Option<PathBuf>,
    },
    /// Subspace modal identification (writes modes.parquet, stabilization.parquet…).
    Modal {
        /// Event folder or zip.
        event: PathBuf,
        #[arg(long)]
        out: PathBuf,
        /// auto (input–output when base channels exist), ssi-cov, ssi-data or io.
        #[arg(long, default_value = "auto")]
        method: String,
        /// Band of interest LO,HI in Hz (default: from the structure, else 0.2,20).
        #[arg(long)]
        band: Option<String>,
        /// Decimation factor (default: automatic, ≈ 4 × the band's top).
        #[arg(long)]
        decimate: Option<String>,
        /// Block rows (default: automatic).
        #[arg(long)]
        block_rows: Option<String>,
        /// Model orders MIN,MAX[,STEP] (default: 2 to what the data support).
        #[arg(long)]
        orders: Option<String>,
        /// Input channel ids ID,ID,… for io (default: horizontal base channels).
        #[arg(long)]
        inputs: Option<String>,
        /// An earlier run of the same structure (its output directory, or its
        /// modes.parquet): pair the modes and write frequency_shifts.parquet.
        #[arg(long, value_name = "DIR_OR_FILE")]
        reference: Option<PathBuf>,
    },
    /// Bouc-Wen identification and damage index (bouc_wen.parquet, damage.parquet…).
    Hysteresis {
        /// Event folder or zip.
        event: PathBuf,
        #[arg(long)]
        out: PathBuf,
    },
    /// Hybrid-test design from recorded response: actuator layout (POD), Guyan + rigid-body
    /// reduction, Craig–Bampton prototype (docs/test-design.md).
    Design {
        /// Design file (TOML: twin, PS node set, base motion, settings).
        design: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Rehearse the hybrid test of a design run before the specimen is loaded: virtual test
    /// with actuator lag, delay and noise, swept over time scales λ (docs/test-design.md).
    Rehearse {
        /// Output directory of a design run (holds rehearsal_model.json).
        design_out: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Rehearsal settings (TOML, the `rehearse` stage's params).
        #[arg(long)]
        settings: Option<PathBuf>,
        /// Integration scheme: alpha-os or central-difference (overrides the settings).
        #[arg(long)]
        scheme: Option<String>,
        /// Time scales λ to sweep, comma-separated (overrides the settings).
        #[arg(long, value_delimiter = ',')]
        time_scales: Option<Vec<f64>>,
    },
    /// Generate the synthetic sample events (known model, with truth files).
    Synth {
        /// Directory to write the event folders into.
        #[arg(long, default_value = "sample-records")]
        out: PathBuf,
        /// Random seed (same seed, same files).
        #[arg(long, default_value_t = 2026)]
        seed: u64,
    },
    /// Run a pipeline file on an event folder; several events (or a folder of
    /// event folders) run in parallel into a table-first Hive dataset:
    /// DIR/<table>/structure=…/event=…/part-0.parquet, each event's run
    /// (run.json, event.json, report.html) in DIR/runs/structure=…/event=…/.
    Run {
        /// Pipeline file (pipelines/*.toml).
        pipeline: PathBuf,
        /// Event folder(s) or zip(s).
        #[arg(required = true)]
        event: Vec<PathBuf>,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// An earlier run of the same structure (its output directory, holding
        /// modes.parquet): every modal stage pairs its modes with it and writes
        /// frequency_shifts.parquet.
        #[arg(long, value_name = "DIR")]
        reference: Option<PathBuf>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    quaketwin::fixed_order_reductions();
    let result = match &cli.command {
        Command::Inspect { event } => quaketwin::commands::inspect(event).map(|s| print!("{s}")),
        Command::Ingest { event, out, mcap } => {
            quaketwin::commands::ingest(event, out, mcap.as_deref(), cli.quiet).map(|_| ())
        }
        Command::Update {
            twin,
            modes,
            out,
            settings,
        } => quaketwin::commands::update(twin, modes, out, settings.as_deref()).map(|s| {
            if !cli.quiet {
                eprintln!("{}", serde_json::to_string_pretty(&s).unwrap_or_default());
            }
        }),
        Command::Report { dir, settings } => quaketwin::commands::report(dir, settings.as_deref())
            .map(|p| {
                if !cli.quiet {
                    eprintln!("wrote {}", p.display());
                }
            }),
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
            let flags = quaketwin::commands::ModalFlags {
                method: method.clone(),
                band: band.clone(),
                decimate: decimate.clone(),
                block_rows: block_rows.clone(),
                orders: orders.clone(),
                inputs: inputs.clone(),
                reference: reference.clone(),
            };
            quaketwin::commands::modal(event, out, &flags, cli.quiet)
        }
        Command::Hysteresis { event, out } => {
            quaketwin::commands::hysteresis(event, out, cli.quiet)
        }
        Command::Design { design, out } => quaketwin::commands::design(design, out).map(|s| {
            if !cli.quiet {
                eprintln!("{}", serde_json::to_string_pretty(&s).unwrap_or_default());
            }
        }),
        Command::Rehearse {
            design_out,
            out,
            settings,
            scheme,
            time_scales,
        } => quaketwin::commands::rehearse(
            design_out,
            out,
            settings.as_deref(),
            scheme.as_deref(),
            time_scales.clone(),
        )
        .map(|s| {
            if !cli.quiet {
                eprintln!("{}", serde_json::to_string_pretty(&s).unwrap_or_default());
            }
        }),
        Command::Synth { out, seed } => quaketwin::commands::synth(out, *seed).map(|dirs| {
            for d in dirs {
                println!("wrote {}", d.display());
            }
        }),
        Command::Run {
            pipeline,
            event,
            out,
            reference,
        } => {
            let events = quaketwin::commands::expand_events(event);
            let reference = reference.as_deref();
            if event.len() == 1 && events.len() == 1 && events[0] == event[0] {
                quaketwin::commands::run_pipeline_with(
                    pipeline, &events[0], out, reference, cli.quiet,
                )
                .map(|_| ())
            } else {
                quaketwin::commands::run_many_with(pipeline, &events, out, reference, cli.quiet)
                    .and_then(|results| {
                        results
                            .into_iter()
                            .map(|(_, r)| r)
                            .find(|r| r.is_err())
                            .unwrap_or(Ok(()))
                    })
            }
        }
    };
    match result {
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
