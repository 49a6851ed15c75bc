//! Pipeline files (`pipelines/*.toml`): named stages of known kinds, their
//! parameters and the stages whose outputs they read.  A user contract,
//! documented in docs/pipelines.md.
//!
//! Reading a pipeline file builds it: every stage's `params` are
//! deserialized into the stage kind's typed parameters there and then, so a
//! misspelt key or a value of the wrong type is a usage error (exit 2) that
//! names the file, the line and the key before any event data is read; and
//! every product a stage needs is routed to the one declared input that
//! provides it.

use std::collections::HashMap;

use serde::Deserialize;
use toml::de::{DeTable, DeValue, ValueDeserializer};

use super::stage::{ProductKind, Stage, StageKind};
use crate::error::{Error, Result};

/// Largest pipeline file read, bytes (checked before it is read or parsed;
/// the bundled pipelines are 1–5 kB).
pub const MAX_PIPELINE_BYTES: u64 = 1 << 20;

/// Most stages a pipeline may declare (the bundled pipelines have up to a
/// dozen; every stage runs on every event).
pub const MAX_STAGES: usize = 256;

/// The declaration of one stage, as written in the pipeline file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageDecl {
    /// Unique name within the pipeline.
    pub name: String,
    /// Stage kind (`ingest`, `condition`, `metrics`, …: the catalog handed to the parser).
    pub kind: String,
    /// Names of earlier stages whose outputs this stage reads.
    #[serde(default)]
    pub inputs: Vec<String>,
    /// Kind-specific parameters, as written (the typed form lives in the built stage).
    #[serde(default)]
    pub params: toml::Table,
    /// A stage may be switched off without deleting it.
    #[serde(default = "yes")]
    pub enabled: bool,
}

fn yes() -> bool {
    true
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineSection {
    pub name: String,
    pub description: Option<String>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct PipelineDoc {
    pipeline: PipelineSection,
    #[serde(rename = "stage", default)]
    stages: Vec<StageDecl>,
}

/// One stage of a built pipeline: its declaration, its kind, the stage with
/// typed parameters, and where each product it needs comes from.
pub struct PlannedStage {
    pub decl: StageDecl,
    pub kind: &'static StageKind,
    pub stage: Box<dyn Stage>,
    /// (product, index of the earlier stage that provides it).
    pub routes: Vec<(ProductKind, usize)>,
}

/// A pipeline read from its file: stages built, products routed.
pub struct Pipeline {
    pub pipeline: PipelineSection,
    pub stages: Vec<PlannedStage>,
}

impl std::fmt::Debug for Pipeline {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Pipeline")
            .field("pipeline", &self.pipeline)
            .field(
                "stages",
                &self.stages.iter().map(|s| &s.decl).collect::<Vec<_>>(),
            )
            .finish()
    }
}

/// Line (1-based) of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    text[..at.min(text.len())].matches('\n').count() + 1
}

fn toml_error(file: &str, text: &str, e: &toml::de::Error, what: &str) -> Error {
    let line = e
        .span()
        .map(|s| format!(" line {}", line_of(text, s.start)))
        .unwrap_or_default();
    Error::usage(format!("{file}{line}: {what}: {}", e.message()))
}

/// The `params` value of stage `index` of the document, with its spans.
fn params_value<'i>(
    root: &toml::Spanned<DeTable<'i>>,
    index: usize,
) -> Option<toml::Spanned<DeValue<'i>>> {
    let DeValue::Array(stages) = root.get_ref().get("stage")?.get_ref() else {
        return None;
    };
    let DeValue::Table(stage) = stages.get(index)?.get_ref() else {
        return None;
    };
    stage.get("params").cloned()
}

/// Deserializes typed parameters `T` from the `params` of stage `index` of
/// the pipeline document `root` (the text parsed once, with spans); errors
/// name the file and the line of the offending key or value.  A stage
/// without `params` gets `T` from an empty table.
pub fn typed_params<T: serde::de::DeserializeOwned>(
    text: &str,
    root: &toml::Spanned<DeTable<'_>>,
    file: &str,
    index: usize,
    decl: &StageDecl,
) -> Result<T> {
    let what = format!("stage {:?} ({}): bad params", decl.name, decl.kind);
    match params_value(root, index) {
        Some(v) => T::deserialize(ValueDeserializer::from(v))
            .map_err(|e| toml_error(file, text, &e, &what)),
        None => T::deserialize(
            ValueDeserializer::parse("{}")
                .map_err(|e| Error::usage(format!("{what}: {}", e.message())))?,
        )
        .map_err(|e| Error::usage(format!("{file}: {what}: {}", e.message()))),
    }
}

