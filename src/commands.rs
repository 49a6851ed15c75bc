//! What each CLI subcommand does, as library functions (so tests call them
//! directly and the binary stays a thin clap front end).

use std::fmt::Write as _;
use std::path::Path;

use crate::error::Result;
use crate::event_folder::{self, LoadedEvent};
use crate::pipeline::{self, StageOutcome};
use crate::stages::{load_pipeline, parse_pipeline};
use crate::vocab::format_epoch_ns;

/// `quaketwin inspect EVENT`: a table of the channels, what was inferred and
/// what is missing.  The event's samples are not kept (see
/// [`event_folder::load_listing`]): memory is that of its largest file.
pub fn inspect(event: &Path) -> Result<String> {
    let loaded = event_folder::load_listing(event)?;
    Ok(render_inventory(&loaded))
}

/// `quaketwin inspect EVENT --json`: the inventory as JSON (the same
/// document the ingest stage writes as `event.json`).
pub fn inspect_json(event: &Path) -> Result<String> {
    let loaded = event_folder::load_listing(event)?;
    let bytes = crate::stages::ingest::inventory_json(&loaded)?;
    Ok(String::from_utf8_lossy(&bytes).into_owned() + "\n")
}

/// `quaketwin init EVENT [-o FILE] [--force]`: the manifest text, written
/// to `out` atomically when given (refusing an existing file without
/// `force`, and any path inside the event, whose inputs are never
/// modified).  Returns the text when it is for standard output, else `None`.
pub fn init(event: &Path, out: Option<&Path>, force: bool) -> Result<Option<String>> {
    use crate::error::Error;
    let loaded = event_folder::load_headers(event)?;
    let text =
        event_folder::init::manifest_text(&loaded, &event.display().to_string(), event.is_file());
    let Some(out) = out else {
        return Ok(Some(text));
    };
    // Never into the input: the event itself, or anywhere inside a folder event.
    let absolute = |p: &std::path::Path| -> std::path::PathBuf {
        let p = if p.is_absolute() {
            p.to_path_buf()
        } else {
            std::env::current_dir()
                .map(|d| d.join(p))
                .unwrap_or_else(|_| p.to_path_buf())
        };
        // The parent exists (or the write fails anyway): resolve it, keep the name.
        match (
            p.parent().and_then(|d| d.canonicalize().ok()),
            p.file_name(),
        ) {
            (Some(d), Some(n)) => d.join(n),
            _ => p,
        }
    };
    let event_abs = event.canonicalize().map_err(|e| Error::io(event, e))?;
    let out_abs = absolute(out);
    if out_abs == event_abs || out_abs.starts_with(&event_abs) {
        return Err(Error::usage(format!(
            "{}: inside the event {}, whose files quaketwin never modifies; write the manifest elsewhere and copy it in yourself",
            out.display(),
            event.display()
        )));
    }
    crate::sinks::atomic::check_replaceable(out)?;
    if !force && std::fs::symlink_metadata(out).is_ok() {
        return Err(Error::usage(format!(
            "{} exists: give --force to replace it",
            out.display()
        )));
    }
    crate::sinks::atomic::write_bytes_atomically(out, text.as_bytes())?;
    Ok(None)
}

/// Human-readable inventory of a loaded event.
pub fn render_inventory(loaded: &LoadedEvent) -> String {
    let e = &loaded.event;
    let mut s = String::new();
    let _ = writeln!(s, "event     {}", e.name);
    if let Some(t) = e.origin_ns {
        let _ = writeln!(s, "origin    {}", format_epoch_ns(t));
    }
    if let Some(m) = e.magnitude {
        let _ = writeln!(s, "magnitude {m}");
    }
    if let Some(st) = &e.structure {
        let _ = writeln!(
            s,
            "structure {} ({} storey heights, {} masses{})",
            st.name.as_deref().unwrap_or("unnamed"),
            st.storey_heights_m.len(),
            st.masses_kg.len(),
            st.twin
                .as_ref()
                .map(|t| format!(", twin {t}"))
                .unwrap_or_default()
        );
    }
    if let Some(st) = &e.structure {
        let said = [
            st.kind.as_ref().map(|k| format!("kind {k}")),
            st.storeys.map(|n| format!("{n} storeys")),
            st.height_m.map(|h| format!("height {h} m")),
        ];
        let said: Vec<String> = said.into_iter().flatten().collect();
        if !said.is_empty() {
            let _ = writeln!(s, "          {}", said.join(", "));
        }
        for i in &st.inferred {
            let _ = writeln!(s, "          inferred: {i}");
        }
    }
    let _ = writeln!(s, "\nfiles ({}):", loaded.files.len());
    for f in &loaded.files {
        let what = match (&f.skipped, f.format) {
            (Some(why), _) => format!("skipped: {why}"),
            (None, Some(fmt)) => format!("{fmt}, {} channel(s)", f.channels),
            (None, None) => "?".into(),
        };
        let _ = writeln!(s, "  {:<60} {}", f.name, what);
    }
    let _ = writeln!(s, "\nchannels ({}):", e.records.len());
    let _ = writeln!(
        s,
        "  {:<22} {:<7} {:<9} {:>5} {:<7} {:<7} {:>8} {:>7} {:<25}",
        "id", "format", "dir", "level", "role", "units", "fs_hz", "npts", "start (UTC)"
    );
    for r in &e.records {
        let c = &r.channel;
        let _ = writeln!(
            s,
            "  {:<22} {:<7} {:<9} {:>5} {:<7} {:<7} {:>8.3} {:>7} {:<25}",
            c.id,
            c.source.format,
            c.direction
                .map(|d| d.to_string())
                .unwrap_or_else(|| "?".into()),
            c.level.map(|l| l.to_string()).unwrap_or_else(|| "?".into()),
            c.role.name(),
            c.units.name(),
            c.sampling_rate_hz,
            r.samples.len(),
            c.start_ns
                .map(format_epoch_ns)
                .unwrap_or_else(|| "?".into()),
        );
        for i in &c.inferred {
            let _ = writeln!(s, "      inferred: {i}");
        }
        if !c.missing.is_empty() {
            let _ = writeln!(s, "      missing:  {}", c.missing.join(", "));
        }
        for q in &c.qa {
            let _ = writeln!(
                s,
                "      qa:       {}",
                serde_json::to_string(q).unwrap_or_default()
            );
        }
    }
    render_geometry(&mut s, &loaded.geometry, &e.history);
    if !e.notes.is_empty() {
        let _ = writeln!(s, "\nnotes:");
        for n in &e.notes {
            let _ = writeln!(s, "  - {n}");
        }
    }
    s
}

