//! `hysteresis` and `damage`: instantaneous Bouc-Wen identification per
//! horizontal direction (METHODS §4; numerical work in `crate::hysteresis`)
//! and the damage index ι(t).
//!
//! Processing is explicit and declared in the pipeline: the stage reads the
//! conditioned event of its `condition` input — in pipelines/post-earthquake.toml
//! a condition stage with no steps (QA and SI units only: band-pass filtering
//! biases N towards 1 and γ towards −β, METHODS §1); the identification
//! integrates velocities itself with the configured drift control.

use std::path::Path;

use serde::Deserialize;

use super::condition::Conditioned;
use crate::error::{Error, Result};
pub use crate::hysteresis::{
    auto_directions, DirectionSpec, MassLumping, MassResolution, ReducedMassRecord,
};
use crate::hysteresis::{
    identify_event, BasisForm, EventSettings, FrequencyBand, IdentifySettings, VelocityDrift,
};
use crate::pipeline::{Product, ProductKind, RunContext, Stage, StageKind, StageSource};
use crate::sinks::hysteresis_tables::{self as tables, DirectionOutcome};
use crate::sinks::provenance::Provenance;
use crate::vocab::Event;

pub const KIND: StageKind = StageKind {
    kind: "hysteresis",
    needs: &[ProductKind::ConditionedEvent],
    provides: Some(ProductKind::Hysteresis),
    reads_all_earlier: false,
    build,
};

pub const DAMAGE_KIND: StageKind = StageKind {
    kind: "damage",
    needs: &[ProductKind::Hysteresis],
    provides: Some(ProductKind::Damage),
    reads_all_earlier: false,
    build: build_damage,
};

pub const BOUC_WEN_FILE: &str = crate::vocab::tables::BOUC_WEN.file;
pub const INSTANTANEOUS_FILE: &str = crate::vocab::tables::BOUC_WEN_INSTANTANEOUS.file;
pub const FIT_FILE: &str = crate::vocab::tables::HYSTERESIS_FIT.file;
pub const DAMAGE_FILE: &str = crate::vocab::tables::DAMAGE.file;

/// The product: the identification of every direction.
pub struct Identification {
    pub outcomes: Vec<DirectionOutcome>,
    /// The event's provenance followed by the identification step: what the
    /// damage table, made from these outcomes, carries.
    pub provenance: Provenance,
}

/// Parameters of the `hysteresis` stage (docs/pipelines.md).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HysteresisParams {
    /// `jerk` (Eq. A7–A10, default) or `integral` (Eq. 27–30).
    pub form: BasisForm,
    /// Lower limit of the frequency integral of Eq. 20, Hz (0 = the thesis's full band).
    pub band_low_hz: f64,
    pub exponent_min: f64,
    pub exponent_max: f64,
    pub exponent_resolution: f64,
    pub instantaneous: bool,
    /// `none` (default: plain integration from rest) or `endpoint_ramp`
    /// (removes the velocity drift of a constant acceleration offset,
    /// estimated from a Hann-weighted mean over the last 10 % of the record;
    /// see `VelocityDrift::EndpointRamp`).
    pub velocity_drift: VelocityDrift,
    /// Grid step of σ in the reduced-mass search of Eq. 35–36 (≤ 0.001).
    pub reduced_mass_step: f64,
    /// Masses of uninstrumented levels: `auto`, `tributary` or `eq35_36`.
    pub mass_lumping: MassLumping,
    /// Explicit directions; default: one per horizontal direction that has a
    /// level-0 input channel and at least one floor (any levels).
    pub directions: Option<Vec<DirectionSpec>>,
    /// Keep every n-th sample in hysteresis_fit/hysteresis_fit.parquet and damage/damage.parquet.
    pub output_decimation: usize,
    /// Fail the stage when a direction cannot be identified (the CLI command
    /// does); in a pipeline the reason is written to bouc_wen/bouc_wen.parquet instead.
    pub fail_on_error: bool,
    /// The part of each record identified (`crate::hysteresis::window`).
    pub window: crate::hysteresis::WindowSettings,
}