fn too_many_stages(file: &str, n: usize) -> Error {
    Error::usage(format!(
        "{file}: {n} stages declared: more than the limit of {MAX_STAGES}"
    ))
}

fn too_big(file: &str, size: u64) -> Error {
    Error::usage(format!(
        "{file}: pipeline file of {size} bytes: larger than the limit of {MAX_PIPELINE_BYTES} bytes"
    ))
}

impl Pipeline {
    /// Reads and builds a pipeline with the stage kinds of `catalog`.
    pub fn parse(text: &str, file: &str, catalog: &'static [StageKind]) -> Result<Pipeline> {
        // Sizes first, before the parser holds the text many times over.
        if text.len() as u64 > MAX_PIPELINE_BYTES {
            return Err(too_big(file, text.len() as u64));
        }
        let headers = text
            .lines()
            .filter(|l| l.trim().replace(' ', "") == "[[stage]]")
            .count();
        if headers > MAX_STAGES {
            return Err(too_many_stages(file, headers));
        }
        let doc: PipelineDoc = toml::from_str(text)
            .map_err(|e| toml_error(file, text, &e, "invalid pipeline file"))?;
        if doc.stages.is_empty() {
            return Err(Error::usage(format!("{file}: no [[stage]] declared")));
        }
        if doc.stages.len() > MAX_STAGES {
            return Err(too_many_stages(file, doc.stages.len()));
        }
        // Parsed once with spans for every stage's typed params (not once per stage).
        let root = DeTable::parse(text)
            .map_err(|e| toml_error(file, text, &e, "invalid pipeline file"))?;
        let mut stages: Vec<PlannedStage> = Vec::with_capacity(doc.stages.len());
        let mut by_name: HashMap<String, usize> = HashMap::new();
        for (index, decl) in doc.stages.into_iter().enumerate() {
            if by_name.contains_key(&decl.name) {
                return Err(Error::usage(format!(
                    "{file}: stage name {:?} is used twice",
                    decl.name
                )));
            }
            let Some(kind) = catalog.iter().find(|k| k.kind == decl.kind) else {
                let known: Vec<&str> = catalog.iter().map(|k| k.kind).collect();
                return Err(Error::usage(format!(
                    "{file}: stage {:?} has unknown kind {:?} (known: {})",
                    decl.name,
                    decl.kind,
                    known.join(", ")
                )));
            };
            let mut inputs = Vec::with_capacity(decl.inputs.len());
            for i in &decl.inputs {
                match by_name.get(i) {
                    Some(&j) => inputs.push(j),
                    None => {
                        return Err(Error::usage(format!(
                            "{file}: stage {:?} reads {:?}, which is not an earlier stage",
                            decl.name, i
                        )))
                    }
                }
            }
            let routes = route(file, &decl, kind, &inputs, &stages)?;
            let stage = (kind.build)(&StageSource {
                text,
                root: &root,
                file,
                index,
                decl: &decl,
            })?;
            by_name.insert(decl.name.clone(), stages.len());
            stages.push(PlannedStage {
                decl,
                kind,
                stage,
                routes,
            });
        }
        check_outputs(file, &stages)?;
        Ok(Pipeline {
            pipeline: doc.pipeline,
            stages,
        })
    }

    /// Reads and builds the pipeline file at `path`.
    pub fn load(path: &std::path::Path, catalog: &'static [StageKind]) -> Result<Pipeline> {
        let text = Self::read_text(path)?;
        Self::parse(&text, &path.display().to_string(), catalog)
    }

    /// The text of the pipeline file at `path`, its size checked against
    /// [`MAX_PIPELINE_BYTES`] before it is read.
    pub fn read_text(path: &std::path::Path) -> Result<String> {
        crate::input_file::read_to_string_or(path, MAX_PIPELINE_BYTES, |size| {
            too_big(&path.display().to_string(), size)
        })
    }
}

