//! Pipeline files (`pipelines/*.toml`): named stages of known kinds, their
//! parameters and the stages whose outputs they read.  A user contract,
//! documented in docs/pipelines.md.

use serde::Deserialize;

use crate::error::{Error, Result};

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineFile {
    pub pipeline: PipelineSection,
    #[serde(rename = "stage")]
    pub stages: Vec<StageDecl>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineSection {
    pub name: String,
    pub description: Option<String>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageDecl {
    /// Unique name within the pipeline.
    pub name: String,
    /// Stage kind from the registry (`ingest`, `condition`, `metrics`, …).
    pub kind: String,
    /// Names of earlier stages whose outputs this stage reads.
    #[serde(default)]
    pub inputs: Vec<String>,
    /// Kind-specific parameters (checked by the stage).
    #[serde(default = "empty_table")]
    pub params: toml::Table,
    /// A stage may be switched off without deleting it.
    #[serde(default = "yes")]
    pub enabled: bool,
}

fn empty_table() -> toml::Table {
    toml::Table::new()
}
fn yes() -> bool {
    true
}

impl PipelineFile {
    pub fn parse(text: &str, file: &str) -> Result<PipelineFile> {
        let p: PipelineFile = toml::from_str(text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
            Error::usage(format!(
                "{file}{}: invalid pipeline file: {}",
                line.map(|l| format!(" line {l}")).unwrap_or_default(),
                e.message()
            ))
        })?;
        p.validate(file)?;
        Ok(p)
    }

    pub fn load(path: &std::path::Path) -> Result<PipelineFile> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        Self::parse(&text, &path.display().to_string())
    }

    fn validate(&self, file: &str) -> Result<()> {
        let mut seen: Vec<&str> = Vec::new();
        for s in &self.stages {
            if seen.contains(&s.name.as_str()) {
                return Err(Error::usage(format!(
                    "{file}: stage name {:?} is used twice",
                    s.name
                )));
            }
            if !super::registry::KINDS.contains(&s.kind.as_str()) {
                return Err(Error::usage(format!(
                    "{file}: stage {:?} has unknown kind {:?} (known: {})",
                    s.name,
                    s.kind,
                    super::registry::KINDS.join(", ")
                )));
            }
            for i in &s.inputs {
                if !seen.contains(&i.as_str()) {
                    return Err(Error::usage(format!(
                        "{file}: stage {:?} reads {:?}, which is not an earlier stage",
                        s.name, i
                    )));
                }
            }
            seen.push(&s.name);
        }
        if self.stages.is_empty() {
            return Err(Error::usage(format!("{file}: no [[stage]] declared")));
        }
        Ok(())
    }
}

/// Reads a typed parameter set from a stage's `params` table, refusing
/// unknown keys (the parameter structs use `deny_unknown_fields`).
pub fn params<T: serde::de::DeserializeOwned>(stage: &StageDecl) -> Result<T> {
    toml::Value::Table(stage.params.clone())
        .try_into()
        .map_err(|e: toml::de::Error| {
            Error::usage(format!(
                "stage {:?} ({}): bad params: {}",
                stage.name,
                stage.kind,
                e.message()
            ))
        })
}