/// The building geometry applied at ingest: axes (stated or inferred),
/// what was done to each channel, the floors combined.
fn render_geometry(
    s: &mut String,
    g: &crate::geometry::GeometryReport,
    history: &crate::vocab::ProcessingHistory,
) {
    let _ = writeln!(s, "\ngeometry:");
    for step in history.steps.iter().filter(|h| h.step == "reverse_sign") {
        let _ = writeln!(
            s,
            "  {:<22} reversed      (stated: manifest reversed = true)",
            step.params["channel"].as_str().unwrap_or("?")
        );
    }
    match &g.axes {
        Some(a) => {
            let _ = writeln!(
                s,
                "  building axes X = {}°, Y = {}° ({})",
                a.x_azimuth_deg,
                a.y_azimuth_deg,
                match a.source {
                    crate::geometry::AxesSource::Stated => "stated: structure.x_axis_azimuth_deg",
                    crate::geometry::AxesSource::Inferred => "inferred from the sensor azimuths",
                }
            );
        }
        None if g.actions.iter().any(|a| a.action == "unresolved") => {
            let _ = writeln!(
                s,
                "  building axes not stated, and not inferred: some channels are in the structure's own axes (Long/Tran, X/Y), others at azimuths (state structure.x_axis_azimuth_deg)"
            );
        }
        None => {
            let _ = writeln!(
                s,
                "  no channel is labelled by azimuth: directions as stated"
            );
        }
    }
    for a in &g.actions {
        let partner = a
            .partner
            .as_ref()
            .map(|p| format!(" (with {p})"))
            .unwrap_or_default();
        let _ = writeln!(
            s,
            "  {:<22} {:<13} {} -> {}{partner}",
            a.channel, a.action, a.from, a.to
        );
    }
    for f in &g.floors {
        let _ = writeln!(
            s,
            "  level {}: {} of {} -> {}{}",
            f.level,
            f.method,
            f.channels.join(", "),
            if f.floors.is_empty() {
                "-".to_string()
            } else {
                f.floors.join(", ")
            },
            if f.note.is_empty() {
                String::new()
            } else {
                format!(" ({})", f.note)
            }
        );
    }
}

/// `quaketwin run PIPELINE EVENT --out DIR`.
pub fn run_pipeline(
    pipeline_path: &Path,
    event: &Path,
    out: &Path,
    quiet: bool,
) -> Result<Vec<(String, StageOutcome)>> {
    run_pipeline_with(pipeline_path, event, out, None, quiet)
}

/// `quaketwin run PIPELINE EVENT --out DIR [--reference EARLIER_RUN]`.
pub fn run_pipeline_with(
    pipeline_path: &Path,
    event: &Path,
    out: &Path,
    reference: Option<&Path>,
    quiet: bool,
) -> Result<Vec<(String, StageOutcome)>> {
    let p = load_run_pipeline(pipeline_path, out, reference)?;
    pipeline::run(&p, event, out, quiet)
}

/// The pipeline of `quaketwin run`, with `--reference` set into its modal
/// stages (checked first: usage errors, exit 2, before any event is read).
fn load_run_pipeline(
    pipeline_path: &Path,
    out: &Path,
    reference: Option<&Path>,
) -> Result<crate::pipeline::Pipeline> {
    match reference {
        None => load_pipeline(pipeline_path),
        Some(r) => {
            let file = check_reference(r, out)?;
            crate::stages::load_pipeline_with_reference(pipeline_path, &path_text(&file)?)
        }
    }
}