impl Default for HysteresisParams {
    fn default() -> Self {
        let d = IdentifySettings::default();
        HysteresisParams {
            form: BasisForm::Jerk,
            band_low_hz: 0.0,
            exponent_min: d.exponent_min,
            exponent_max: d.exponent_max,
            exponent_resolution: d.exponent_resolution,
            instantaneous: true,
            velocity_drift: VelocityDrift::None,
            reduced_mass_step: 0.001,
            mass_lumping: MassLumping::Auto,
            directions: None,
            output_decimation: 1,
            fail_on_error: false,
            window: Default::default(),
        }
    }
}

impl HysteresisParams {
    pub fn identify_settings(&self) -> Result<IdentifySettings> {
        let mut s = IdentifySettings {
            exponent_min: self.exponent_min,
            exponent_max: self.exponent_max,
            exponent_resolution: self.exponent_resolution,
            instantaneous: self.instantaneous,
            ..IdentifySettings::default()
        };
        s.form = self.form;
        s.velocity_drift = self.velocity_drift;
        if !(self.band_low_hz.is_finite() && self.band_low_hz >= 0.0) {
            return Err(Error::usage(format!(
                "band_low_hz = {}: must be a frequency ≥ 0 Hz",
                self.band_low_hz
            )));
        }
        if self.band_low_hz > 0.0 {
            s.band = FrequencyBand::above(self.band_low_hz);
            s.transform = crate::hysteresis::Transform::Fft;
        }
        Ok(s)
    }

    /// The settings of the whole identification, checked
    /// (`EventSettings::validate`: the bounds' one home).
    pub fn event_settings(&self) -> Result<EventSettings> {
        let settings = EventSettings {
            identify: self.identify_settings()?,
            reduced_mass_step: self.reduced_mass_step,
            mass_lumping: self.mass_lumping,
            directions: self.directions.clone(),
            window: self.window,
            fail_on_error: self.fail_on_error,
        };
        settings.validate().map(|()| settings)
    }
}

/// Runs the identification on `event` (loaded from `event_dir`, against which
/// the manifest's twin path is resolved) for every direction; returns the
/// outcomes and, per direction with resolvable masses, which masses were used.
pub fn identify_event_at(
    event: &Event,
    event_dir: Option<&Path>,
    p: &HysteresisParams,
) -> Result<(Vec<DirectionOutcome>, Vec<MassResolution>)> {
    identify_event(event, event_dir, &p.event_settings()?)
}

/// Writes the three identification tables.
pub fn write_identification(
    dir: &std::path::Path,
    outcomes: &[DirectionOutcome],
    masses: &[MassResolution],
    p: &HysteresisParams,
    provenance: &Provenance,
) -> Result<()> {
    let settings_json = serde_json::json!({
        "form": p.form, "band_low_hz": p.band_low_hz, "exponent_min": p.exponent_min,
        "exponent_max": p.exponent_max, "exponent_resolution": p.exponent_resolution,
        "velocity_drift": p.velocity_drift, "reduced_mass_step": p.reduced_mass_step,
        "mass_lumping": p.mass_lumping, "window": p.window,
    });
    let mut meta = provenance.metadata();
    meta.extend([
        ("quaketwin.settings".to_string(), settings_json.to_string()),
        (
            "quaketwin.masses".to_string(),
            serde_json::to_string(masses).unwrap_or_default(),
        ),
    ]);
    tables::write_bouc_wen(&dir.join(BOUC_WEN_FILE), outcomes, &meta)?;
    tables::write_instantaneous(&dir.join(INSTANTANEOUS_FILE), outcomes, &meta)?;
    tables::write_fit(&dir.join(FIT_FILE), outcomes, p.output_decimation, &meta)
}

