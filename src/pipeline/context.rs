//! The run context: the event (the run's source), the output directory, and
//! the products of the stages that have run, handed to later stages along
//! the routes declared by their `inputs`.

use std::path::{Path, PathBuf};

use std::sync::Arc;

use super::config::Pipeline;
use super::stage::{Product, ProductKind};
use crate::conditioning::event_window::{cut_to_window, envelope, event_window, EventWindow};
use crate::error::{Error, Result};
use crate::event_folder::{LoadedEvent, ReferencedFiles};
use crate::vocab::{Event, Record, SampleStore};

/// Environment variable overriding [`super::spill::PARK_ABOVE_SAMPLES`]
/// (the tests set it to 0 to run the parked paths on small events).
pub const PARK_ABOVE_ENV: &str = "QUAKETWIN_PARK_ABOVE_SAMPLES";

pub struct RunContext<'p> {
    pub event_path: PathBuf,
    pub out_dir: PathBuf,
    /// How the run shows its progress (quiet, or an event's label).
    pub progress: super::Progress,
    /// Files the event refers to (twin, design file), read from a zipped event too.
    pub referenced: ReferencedFiles,
    pipeline: &'p Pipeline,
    /// Index of the stage being run.
    current: usize,
    event: Option<LoadedEvent>,
    /// The event window of a continuous event (found as the event is loaded).
    window: Option<EventWindow>,
    /// Product of each stage (by index), once it ran or was restored.
    products: Vec<Option<Product>>,
    /// Events with more samples than this are parked in the spill file.
    park_above: usize,
    /// The spill file, once an event was big enough to need it.
    spill: Option<Arc<dyn SampleStore>>,
}

impl<'p> RunContext<'p> {
    pub fn new(pipeline: &'p Pipeline, event_path: &Path, out_dir: &Path, quiet: bool) -> Self {
        RunContext {
            event_path: event_path.to_path_buf(),
            out_dir: out_dir.to_path_buf(),
            progress: super::Progress { quiet, label: None },
            referenced: ReferencedFiles::new(event_path),
            pipeline,
            current: 0,
            event: None,
            window: None,
            products: (0..pipeline.stages.len()).map(|_| None).collect(),
            park_above: std::env::var(PARK_ABOVE_ENV)
                .ok()
                .and_then(|v| v.trim().parse().ok())
                .unwrap_or(super::spill::PARK_ABOVE_SAMPLES),
            spill: None,
        }
    }

    /// A stage's progress line: shown by default for a one-event run, with
    /// `-v` (labelled) in a many-event run, never when the run is quiet.
    pub fn info(&self, line: impl std::fmt::Display) {
        self.progress.line(line);
    }

    /// Uses `loaded` as the run's event instead of reading `event_path`
    /// (an event built in memory).
    pub fn with_loaded_event(mut self, loaded: LoadedEvent) -> Self {
        let envelopes: Vec<_> = loaded
            .event
            .records
            .iter()
            .filter_map(|r| record_envelope(r))
            .collect();
        self.window = event_window(&envelopes);
        self.event = Some(loaded);
        self
    }

    /// The event window when the event is a continuous record
    /// (`conditioning::event_window`), `None` for a triggered one.
    pub fn event_window(&mut self) -> Result<Option<EventWindow>> {
        self.loaded_event()?;
        Ok(self.window.clone())
    }

    /// The event the analyses run on: the loaded event, cut to its event
    /// window when it is a continuous record (parked samples as views: nothing
    /// is read or copied).
    pub fn analysis_event(&mut self) -> Result<Event> {
        let window = self.event_window()?;
        let event = &self.loaded_event()?.event;
        Ok(match &window {
            Some(w) => cut_to_window(event, w),
            None => event.clone(),
        })
    }

    /// Runs stage `index` alone (no manifest, no fingerprint: the pipeline's
    /// `run` does those) and keeps its product for later stages.
    pub fn run_stage(&mut self, index: usize) -> Result<()> {
        let pipeline = self.pipeline;
        let stage = pipeline
            .stages
            .get(index)
            .ok_or_else(|| Error::usage(format!("the pipeline has no stage number {index}")))?;
        self.enter(index);
        let product = stage.stage.run(self)?;
        self.set_product(product);
        Ok(())
    }

    /// Makes stage `index` the one whose routes `input` follows.
    pub(super) fn enter(&mut self, index: usize) {
        self.current = index;
    }

    /// Stores the product of the current stage.
    pub(super) fn set_product(&mut self, product: Option<Product>) {
        self.products[self.current] = product;
    }