/// The `modes.parquet` of `--reference` (an earlier run's output directory
/// or the file itself): usage errors naming the path when it is missing,
/// not a modes table, or inside the output directory `out` (which the run
/// rewrites).
pub fn check_reference(reference: &Path, out: &Path) -> Result<std::path::PathBuf> {
    let file = crate::sinks::modal_tables::locate_modes(reference)
        .map_err(|e| e.usage_about("--reference"))?;
    if let (Ok(f), Ok(o)) = (std::fs::canonicalize(&file), std::fs::canonicalize(out)) {
        if f.starts_with(&o) {
            return Err(crate::error::Error::usage(format!(
                "--reference {}: lies inside the output directory {}, which this run rewrites: give the output directory of an earlier run",
                reference.display(),
                out.display()
            )));
        }
    }
    Ok(file)
}

/// A path as pipeline-file text (usage error when it is not UTF-8).
fn path_text(p: &Path) -> Result<String> {
    p.to_str().map(str::to_string).ok_or_else(|| {
        crate::error::Error::usage(format!("{}: path is not valid UTF-8", p.display()))
    })
}

/// The pipeline `quaketwin ingest` runs (a copy of pipelines/ingest.toml
/// embedded in the binary, so the command works from any directory).
pub const INGEST_PIPELINE: &str = include_str!("../pipelines/ingest.toml");

/// `quaketwin ingest EVENT --out DIR [--mcap FILE]`: read, condition,
/// metrics; optionally the conditioned event as MCAP for replay or viewing.
pub fn ingest(
    event: &Path,
    out: &Path,
    mcap: Option<&Path>,
    quiet: bool,
) -> Result<Vec<(String, StageOutcome)>> {
    let p = parse_pipeline(INGEST_PIPELINE, "built-in ingest pipeline")?;
    let outcomes = pipeline::run(&p, event, out, quiet)?;
    if let Some(path) = mcap {
        let (conditioned, _) = crate::sinks::event_tables::read_samples(
            &out.join(crate::vocab::tables::SAMPLES.file),
        )?;
        let write =
            || crate::sinks::mcap_writer::write_event(&conditioned, path, &Default::default());
        // An MCAP file inside the output directory is listed in its run
        // manifest (so a later run of another event removes it); elsewhere
        // it is the user's file (still never replacing a link or device).
        match mcap_name_in(out, path) {
            Some(name) => {
                pipeline::write_extra_output(out, &name, "mcap (quaketwin ingest --mcap)", write)?
            }
            None => write()?,
        }
    }
    Ok(outcomes)
}

/// The file name of `path` when it lies directly in directory `out`.
fn mcap_name_in(out: &Path, path: &Path) -> Option<String> {
    let name = path.file_name()?.to_string_lossy().into_owned();
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let same = std::fs::canonicalize(parent).ok()? == std::fs::canonicalize(out).ok()?;
    same.then_some(name)
}

/// `quaketwin report DIR`: writes DIR/report.html from the outputs in DIR
/// (under the directory's lock, and listed in its run manifest when it has one).
pub fn report(dir: &Path, settings: Option<&Path>) -> Result<std::path::PathBuf> {
    let settings: crate::report::ReportSettings = match settings {
        None => Default::default(),
        Some(p) => {
            let text = crate::input_file::read_to_string(p, crate::input_file::MAX_SETTINGS_BYTES)?;
            toml::from_str(&text).map_err(|e: toml::de::Error| {
                crate::error::Error::usage(format!("{}: {}", p.display(), e.message()))
            })?
        }
    };
    pipeline::write_extra_output(dir, "report.html", "report (quaketwin report)", || {
        // Under the directory's lock: the files checked are the files shown.
        crate::report::verify_against_manifest(dir)?;
        crate::report::write_report(dir, &settings)
    })
}

/// `quaketwin synth --out DIR`: writes the sample events.
pub fn synth(out: &Path, seed: u64) -> Result<Vec<std::path::PathBuf>> {
    let settings = crate::synth::event::SynthSettings {
        seed,
        ..Default::default()
    };
    let mut written = crate::synth::event::write_sample_events(out, &settings)?;
    written.push(crate::synth::facade::write_facade_sample(out, seed)?);
    written.push(crate::synth::realistic::nsmp::write(out, seed)?);
    written.push(crate::synth::realistic::tall::write(out, seed)?);
    written.push(crate::synth::realistic::degrading::write(out, seed)?);
    Ok(written)
}

/// Flags of `quaketwin modal` as typed (parsed and checked by [`modal`]).
#[derive(Debug, Clone, Default)]
pub struct ModalFlags {
    pub method: String,
    pub band: Option<String>,
    pub decimate: Option<String>,
    pub block_rows: Option<String>,
    pub orders: Option<String>,
    pub inputs: Option<String>,
    /// `--reference`: an earlier run's output directory or modes.parquet.
    pub reference: Option<std::path::PathBuf>,
}

fn numbers<T: std::str::FromStr>(flag: &str, text: &str, counts: &[usize]) -> Result<Vec<T>> {
    let bad = || {
        crate::error::Error::usage(format!(
            "--{flag} {text:?}: expected {} comma-separated number(s)",
            counts
                .iter()
                .map(|c| c.to_string())
                .collect::<Vec<_>>()
                .join(" or ")
        ))
    };
    let v: Vec<T> = text
        .split(',')
        .map(|x| x.trim().parse::<T>().map_err(|_| bad()))
        .collect::<Result<_>>()?;
    if counts.contains(&v.len()) {
        Ok(v)
    } else {
        Err(bad())
    }
}

