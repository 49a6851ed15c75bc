use serde::{Deserialize, Serialize};

/// One processing step with its parameters, recorded so that every output can
/// say exactly what was done (METHODS §1: "each step recorded").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProcessingStep {
    /// Step name (`units_to_si`, `detrend`, `bandpass`, …).
    pub step: String,
    /// Channels it applied to (empty = all).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub channels: Vec<String>,
    /// Parameters as JSON (serde).
    pub params: serde_json::Value,
}

/// Ordered list of steps; serialised as JSON into Parquet file metadata.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ProcessingHistory {
    pub steps: Vec<ProcessingStep>,
}

impl ProcessingHistory {
    pub fn push(&mut self, step: impl Into<String>, params: serde_json::Value) {
        self.steps.push(ProcessingStep {
            step: step.into(),
            channels: Vec::new(),
            params,
        });
    }
    pub fn push_for(
        &mut self,
        step: impl Into<String>,
        channels: Vec<String>,
        params: serde_json::Value,
    ) {
        self.steps.push(ProcessingStep {
            step: step.into(),
            channels,
            params,
        });
    }
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_else(|_| "{}".into()) // ok: plain data always serialises
    }
}