    /// The event as read from the event folder (or zip), loaded on first use.
    /// A big event (more samples than the park threshold, [`PARK_ABOVE_ENV`])
    /// has its samples parked in the run's spill file: stages read them a
    /// channel at a time.
    pub fn loaded_event(&mut self) -> Result<&LoadedEvent> {
        if self.event.is_none() {
            // Records are parked as they are read once the event is past the
            // threshold; those read before, and what the building geometry
            // formed or read back (floor motions), are parked at the end.
            let (threshold, out_dir) = (self.park_above, self.out_dir.clone());
            let mut spill: Option<Arc<dyn SampleStore>> = self.spill.clone();
            let mut total = 0usize;
            let mut envelopes = Vec::new();
            let mut loaded = crate::event_folder::load_parking(
                &self.event_path,
                &Default::default(),
                &mut |r| {
                    // Each record's envelope as it is read (before it is parked).
                    envelopes.extend(record_envelope(r));
                    total += r.samples.len();
                    if total <= threshold {
                        return Ok(());
                    }
                    if spill.is_none() {
                        spill = Some(super::spill::SpillFile::create(&out_dir)?);
                    }
                    match &spill {
                        Some(s) => park(&mut r.samples, s),
                        None => Ok(()),
                    }
                },
            )?;
            self.spill = spill;
            self.window = event_window(&envelopes);
            if let Some(s) = &self.spill {
                for r in loaded.event.records.iter_mut() {
                    park(&mut r.samples, s)?;
                }
            }
            self.event = Some(loaded);
        }
        Ok(self.event.as_ref().expect("just set")) // ok: set above
    }

    /// The run's spill file, when the event is parked (stages park what they
    /// produce there too); `None` for an event held in memory.
    pub fn parked(&self) -> Option<Arc<dyn SampleStore>> {
        self.spill.clone()
    }

    /// The spill file when `samples` (what a stage produces) are more than
    /// the park threshold, `None` otherwise — even when the event is parked:
    /// a continuous event's window is small beside the records, and parking
    /// it would only grow the spill file.
    pub fn spill_for(&mut self, samples: usize) -> Result<Option<Arc<dyn SampleStore>>> {
        if samples > self.park_above {
            self.spill().map(Some)
        } else {
            Ok(None)
        }
    }

    /// The spill file when `samples` (of an event or a product read back)
    /// are more than the park threshold, or when the event is parked.
    pub fn spill_above(&mut self, samples: usize) -> Result<Option<Arc<dyn SampleStore>>> {
        if samples > self.park_above {
            self.spill().map(Some)
        } else {
            Ok(self.spill.clone())
        }
    }

    /// The spill file, created on first use.
    fn spill(&mut self) -> Result<Arc<dyn SampleStore>> {
        if self.spill.is_none() {
            self.spill = Some(super::spill::SpillFile::create(&self.out_dir)?);
        }
        Ok(self.spill.clone().expect("just set")) // ok: set above
    }

    /// The product `kind` of the current stage's input that provides it (the
    /// route fixed when the pipeline file was read).  A provider skipped as
    /// up to date restores it from its outputs on first use.
    pub fn input<T: 'static>(&mut self, kind: ProductKind) -> Result<&T> {
        let pipeline = self.pipeline;
        let me = &pipeline.stages[self.current];
        let Some(&(_, from)) = me.routes.iter().find(|(k, _)| *k == kind) else {
            return Err(Error::usage(format!(
                "stage {:?} asked for {}, which it does not declare among the products it needs",
                me.decl.name,
                kind.describe()
            )));
        };
        if self.products[from].is_none() {
            let provider = &pipeline.stages[from];
            let current = self.current;
            self.current = from;
            let restored = provider.stage.restore(self);
            self.current = current;
            self.products[from] = restored?;
        }
        self.products[from]
            .as_ref()
            .and_then(|p| p.downcast_ref::<T>())
            .ok_or_else(|| {
                Error::usage(format!(
                    "stage {:?}: stage {:?} provided no {}",
                    me.decl.name,
                    pipeline.stages[from].decl.name,
                    kind.describe()
                ))
            })
    }
}

/// Parks `samples` in `store`; an error names the store.
pub fn park(samples: &mut crate::vocab::Samples, store: &Arc<dyn SampleStore>) -> Result<()> {
    samples.park(store).map_err(|e| {
        Error::output(
            std::path::Path::new(&store.describe()),
            format!("parking samples: {e}"),
        )
    })
}

/// The envelope of a record as read, for its event window (records in
/// memory only: a parked record's was taken as it was read).
fn record_envelope(r: &Record) -> Option<crate::conditioning::event_window::Envelope> {
    if r.samples.is_parked() {
        return None;
    }
    envelope(&r.samples, r.channel.sampling_rate_hz, r.channel.start_ns)
}