/// Every output file has one stage that writes it, and is a plain file name
/// inside the output directory.
fn check_outputs(file: &str, stages: &[PlannedStage]) -> Result<()> {
    let mut seen: HashMap<String, &str> = HashMap::new();
    for s in stages {
        for o in s.stage.outputs() {
            if !super::is_plain_name(&o) {
                return Err(Error::usage(format!(
                    "{file}: stage {:?}: output {o:?} is not a plain file name inside the output directory",
                    s.decl.name
                )));
            }
            if let Some(other) = seen.get(&o) {
                return Err(Error::usage(format!(
                    "{file}: stages {other:?} and {:?} would both write {o}; give one of them another file name",
                    s.decl.name
                )));
            }
            seen.insert(o, &s.decl.name);
        }
    }
    Ok(())
}

/// For each product the stage's kind needs, the one declared input that
/// provides it (usage error when none or several do).
fn route(
    file: &str,
    decl: &StageDecl,
    kind: &StageKind,
    inputs: &[usize],
    earlier: &[PlannedStage],
) -> Result<Vec<(ProductKind, usize)>> {
    let mut routes = Vec::new();
    for &need in kind.needs {
        let providers: Vec<usize> = inputs
            .iter()
            .copied()
            .filter(|&j| earlier[j].kind.provides == Some(need))
            .collect();
        match providers.as_slice() {
            [j] => routes.push((need, *j)),
            [] => {
                return Err(Error::usage(format!(
                    "{file}: stage {:?} ({}) needs {}: list the stage that provides it in its `inputs` (a `{}` stage)",
                    decl.name,
                    decl.kind,
                    need.describe(),
                    need.provider_kind()
                )))
            }
            _ => {
                let names: Vec<&str> = providers
                    .iter()
                    .map(|&j| earlier[j].decl.name.as_str())
                    .collect();
                return Err(Error::usage(format!(
                    "{file}: stage {:?} ({}) has several inputs providing {}: {}; keep one",
                    decl.name,
                    decl.kind,
                    need.describe(),
                    names.join(", ")
                )));
            }
        }
    }
    Ok(routes)
}

/// What a stage kind's builder is given: its declaration and where it sits
/// in the pipeline text (for the line numbers of parameter errors).
pub struct StageSource<'a> {
    text: &'a str,
    /// The pipeline text parsed once, with spans.
    root: &'a toml::Spanned<DeTable<'a>>,
    file: &'a str,
    index: usize,
    pub decl: &'a StageDecl,
}

impl StageSource<'_> {
    /// The stage's typed parameters (unknown keys and wrong types refused
    /// with file and line).
    pub fn params<T: serde::de::DeserializeOwned>(&self) -> Result<T> {
        typed_params(self.text, self.root, self.file, self.index, self.decl)
    }
    /// Two typed views of the params: `K` from the keys listed in `keys`
    /// (the stage's own, e.g. an output file name) and `T` from all the
    /// others (a settings struct shared with library callers).  Both refuse
    /// unknown keys with file and line.
    pub fn params_split<T, K>(&self, keys: &[&str]) -> Result<(T, K)>
    where
        T: serde::de::DeserializeOwned,
        K: serde::de::DeserializeOwned,
    {
        let what = format!(
            "stage {:?} ({}): bad params",
            self.decl.name, self.decl.kind
        );
        let (file, text) = (self.file, self.text);
        let Some(value) = params_value(self.root, self.index) else {
            return Ok((self.params()?, self.params()?));
        };
        let DeValue::Table(table) = value.get_ref() else {
            return Ok((self.params()?, self.params()?));
        };
        let part = |own: bool| {
            let mut t = DeTable::new();
            for (k, v) in table.iter() {
                if keys.contains(&k.get_ref().as_ref()) == own {
                    t.insert(k.clone(), v.clone());
                }
            }
            ValueDeserializer::from(toml::Spanned::new(value.span(), DeValue::Table(t)))
        };
        let rest = T::deserialize(part(false)).map_err(|e| toml_error(file, text, &e, &what))?;
        let own = K::deserialize(part(true)).map_err(|e| toml_error(file, text, &e, &what))?;
        Ok((rest, own))
    }

    /// The pipeline file's name, for messages.
    pub fn file(&self) -> &str {
        self.file
    }
    /// A usage error for parameters that parse but make no sense, naming
    /// the file and stage (and the line of the stage's `params`).
    pub fn invalid(&self, e: impl std::fmt::Display) -> Error {
        let line = params_value(self.root, self.index)
            .map(|v| format!(" line {}", line_of(self.text, v.span().start)))
            .unwrap_or_default();
        Error::usage(format!(
            "{}{line}: stage {:?} ({}): bad params: {e}",
            self.file, self.decl.name, self.decl.kind
        ))
    }
}
