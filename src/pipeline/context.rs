//! The run context: the event (the run's source), the output directory, and
//! the products of the stages that have run, handed to later stages along
//! the routes declared by their `inputs`.

use std::path::{Path, PathBuf};

use super::config::Pipeline;
use super::stage::{Product, ProductKind};
use crate::error::{Error, Result};
use crate::event_folder::{LoadedEvent, ReferencedFiles};

pub struct RunContext<'p> {
    pub event_path: PathBuf,
    pub out_dir: PathBuf,
    pub quiet: bool,
    /// Files the event refers to (twin, design file), read from a zipped event too.
    pub referenced: ReferencedFiles,
    pipeline: &'p Pipeline,
    /// Index of the stage being run.
    current: usize,
    event: Option<LoadedEvent>,
    /// Product of each stage (by index), once it ran or was restored.
    products: Vec<Option<Product>>,
}

impl<'p> RunContext<'p> {
    pub fn new(pipeline: &'p Pipeline, event_path: &Path, out_dir: &Path, quiet: bool) -> Self {
        RunContext {
            event_path: event_path.to_path_buf(),
            out_dir: out_dir.to_path_buf(),
            quiet,
            referenced: ReferencedFiles::new(event_path),
            pipeline,
            current: 0,
            event: None,
            products: (0..pipeline.stages.len()).map(|_| None).collect(),
        }
    }

    /// Uses `loaded` as the run's event instead of reading `event_path`
    /// (an event built in memory).
    pub fn with_loaded_event(mut self, loaded: LoadedEvent) -> Self {
        self.event = Some(loaded);
        self
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
    pub fn loaded_event(&mut self) -> Result<&LoadedEvent> {
        if self.event.is_none() {
            self.event = Some(crate::event_folder::load(&self.event_path)?);
        }
        Ok(self.event.as_ref().expect("just set")) // ok: set above
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