impl ModalFlags {
    /// The `[stage.params]` lines of the modal stage; bad values are usage
    /// errors (exit 2) before any record is read.
    pub fn params_toml(&self) -> Result<String> {
        let mut t = format!("method = {:?}\n", self.method);
        if let Some(b) = &self.band {
            let v: Vec<f64> = numbers("band", b, &[2])?;
            t += &format!("band_hz = [{:?}, {:?}]\n", v[0], v[1]);
        }
        if let Some(d) = &self.decimate {
            let v: Vec<usize> = numbers("decimate", d, &[1])?;
            t += &format!("decimation = {}\n", v[0]);
        }
        if let Some(p) = &self.block_rows {
            let v: Vec<usize> = numbers("block-rows", p, &[1])?;
            t += &format!("block_rows = {}\n", v[0]);
        }
        if let Some(o) = &self.orders {
            let v: Vec<usize> = numbers("orders", o, &[2, 3])?;
            t += &format!(
                "orders = [{}, {}, {}]\n",
                v[0],
                v[1],
                v.get(2).copied().unwrap_or(2)
            );
        }
        if let Some(i) = &self.inputs {
            let ids: Vec<String> = i
                .split(',')
                .map(|x| x.trim().to_string())
                .filter(|x| !x.is_empty())
                .collect();
            t += &format!("inputs = {ids:?}\n");
        }
        Ok(t)
    }
}

/// `quaketwin modal EVENT --out DIR [--method M] [--band LO,HI] [--decimate N]
/// [--block-rows N] [--orders MIN,MAX] [--inputs ID,…] [--reference EARLIER_RUN]`:
/// ingest + condition + modal (+ frequency_shifts.parquet).
pub fn modal(
    event: &Path,
    out: &Path,
    flags: &ModalFlags,
    quiet: bool,
) -> Result<Vec<(String, StageOutcome)>> {
    let mut params = flags.params_toml()?;
    if let Some(r) = &flags.reference {
        let file = path_text(&check_reference(r, out)?)?;
        params += &format!(
            "{} = {}\n",
            crate::stages::prepost::REFERENCE_KEY,
            toml::Value::String(file)
        );
    }
    let text = format!(
        "{INGEST_PIPELINE}\n[[stage]]\nname = \"modal\"\nkind = \"modal\"\ninputs = [\"condition\"]\n[stage.params]\n{params}"
    );
    let mut p = parse_pipeline(&text, "built-in modal pipeline")?;
    // The ingest pipeline's stages plus modal: named as the command, so that
    // its lines read `[modal] modal done …`, not `[ingest] …`.
    p.pipeline.name = "modal".into();
    pipeline::run(&p, event, out, quiet)
}

/// `quaketwin hysteresis EVENT --out DIR`: Bouc-Wen identification and damage
/// index on the records as recorded (SI units only).  A direction that cannot
/// be identified is not a failure: its reason goes to bouc_wen.parquet
/// (`status = not_identifiable`) and to stderr, and the command exits 0.
pub fn hysteresis(event: &Path, out: &Path, quiet: bool) -> Result<Vec<(String, StageOutcome)>> {
    let text = "[pipeline]\nname = \"hysteresis\"\n[[stage]]\nname = \"ingest\"\nkind = \"ingest\"\n\
                [[stage]]\nname = \"as-recorded\"\nkind = \"condition\"\ninputs = [\"ingest\"]\n[stage.params]\nsteps = []\nsamples_file = \"samples_as_recorded.parquet\"\n\
                [[stage]]\nname = \"hysteresis\"\nkind = \"hysteresis\"\ninputs = [\"as-recorded\"]\n\
                [[stage]]\nname = \"damage\"\nkind = \"damage\"\ninputs = [\"hysteresis\"]\n";
    let p = parse_pipeline(text, "built-in hysteresis pipeline")?;
    pipeline::run(&p, event, out, quiet)
}

/// `quaketwin update TWIN --modes modes.parquet --out DIR`: ensemble updating
/// of the twin against measured modes (METHODS §3).
pub fn update(
    twin: &Path,
    modes: &Path,
    out: &Path,
    settings: Option<&Path>,
) -> Result<crate::stages::update::UpdateSummary> {
    let params: crate::stages::update::UpdateParams = match settings {
        None => Default::default(),
        Some(p) => {
            let text = crate::input_file::read_to_string(p, crate::input_file::MAX_SETTINGS_BYTES)?;
            crate::stages::update::UpdateParams::from_toml(&text, &p.display().to_string())?
        }
    };
    // `--modes` may name a run's output directory: its modes.parquet.
    let modes = if modes.is_dir() {
        crate::vocab::tables::MODES.locate(modes)
    } else {
        modes.to_path_buf()
    };
    crate::stages::update::update_from_files(twin, &modes, out, &params)
}

