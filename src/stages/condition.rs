//! `condition`: QA and units, then the declared conditioning steps
//! (resampling/alignment, detrend, taper, zero-phase band-pass, integration;
//! METHODS §1) → `samples/samples.parquet`; with a filter whose corners come from the
//! signal-to-noise ratio (`conditioning::snr`), also `fourier/fourier.parquet`.

use crate::conditioning::event_window::EventWindow;
use crate::conditioning::{
    condition_event_each, BandType, ConditioningSettings, CornersFrom, Motion, ParkSeries, Step,
};
use crate::pipeline::context::park;
use serde::Deserialize;

use crate::error::Result;
use crate::pipeline::{Product, ProductKind, RunContext, Stage, StageKind, StageSource};
use crate::sinks::event_tables;
use crate::vocab::{Event, Samples};

pub const KIND: StageKind = StageKind {
    kind: "condition",
    needs: &[],
    provides: Some(ProductKind::ConditionedEvent),
    reads_all_earlier: false,
    build,
};

/// The conditioned records file (default; `samples_file` names another, so
/// that two condition stages — e.g. the band-passed records for modal
/// identification and the records as recorded for Bouc-Wen — can coexist).
pub const SAMPLES_FILE: &str = crate::vocab::tables::SAMPLES.file;
/// The records' Fourier spectra and chosen corners (a filter with
/// `corners_from = "snr"`).
pub const FOURIER_FILE: &str = crate::vocab::tables::FOURIER.file;

/// The stage's own params beside the conditioning settings.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OutputParams {
    samples_file: Option<String>,
    /// `"auto"` (default): the filter's high-pass corner (the low corner of
    /// a band-pass) is lowered, for this event, to the low edge of the band
    /// modal identification uses (`modal::band_low_edge_of_event`) when
    /// that lies below it — a tall building's 0.15–0.2 Hz fundamental
    /// survives; `"stated"`: the corner as written.
    high_pass: Option<String>,
}

/// The product: the conditioned event and, per acceleration channel, its
/// acceleration, velocity and displacement — parked in the run's spill file
/// when the event is (`RunContext::parked`).
pub struct Conditioned {
    pub event: Event,
    pub motions: Vec<Motion>,
}

fn build(src: &StageSource) -> Result<Box<dyn Stage>> {
    let (settings, output): (ConditioningSettings, OutputParams) =
        src.params_split(&["samples_file", "high_pass"])?;
    settings.validate().map_err(|e| src.invalid(e))?;
    // A file name (`samples_as_recorded/samples_as_recorded.parquet`), written in a folder of
    // its own like every table (`samples_as_recorded/samples_as_recorded.parquet`).
    let samples_file = match output.samples_file {
        None => SAMPLES_FILE.to_string(),
        Some(name)
            if name.ends_with(".parquet")
                && crate::pipeline::is_plain_name(&name)
                && !name.contains('/') =>
        {
            crate::vocab::schema::table_file(&name)
        }
        Some(name) => {
            return Err(src.invalid(format!(
                "samples_file {name:?} must be a .parquet file name (no folder)"
            )))
        }
    };
    let auto_high_pass = match output.high_pass.as_deref() {
        None | Some("auto") => true,
        Some("stated") => false,
        Some(other) => {
            return Err(src.invalid(format!(
                "high_pass {other:?}: expected \"auto\" or \"stated\""
            )))
        }
    };
    Ok(Box::new(Condition {
        settings,
        samples_file,
        auto_high_pass,
    }))
}

struct Condition {
    settings: ConditioningSettings,
    samples_file: String,
    auto_high_pass: bool,
}

/// `settings` with the high-pass corner of its filter lowered to the low
/// edge of `event`'s band of interest when that lies below it (`high_pass =
/// "auto"`); a note says so.  A filter choosing its corners from the SNR
/// also has its highest high-pass (`high_pass_max_hz`) lowered to that edge:
/// a noisy record never loses the band identification uses.
#[doc(hidden)] // public for tests/it/modal_buildings.rs
pub fn with_auto_high_pass(
    settings: &ConditioningSettings,
    event: &Event,
) -> Result<ConditioningSettings> {
    let mut settings = settings.clone();
    let has_high_pass = settings.steps.iter().any(|s| {
        matches!(s, Step::Filter(f) if matches!(f.band, BandType::Highpass | BandType::Bandpass))
    });
    if !has_high_pass {
        return Ok(settings);
    }
    let Some((edge, why)) = crate::modal::band_low_edge_of_event(event)? else {
        return Ok(settings);
    };
    for step in settings.steps.iter_mut() {
        if let Step::Filter(f) = step {
            if matches!(f.band, BandType::Highpass | BandType::Bandpass) && edge < f.corners_hz[0] {
                crate::console::note(format!(
                    "condition ({}): high-pass corner {} Hz lowered to {edge:.3} Hz, the low edge of the band of interest: {why}",
                    event.name, f.corners_hz[0]
                ));
                f.corners_hz[0] = edge;
            }
            if f.corners_from == CornersFrom::Snr && edge < f.high_pass_max_hz {
                f.high_pass_max_hz = edge;
            }
        }
    }
    Ok(settings)
}