fn build(src: &StageSource) -> Result<Box<dyn Stage>> {
    let params: HysteresisParams = src.params()?;
    params.event_settings().map_err(|e| src.invalid(e))?;
    Ok(Box::new(Hysteresis { params }))
}

struct Hysteresis {
    params: HysteresisParams,
}

impl Hysteresis {
    fn identify(
        &self,
        ctx: &mut RunContext,
    ) -> Result<(Vec<DirectionOutcome>, Vec<MassResolution>, Provenance)> {
        let event_dir = ctx.event_path.clone();
        let Conditioned { event, .. } = ctx.input(ProductKind::ConditionedEvent)?;
        let (outcomes, masses) = identify_event_at(event, Some(&event_dir), &self.params)?;
        let provenance = tables::identification_provenance(event, &outcomes);
        Ok((outcomes, masses, provenance))
    }
}

impl Stage for Hysteresis {
    fn outputs(&self) -> Vec<String> {
        [BOUC_WEN_FILE, INSTANTANEOUS_FILE, FIT_FILE]
            .map(String::from)
            .to_vec()
    }
    /// Automatic directions need levels and building axes; without any (e.g. a folder without
    /// event.toml whose headers state neither) there is nothing to identify, and saying so
    /// beats writing empty tables.
    fn not_applicable(&self, ctx: &mut RunContext) -> Result<Option<String>> {
        if self.params.directions.is_some() {
            return Ok(None);
        }
        let (specs, skipped) = auto_directions(&ctx.loaded_event()?.event);
        Ok((specs.is_empty() && skipped.is_empty()).then(|| {
            "no horizontal direction has records with a known level and building axis (a base, level 0, and at least one floor): state `level` and `direction` per channel in event.toml (docs/event-folder.md)".to_string()
        }))
    }
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let (outcomes, masses, provenance) = self.identify(ctx)?;
        for m in &masses {
            ctx.info(format!("[hysteresis] {}", m.message()));
        }
        for o in &outcomes {
            if let DirectionOutcome::NotIdentifiable {
                direction, reason, ..
            } = o
            {
                ctx.info(format!(
                    "[hysteresis] direction {direction}: not identifiable: {reason}"
                ));
            }
        }
        write_identification(&ctx.out_dir, &outcomes, &masses, &self.params, &provenance)?;
        Ok(Some(Box::new(Identification {
            outcomes,
            provenance,
        })))
    }
    /// The identification is not stored in a form that can be loaded back
    /// whole: when the stage was skipped it is recomputed in memory (its
    /// outputs are not rewritten).
    fn restore(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let (outcomes, _, provenance) = self.identify(ctx)?;
        Ok(Some(Box::new(Identification {
            outcomes,
            provenance,
        })))
    }
}

/// Parameters of the `damage` stage.
#[derive(Debug, Clone, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct DamageParams {
    /// Keep every n-th time step in damage/damage.parquet (the last is always kept).
    pub output_decimation: usize,
}

fn build_damage(src: &StageSource) -> Result<Box<dyn Stage>> {
    Ok(Box::new(Damage {
        params: src.params()?,
    }))
}

struct Damage {
    params: DamageParams,
}

impl Stage for Damage {
    fn outputs(&self) -> Vec<String> {
        vec![DAMAGE_FILE.into()]
    }
    fn run(&self, ctx: &mut RunContext) -> Result<Option<Product>> {
        let out = ctx.out_dir.join(DAMAGE_FILE);
        let Identification {
            outcomes,
            provenance,
        } = ctx.input(ProductKind::Hysteresis)?;
        let decimation = self.params.output_decimation.max(1);
        let provenance = provenance.clone().then_step(
            "damage_index",
            serde_json::json!({ "output_decimation": decimation }),
        );
        tables::write_damage(&out, outcomes, decimation, &provenance.metadata())?;
        Ok(None)
    }
}