/// `quaketwin design DESIGN.toml --out DIR`: hybrid-test design (METHODS §5–6) from the
/// design file's twin, PS node set and base motion; writes the design tables into DIR.
pub fn design(design: &Path, out: &Path) -> Result<crate::stages::design::DesignSummary> {
    crate::stages::design::design_from_file(design, out)
}

/// What `quaketwin twin export` wrote.
#[derive(Debug, Clone, serde::Serialize)]
pub struct TwinExport {
    /// Free DoFs (the order of the matrices' rows).
    pub dofs: usize,
    pub stiffness: std::path::PathBuf,
    pub mass: std::path::PathBuf,
    /// The parameter values the matrices are assembled at (the twin's start values).
    pub parameters: Vec<(String, f64)>,
}

/// `quaketwin twin export TWIN --out DIR`: the twin's stiffness and mass
/// matrices over its free DoFs at its start parameters, as Matrix Market
/// (`DIR/stiffness.mtx`, `DIR/mass.mtx`, lower triangles, `coordinate real
/// symmetric`), so that any eigen-solver (scipy's `eigsh`…) can be run on
/// exactly the model quaketwin solves (`scripts/eigsh_compare.py`).
pub fn twin_export(twin: &Path, out: &Path) -> Result<TwinExport> {
    let twin = crate::twin::file::load_twin(twin)?;
    let sys = &twin.system;
    let theta = sys.start_values();
    std::fs::create_dir_all(out).map_err(|e| crate::error::Error::io(out, e))?;
    let (stiffness, mass) = (out.join("stiffness.mtx"), out.join("mass.mtx"));
    crate::sinks::matrix_market::write_matrix_market_symmetric(
        &sys.stiffness_at(&theta),
        &stiffness,
    )?;
    crate::sinks::matrix_market::write_matrix_market_symmetric(&sys.mass_at(&theta), &mass)?;
    Ok(TwinExport {
        dofs: sys.n,
        stiffness,
        mass,
        parameters: sys
            .parameters
            .iter()
            .map(|p| (p.name.clone(), p.start))
            .collect(),
    })
}

/// What `quaketwin twin modes` found.
#[derive(Debug, Clone, serde::Serialize)]
pub struct TwinModes {
    pub dofs: usize,
    pub frequencies_hz: Vec<f64>,
    /// Wall time of the eigen-solve (assembly at θ, factorisation, iterations).
    pub solve_seconds: f64,
}

/// `quaketwin twin modes TWIN [--count N]`: the N lowest modes of the twin
/// at its start parameters, and the time the solve took.
pub fn twin_modes(twin: &Path, count: usize) -> Result<TwinModes> {
    let most = crate::twin::eigen::MAX_MODES;
    if !(1..=most).contains(&count) {
        return Err(crate::error::Error::usage(format!(
            "--count {count}: must be 1..={most}"
        )));
    }
    crate::fixed_order_reductions();
    let twin = crate::twin::file::load_twin(twin)?;
    let sys = &twin.system;
    let t0 = std::time::Instant::now();
    let modes = sys.modes(&sys.start_values(), count)?;
    Ok(TwinModes {
        dofs: sys.n,
        frequencies_hz: modes.frequencies_hz(),
        solve_seconds: t0.elapsed().as_secs_f64(),
    })
}

/// `quaketwin twin plate --nx NX --ny NY --out FILE`: writes the benchmark
/// twin of a clamped concrete shell plate (NX × NY elements; 162 × 102 gives
/// 100 116 free DoFs, the model of the twin benchmark).
pub fn twin_plate(nx: usize, ny: usize, out: &Path) -> Result<()> {
    if nx == 0 || ny == 0 || nx.saturating_mul(ny) > 1_000_000 {
        return Err(crate::error::Error::usage(format!(
            "--nx {nx} --ny {ny}: between 1 and 10⁶ elements"
        )));
    }
    let text = crate::twin::benchmark::shell_plate_toml(nx, ny, nx as f64 * 0.1, ny as f64 * 0.1);
    crate::sinks::atomic::write_bytes_atomically(out, text.as_bytes())
}

/// Environment variable naming the Python interpreter `quaketwin fleet` runs
/// (default `python3`).
pub const PYTHON_ENV: &str = "QUAKETWIN_PYTHON";