/// The whole records of `loaded` in SI units, described as the records of
/// `conditioned` (its channels — units, QA — and history) are: the records
/// as recorded of a continuous event, whose analyses took its window.
/// Parked samples are scaled as they are read, nothing is copied.
fn whole_records(loaded: &Event, conditioned: &Event) -> Result<Event> {
    let mut whole = conditioned.clone();
    for r in whole.records.iter_mut() {
        let Some(source) = loaded.record(&r.channel.id) else {
            continue;
        };
        let Some(factor) = source.channel.units.to_si_factor() else {
            continue;
        };
        r.samples = source.samples.scaled(factor);
        r.channel.start_ns = source.channel.start_ns;
    }
    Ok(whole)
}

impl Stage for Condition {
    fn outputs(&self) -> Vec<String> {
        let mut files = vec![self.samples_file.clone()];
        if self.settings.snr_filter().is_some() {
            files.push(FOURIER_FILE.into());
        }
        files
    }
    /// A channel at a time: a parked event's channels are read back, conditioned
    /// and parked again one by one (issue 14 item 5).
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        // Cloning a parked event copies its channels' descriptions, not their
        // samples; a continuous record is cut to its event window.
        let mut event = ctx.analysis_event()?;
        // What this stage makes is parked when it is big (a continuous
        // event's window is not: it stays in memory).
        let produced: usize = event.records.iter().map(|r| r.samples.len()).sum();
        let spill = ctx.spill_for(produced)?;
        // A parked event's motions are parked series by series as each is
        // final (two series of a day-long channel in memory, not three).
        let park_series = |values: Vec<f64>| -> Result<Samples> {
            let mut samples = Samples::new(values);
            if let Some(spill) = &spill {
                park(&mut samples, spill)?;
            }
            Ok(samples)
        };
        let parking: Option<&ParkSeries> = spill.as_ref().map(|_| &park_series as &ParkSeries);
        let settings = if self.auto_high_pass {
            with_auto_high_pass(&self.settings, &event)?
        } else {
            self.settings.clone()
        };
        let output = condition_event_each(&mut event, &settings, parking, &|record, motion| {
            let Some(spill) = &spill else {
                return Ok(());
            };
            // An integrated record's samples are its motion's acceleration
            // (shared once parked, `conditioning::condition_event_each`).
            if let Some(m) = motion {
                park(&mut m.acceleration, spill)?;
                park(&mut m.velocity, spill)?;
                park(&mut m.displacement, spill)?;
            }
            park(&mut record.samples, spill)
        })?;
        let motions = output.motions;
        if settings.snr_filter().is_some() {
            let path = ctx.out_dir.join(FOURIER_FILE);
            crate::sinks::fourier_tables::write_fourier(&path, &event, &output.fourier)?;
        }
        let path = ctx.out_dir.join(&self.samples_file);
        match ctx.event_window()? {
            // The records as recorded of a continuous event are written
            // whole (the full-rate acceleration once), the analyses take
            // the window.
            Some(_) if self.settings.steps.is_empty() => {
                let whole = whole_records(&ctx.loaded_event()?.event, &event)?;
                event_tables::write_samples(&path, &whole, &[])?;
            }
            _ => event_tables::write_samples(&path, &event, &motions)?,
        }
        Ok(Some(Box::new(Conditioned { event, motions })))
    }
    fn restore(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let path = ctx.out_dir.join(&self.samples_file);
        // Samples read back are parked as the event's would be (by their number).
        let (mut event, motions) =
            event_tables::read_samples_parked(&path, |rows| ctx.spill_above(rows))?;
        // Whole records of a continuous event, read back: cut as the run cut them.
        if let Some(window) = EventWindow::from_history(&event.history) {
            let span_s = window.window_s[1] - window.window_s[0];
            for r in event.records.iter_mut() {
                let range = window.samples_of(r);
                let whole = r.samples.len() as f64 > span_s * r.channel.sampling_rate_hz + 1.0;
                if whole && range.len() < r.samples.len() {
                    r.samples = r.samples.window(range);
                }
            }
        }
        Ok(Some(Box::new(Conditioned { event, motions })))
    }
}