/// `quaketwin fleet PIPELINE EVENT… --out URL [--scheduler ADDRESS]`: hands
/// over to the Python package's fleet runner (`python3 -m quaketwin.fleet`),
/// which maps the events over a Dask cluster (docs/python.md).  Its exit
/// status is this command's: 1 when an event failed (listed in
/// `OUT/fleet_runs`), 2 for usage errors.
pub fn fleet(
    pipeline: &Path,
    events: &[String],
    out: &str,
    scheduler: Option<&str>,
    quiet: bool,
) -> Result<()> {
    let python = std::env::var(PYTHON_ENV).unwrap_or_else(|_| "python3".into());
    let missing = |why: String| {
        crate::error::Error::usage(format!(
            "quaketwin fleet runs the Python package with {python} ({PYTHON_ENV}): {why}; install it with `pip install '.[fleet]'` (docs/python.md)"
        ))
    };
    let found = std::process::Command::new(&python)
        .args([
            "-c",
            "import importlib.util as u, sys; sys.exit(0 if u.find_spec('quaketwin') and u.find_spec('distributed') else 3)",
        ])
        .status()
        .map_err(|e| missing(e.to_string()))?;
    if !found.success() {
        return Err(missing(
            "the quaketwin package or dask.distributed is not installed".into(),
        ));
    }
    let mut cmd = std::process::Command::new(&python);
    cmd.args(["-m", "quaketwin.fleet"])
        .arg(pipeline)
        .args(events)
        .args(["--out", out]);
    if let Some(s) = scheduler {
        cmd.args(["--scheduler", s]);
    }
    if quiet {
        cmd.arg("--quiet");
    }
    let status = cmd.status().map_err(|e| missing(e.to_string()))?;
    match status.code() {
        Some(0) => Ok(()),
        Some(2) => Err(crate::error::Error::usage("quaketwin fleet: usage error (above)")),
        _ => Err(crate::error::Error::numerical(format!(
            "quaketwin fleet: some events failed ({status}); each failure is a row of {out}/fleet_runs/part-0.parquet"
        ))),
    }
}

/// `quaketwin rehearse DESIGN_OUT --out DIR`: the hybrid test of a design run rehearsed
/// (docs/test-design.md); `settings` a TOML file of the `rehearse` stage's params, `scheme`
/// and `time_scales` override it.
pub fn rehearse(
    design_out: &Path,
    out: &Path,
    settings: Option<&Path>,
    scheme: Option<&str>,
    time_scales: Option<Vec<f64>>,
) -> Result<crate::stages::rehearse::RehearsalSummary> {
    use crate::error::Error;
    let mut s: crate::rehearse::RehearseSettings = match settings {
        None => Default::default(),
        Some(p) => {
            let text = crate::input_file::read_to_string(p, crate::input_file::MAX_SETTINGS_BYTES)?;
            toml::from_str(&text).map_err(|e| {
                Error::usage(format!("{}: bad rehearsal settings: {e}", p.display()))
            })?
        }
    };
    if let Some(name) = scheme {
        s.scheme = match name {
            "alpha-os" => crate::rehearse::Scheme::AlphaOs,
            "central-difference" => crate::rehearse::Scheme::CentralDifference,
            other => {
                return Err(Error::usage(format!(
                    "--scheme {other}: expected alpha-os or central-difference"
                )))
            }
        };
    }
    if let Some(l) = time_scales {
        s.time_scales = l;
    }
    crate::stages::rehearse::rehearse_design_output(design_out, &s, out)
}

/// `quaketwin compare-test DESIGN_OUT TEST_RECORDS --out DIR` (docs/lab-tests.md).
pub fn compare_test(
    design_out: &Path,
    test_records: &Path,
    out: &Path,
    settings: Option<&Path>,
    time_scale: Option<f64>,
    max_lag_s: f64,
    update_specimen: bool,
) -> Result<crate::stages::compare_test::CompareTestSummary> {
    use crate::error::Error;
    if let Some(l) = time_scale.filter(|l| !(*l > 0.0 && l.is_finite())) {
        return Err(Error::usage(format!("--time-scale {l}: must be positive")));
    }
    let most = crate::rehearse::actuator::MAX_DELAY_S;
    if !(max_lag_s > 0.0 && max_lag_s <= most) {
        return Err(Error::usage(format!(
            "--max-lag {max_lag_s}: must lie in (0, {most}] s"
        )));
    }
    let rehearsal = crate::stages::compare_test::rehearsal_settings(design_out, settings)?;
    rehearsal.check("rehearsal settings")?;
    let s = crate::hybrid_test::CompareSettings {
        rehearsal,
        time_scale,
        max_lag_s,
        update_specimen,
    };
    crate::stages::compare_test::compare_test(design_out, test_records, out, s)
}

/// The flags of `quaketwin synth-hybrid-log`.
#[derive(Debug, Clone, Default)]
pub struct HybridLogFlags {
    pub settings: Option<std::path::PathBuf>,
    pub time_scale: Option<f64>,
    pub substeps: Option<usize>,
    pub duration_s: Option<f64>,
    pub delay_s: Option<f64>,
    pub bandwidth_hz: Option<f64>,
    pub noise_m: Option<f64>,
    pub force_noise_n: Option<f64>,
    pub seed: Option<u64>,
}

/// `quaketwin synth-hybrid-log DESIGN_OUT --out DIR`.
pub fn synth_hybrid_log(
    design_out: &Path,
    out: &Path,
    f: &HybridLogFlags,
) -> Result<(
    crate::synth::hybrid_log::HybridLogTruth,
    Vec<std::path::PathBuf>,
)> {
    use crate::error::Error;
    let mut s = crate::synth::hybrid_log::HybridLogSettings::default();
    if let Some(p) = &f.settings {
        let text = crate::input_file::read_to_string(p, crate::input_file::MAX_SETTINGS_BYTES)?;
        s.test = toml::from_str(&text)
            .map_err(|e| Error::usage(format!("{}: bad test settings: {e}", p.display())))?;
    }
    s.time_scale = f.time_scale;
    s.substeps = f.substeps;
    s.duration_s = f.duration_s;
    let t = &mut s.test;
    t.delay_s = f.delay_s.unwrap_or(t.delay_s);
    t.bandwidth_hz = f.bandwidth_hz.or(t.bandwidth_hz);
    t.displacement_noise_m = f.noise_m.unwrap_or(t.displacement_noise_m);
    t.force_noise_n = f.force_noise_n.unwrap_or(t.force_noise_n);
    t.seed = f.seed.unwrap_or(t.seed);
    // Flags named in errors: the settings' keys are these flags' values.
    t.check("synth-hybrid-log flags (--delay, --bandwidth, --noise, --force-noise)")?;
    crate::stages::compare_test::write_synth_hybrid_log(design_out, out, &s)
}

/// Expands the EVENT arguments: a folder with no manifest whose
/// sub-folders each hold an `event.toml` is a folder of event folders.
pub fn expand_events(events: &[std::path::PathBuf]) -> Vec<std::path::PathBuf> {
    let subfolders = |e: &Path| -> Vec<std::path::PathBuf> {
        let mut subs: Vec<_> = std::fs::read_dir(e)
            .map(|rd| {
                rd.flatten()
                    .map(|d| d.path())
                    .filter(|p| p.is_dir())
                    .collect()
            })
            .unwrap_or_default();
        subs.sort();
        subs
    };
    let mut out = Vec::new();
    for e in events {
        let subs = if e.is_dir() && !e.join(crate::event_folder::MANIFEST_NAME).exists() {
            subfolders(e)
        } else {
            Vec::new()
        };
        // A folder of event folders: every subfolder is an event (it has a
        // manifest, or records of its own as the networks publish them, with
        // no manifest), and the folder itself holds no record.
        // Subfolders named after the levels of one structure ("Ground
        // Floor", "1st Floor", "Roof") are that structure's sensors, not
        // events of their own.
        let is_collection = !subs.is_empty()
            && !holds_records(e)
            && !subs.iter().any(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .and_then(crate::event_folder::structure::place_from_text)
                    .is_some()
            })
            && subs
                .iter()
                .all(|p| p.join(crate::event_folder::MANIFEST_NAME).exists() || holds_records(p));
        if is_collection {
            out.extend(subs);
        } else {
            out.push(e.clone());
        }
    }
    out
}

/// Whether `dir` holds, at its top level, a zip or a file the readers
/// classify as a record (from its name and first bytes).
fn holds_records(dir: &Path) -> bool {
    use std::io::Read as _;
    let Ok(rd) = std::fs::read_dir(dir) else {
        return false;
    };
    rd.flatten()
        .map(|d| d.path())
        .filter(|p| p.is_file())
        .any(|p| {
            let name = p
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            if name.to_ascii_lowercase().ends_with(".zip") {
                return true;
            }
            let mut head = Vec::new();
            let read = crate::input_file::open(&p).is_ok_and(|f| {
                f.take(crate::readers::SNIFF_BYTES as u64)
                    .read_to_end(&mut head)
                    .is_ok()
            });
            read && crate::readers::sniff(&name, &head).is_some()
        })
}

/// The Hive partition of one event, `structure=<name>/event=<name>`
/// ([`pipeline::dataset::event_partition`]).
pub fn event_partition(event: &Path) -> Result<std::path::PathBuf> {
    pipeline::dataset::event_partition(event)
}

/// One event of a many-event run: where it ran and how it ended.
#[derive(Debug)]
pub struct EventRun {
    pub event: std::path::PathBuf,
    /// Its run directory `DIR/runs/structure=…/event=…/` (`None` when the
    /// event could not be read far enough to name its partition).
    pub run_dir: Option<std::path::PathBuf>,
    pub result: Result<Vec<(String, StageOutcome)>>,
}

/// `quaketwin run PIPELINE EVENT1 EVENT2 … --out DIR`: events in parallel on
/// all cores, each into its run directory `DIR/runs/structure=…/event=…/`,
/// its tables then published table-first, `DIR/tables/<table>/structure=…/event=…/
/// part-0.parquet` ([`pipeline::dataset`]), so that one table of a whole network reads
/// as one dataset (pyarrow, DuckDB, polars).  Every event is attempted; each
/// one's result is returned, in the order given.  On a terminal each event
/// running shows its own bar (its stage lines with `-v`), and a line when it
/// ends.
pub fn run_many(
    pipeline_path: &Path,
    events: &[std::path::PathBuf],
    out: &Path,
    quiet: bool,
) -> Result<Vec<EventRun>> {
    run_many_with(pipeline_path, events, out, None, quiet)
}

/// [`run_many`] with `--reference` (the same earlier run for every event).
pub fn run_many_with(
    pipeline_path: &Path,
    events: &[std::path::PathBuf],
    out: &Path,
    reference: Option<&Path>,
    quiet: bool,
) -> Result<Vec<EventRun>> {
    use rayon::prelude::*;
    let p = load_run_pipeline(pipeline_path, out, reference)?;
    let name = &p.pipeline.name;
    let runs: Vec<EventRun> = events
        .par_iter()
        .map(|e| {
            let run = pipeline::dataset::add_event(&p, e, out, quiet);
            if !quiet {
                match &run.result {
                    Ok(_) => crate::console::info(format!("[{name}] {} done", e.display())),
                    Err(err) => {
                        crate::console::info(format!("[{name}] {} failed: {err}", e.display()))
                    }
                }
            }
            EventRun {
                event: e.clone(),
                run_dir: run.run_dir,
                result: run.result,
            }
        })
        .collect();
    Ok(runs)
}

/// The runs of `quaketwin run PIPELINE EVENT… --out DIR` ([`run_events`]).
#[derive(Debug)]
pub enum Runs {
    /// One event given, and it is one event: run into `out` itself.
    One {
        event: std::path::PathBuf,
        result: Result<Vec<(String, StageOutcome)>>,
    },
    /// Several events, or a folder of events: the many-event dataset at
    /// `out` ([`run_many_with`]).
    Many(Vec<EventRun>),
}

/// `quaketwin run PIPELINE EVENT… --out DIR` (and Python's
/// `quaketwin.run`): one event runs into `out`; several events, or a folder
/// of events ([`expand_events`]), run into the many-event dataset at `out`.
pub fn run_events(
    pipeline_path: &Path,
    event: &[std::path::PathBuf],
    out: &Path,
    reference: Option<&Path>,
    quiet: bool,
) -> Result<Runs> {
    let events = expand_events(event);
    if event.len() == 1 && events.len() == 1 && events[0] == event[0] {
        let result = run_pipeline_with(pipeline_path, &events[0], out, reference, quiet);
        return Ok(Runs::One {
            event: events[0].clone(),
            result,
        });
    }
    run_many_with(pipeline_path, &events, out, reference, quiet).map(Runs::Many)
}

impl Runs {
    /// The `--json` document: the run summary of the one event, or
    /// `{summary_version, dataset, events: [run summary…]}`.
    pub fn summary_json(&self, pipeline_label: &str, out: &Path) -> Result<String> {
        use crate::summary::{to_json, RunSummary, SUMMARY_VERSION};
        match self {
            Runs::One { event, result } => {
                to_json(&RunSummary::of_run(pipeline_label, event, out, result))
            }
            Runs::Many(runs) => {
                let summaries: Vec<RunSummary> = runs
                    .iter()
                    .map(|r| {
                        let dir = r.run_dir.clone().unwrap_or_else(|| out.to_path_buf());
                        RunSummary::of_run(pipeline_label, &r.event, &dir, &r.result)
                    })
                    .collect();
                to_json(&serde_json::json!({
                    "summary_version": SUMMARY_VERSION,
                    "dataset": out,
                    "events": summaries,
                }))
            }
        }
    }

    /// The error of the one event, or of the first event that failed.
    pub fn into_result(self) -> Result<()> {
        match self {
            Runs::One { result, .. } => result.map(|_| ()),
            Runs::Many(runs) => match runs.into_iter().find(|r| r.result.is_err()) {
                Some(failed) => failed.result.map(|_| ()),
                None => Ok(()),
            },
        }
    }
}

/// `quaketwin track ARCHIVE --out DIR …`: continuous monitoring from an SDS
/// archive ([`crate::track`]).
pub fn track(opts: &crate::track::TrackOptions) -> Result<crate::track::TrackSummary> {
    crate::track::run(opts).map(|(summary, _)| summary)
}

/// `quaketwin history DATASET [--structure ID] --out DIR`: the structure
/// history of a many-event dataset ([`crate::dataset_history`]).
pub fn history(
    opts: &crate::dataset_history::HistoryOptions,
) -> Result<crate::dataset_history::HistorySummary> {
    crate::dataset_history::run(opts)
}

/// `quaketwin synth-archive --out DIR …`: the synthetic monitoring archive
/// ([`crate::synth::archive`]).
pub fn synth_archive(
    out: &Path,
    days: usize,
    channels: usize,
    rate_hz: f64,
    seed: u64,
    day_length: &str,
    damage_day: usize,
) -> Result<crate::synth::archive::ArchiveWritten> {
    let day_ns = crate::monitor::window::parse_duration("--day-length", day_length)?;
    let defaults = crate::synth::archive::ArchiveSettings::default();
    let settings = crate::synth::archive::ArchiveSettings {
        days,
        channels,
        rate_hz,
        seed,
        day_length_s: day_ns as f64 / 1e9,
        // Day N (1-based) starts after N − 1 days; 0: no damage at all.
        damage_day: damage_day.saturating_sub(1),
        damage_factor: if damage_day == 0 {
            1.0
        } else {
            defaults.damage_factor
        },
        ..defaults
    };
    crate::synth::archive::write_archive(out, &settings)
}

/// `quaketwin watch INBOX --pipeline P --out DATASET …`: unattended intake
/// ([`crate::watch`]).
pub fn watch(opts: &crate::watch::WatchOptions) -> Result<crate::watch::WatchSummary> {
    crate::watch::run(opts)
}

/// `quaketwin dashboard DATASET --out SITE`: the fleet's static site
/// ([`crate::dashboard`]).
pub fn dashboard(dataset: &Path, site: &Path) -> Result<crate::dashboard::SiteWritten> {
    crate::dashboard::write_site(dataset, site)
}
