//! Post-earthquake report: turns a pipeline output directory into one
//! self-contained HTML page (`report.html`) — inline CSS, inline SVG charts,
//! no scripts, no network.
//!
//! Every number shown comes from the Parquet/JSON outputs in the directory
//! (read back with the Arrow reader); nothing is recomputed from records.
//! In a pipeline output directory only the files its run manifest
//! (`run.json`) lists are read: a stray file is treated as absent.
//! The only derived quantities are display choices: ratings (threshold
//! comparisons of tabled values), maxima/final values of tabled series,
//! relative changes of tabled before/after values, and decimation of traces
//! (min–max per time bin) and loops (in time order) for drawing.  Each
//! section is always shown; when its stage did not run the section says
//! which file is absent.  The page opens with the rating and a one-screen
//! summary; the raw processing history is in the appendix.
//! Rating thresholds and their rationale: docs/report.md.

pub mod history;
mod html;
pub mod plot;
pub use plot::decimate_curve;
mod sections;
pub use sections::assessment::{
    badge as rating_badge, read_assessment, AssessmentView, IndicatorView,
};
pub use sections::page_head_with_script;
pub mod table;
pub mod tracking;

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

pub use html::{column_heading, escape, format_number, natural_cmp, whole_table};
/// Public only for its test (tests/it/report.rs): the levels of a loop's
/// segment label, either dash.
#[doc(hidden)]
pub use sections::segment_levels;

/// Green/yellow/red limits of one criterion: value < `yellow` is green,
/// `yellow` ≤ value < `red` is yellow, value ≥ `red` is red.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Thresholds {
    pub yellow: f64,
    pub red: f64,
}

impl Thresholds {
    /// Rating of `value`; `None` for a non-finite value (not rated).
    pub fn rate(&self, value: f64) -> Option<Rating> {
        if !value.is_finite() {
            None
        } else if value >= self.red {
            Some(Rating::Red)
        } else if value >= self.yellow {
            Some(Rating::Yellow)
        } else {
            Some(Rating::Green)
        }
    }
}

/// Which value of ι(t) is rated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum IotaStatistic {
    /// ι at the end of the record (the residual, post-event state).
    #[default]
    Final,
    /// max over time of ι(t) (conservative: includes recoverable excursions).
    Peak,
}

impl IotaStatistic {
    /// "final" or "peak", as the report's notes and criteria name it.
    pub fn name(self) -> &'static str {
        match self {
            IotaStatistic::Final => "final",
            IotaStatistic::Peak => "peak",
        }
    }
}

/// Settings of the report (TOML/JSON with defaults for every field).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReportSettings {
    /// Page title; default: "quaketwin report — <event name>".
    pub title: Option<String>,
    /// Report date the title block states (free text, e.g. "2026-12-01");
    /// default: `SOURCE_DATE_EPOCH` when set, else today (UTC).
    pub date: Option<String>,
    /// Damage index ι: green < 0.02 ≤ yellow < 0.05 ≤ red.
    pub iota: Thresholds,
    /// Which value of ι(t) is rated (default: final).
    pub iota_statistic: IotaStatistic,
    /// Peak inter-storey drift ratio: green < 0.005 ≤ yellow < 0.015 ≤ red.
    pub drift: Thresholds,
    /// Residual inter-storey drift ratio (rated where resolved, |D| ≥ 2σ):
    /// green < 0.002 ≤ yellow < 0.005 ≤ red.
    pub residual_drift: Thresholds,
    /// Most points drawn per trace (min–max decimation beyond).
    pub max_points_per_trace: usize,
    /// Most points drawn per force–drift loop (`plot::decimate_curve`).
    pub max_points_per_loop: usize,
    /// Most rows shown of a generic table.
    pub max_table_rows: usize,
}

impl Default for ReportSettings {
    fn default() -> Self {
        ReportSettings {
            title: None,
            date: None,
            iota: Thresholds {
                yellow: 0.02,
                red: 0.05,
            },
            iota_statistic: IotaStatistic::Final,
            drift: Thresholds {
                yellow: 0.005,
                red: 0.015,
            },
            residual_drift: Thresholds {
                yellow: 0.002,
                red: 0.005,
            },
            max_points_per_trace: 2000,
            max_points_per_loop: 6000,
            max_table_rows: 200,
        }
    }
}

impl ReportSettings {
    /// Rejects thresholds that are not 0 ≤ yellow ≤ red (finite) and
    /// absurd plot sizes.
    pub fn validate(&self) -> Result<()> {
        for (name, t) in [
            ("iota", &self.iota),
            ("drift", &self.drift),
            ("residual_drift", &self.residual_drift),
        ] {
            if !(t.yellow.is_finite() && t.red.is_finite() && 0.0 <= t.yellow && t.yellow <= t.red)
            {
                return Err(Error::usage(format!(
                    "report settings: {name} thresholds must satisfy 0 ≤ yellow ≤ red (got yellow = {}, red = {})",
                    t.yellow, t.red
                )));
            }
        }
        // The page embeds every point and row: beyond these it is no longer
        // a page a browser opens.
        const MAX_POINTS: usize = 1_000_000;
        const MAX_ROWS: usize = 100_000;
        for (key, v) in [
            ("max_points_per_trace", self.max_points_per_trace),
            ("max_points_per_loop", self.max_points_per_loop),
        ] {
            if !(10..=MAX_POINTS).contains(&v) {
                return Err(Error::usage(format!(
                    "report settings: {key} = {v}: must be 10..={MAX_POINTS}"
                )));
            }
        }
        if let Some(d) = &self.date {
            if d.trim().is_empty() || d.chars().count() > 64 {
                return Err(Error::usage(
                    "report settings: date must be a short non-empty text (e.g. \"2026-12-01\")",
                ));
            }
        }
        if !(1..=MAX_ROWS).contains(&self.max_table_rows) {
            return Err(Error::usage(format!(
                "report settings: max_table_rows = {}: must be 1..={MAX_ROWS}",
                self.max_table_rows
            )));
        }
        Ok(())
    }
}

/// Traffic-light rating, ordered from best to worst.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Rating {
    Green,
    Yellow,
    Red,
}

impl Rating {
    pub fn label(&self) -> &'static str {
        match self {
            Rating::Green => "GREEN",
            Rating::Yellow => "YELLOW",
            Rating::Red => "RED",
        }
    }
    /// What the rating means for the user (stated on the page).
    pub fn meaning(&self) -> &'static str {
        match self {
            Rating::Green => "below the yellow threshold: no indication of damage",
            Rating::Yellow => "between thresholds: inspect",
            Rating::Red => {
                "at or above the red threshold: inspect urgently, restrict use until assessed"
            }
        }
    }
    fn class(&self) -> &'static str {
        match self {
            Rating::Green => "r-green",
            Rating::Yellow => "r-yellow",
            Rating::Red => "r-red",
        }
    }
    fn symbol(&self) -> &'static str {
        match self {
            Rating::Green => "✓",
            Rating::Yellow => "!",
            Rating::Red => "✕",
        }
    }
    /// Badge: colour, symbol and text label (never colour alone).
    pub(crate) fn badge(&self) -> String {
        format!(
            "<span class=\"badge {}\">{} {}</span>",
            self.class(),
            self.symbol(),
            self.label()
        )
    }
}

/// One rated value: criterion, where, the tabled value and its rating.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Assessment {
    pub criterion: String,
    pub subject: String,
    pub value: f64,
    pub rating: Rating,
    /// The file the value comes from.
    pub source: String,
    /// The value rests on an assumption that may be wrong (a drift ratio
    /// over an assumed storey height): the rating it gives is provisional.
    pub provisional: bool,
}

/// The overall rating of a run's outputs: the worst rating of every rated
/// value, and what drives it (per criterion, its largest value at that
/// rating).  `rating` is `None` when no criterion could be rated.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verdict {
    pub rating: Option<Rating>,
    pub drivers: Vec<Assessment>,
    /// The rating is provisional: a rated value rests on an assumption (an
    /// assumed storey height) and no value free of one already gives RED.
    pub provisional: bool,
    /// Every rated value, in page order.
    pub assessments: Vec<Assessment>,
}

impl Verdict {
    pub fn of(assessments: Vec<Assessment>) -> Verdict {
        let rating = assessments.iter().map(|a| a.rating).max();
        let mut drivers: Vec<Assessment> = Vec::new();
        for a in assessments.iter().filter(|a| Some(a.rating) == rating) {
            match drivers.iter_mut().find(|d| d.criterion == a.criterion) {
                Some(d) if a.value > d.value => *d = a.clone(),
                Some(_) => {}
                None => drivers.push(a.clone()),
            }
        }
        drivers.sort_by(|a, b| a.criterion.cmp(&b.criterion));
        // An assumption can move any rating but a RED that a value free of
        // assumptions gives (the worst there is).
        let firm_red = assessments
            .iter()
            .any(|a| a.rating == Rating::Red && !a.provisional);
        let provisional = assessments.iter().any(|a| a.provisional) && !firm_red;
        Verdict {
            rating,
            drivers,
            provisional,
            assessments,
        }
    }
}

/// The rating the report of `dir` opens with, without drawing the page
/// (the `--json` summaries of `run`, `hysteresis`…).
pub fn verdict(dir: &Path, settings: &ReportSettings) -> Result<Verdict> {
    settings.validate()?;
    Ok(Verdict::of(sections::assessments(dir, settings)))
}

/// Checks every file the report reads in `dir` against the run manifest
/// `dir/run.json` (docs/report.md, "Checked against run.json"): a listed
/// result whose size or XXH64 hash is not the recorded one — another
/// event's table copied in, or a file changed since the run — is an input
/// error naming the file (exit 1), so the page never shows it under this
/// event's title.  A directory without a run manifest has nothing to check
/// against (read as it is); files the manifest does not list are never read.
/// `quaketwin report DIR` calls it; the pipeline's `report` stage does not
/// need to (the run has just written or verified every output it lists).
pub fn verify_against_manifest(dir: &Path) -> Result<()> {
    use crate::pipeline::manifest;
    let m = match manifest::read(dir) {
        Ok(Some(m)) => m,
        Ok(None) => return Ok(()),
        // Nothing listed is shown (`sections::listed`); the write of the
        // page's record in the manifest reports the manifest itself.
        Err(_) => return Ok(()),
    };
    let read = sections::files_read();
    for stage in m
        .stages
        .iter()
        .filter(|s| s.state == manifest::StageState::Done)
    {
        for o in stage
            .outputs
            .iter()
            .filter(|o| read.contains(&o.file.as_str()))
        {
            let path = dir.join(&o.file);
            if std::fs::symlink_metadata(&path).is_err() {
                continue; // absent: the section says so
            }
            if let Err(why) = manifest::verify_output(dir, o)? {
                return Err(Error::input(
                    crate::error::Location::file(path.display().to_string()),
                    format!(
                        "not the file the run recorded in {} ({why}): another run's output copied in, \
                         or changed since the run; re-run the pipeline (`quaketwin run`) to rebuild it, \
                         or remove it",
                        manifest::MANIFEST_FILE
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Renders `dir/report.html`'s content.  Errors only for bad settings or a
/// missing/unreadable directory; unreadable or absent outputs are reported
/// on the page.
pub fn render_report(dir: &Path, settings: &ReportSettings) -> Result<String> {
    settings.validate()?;
    let meta = std::fs::metadata(dir).map_err(|e| Error::io(dir, e))?;
    if !meta.is_dir() {
        return Err(Error::usage(format!(
            "report: {} is not a directory (give a pipeline output directory)",
            dir.display()
        )));
    }
    Ok(sections::page(dir, settings))
}

/// The report's file name in the output directory.
pub const REPORT_FILE: &str = "report.html";

/// Writes `dir/report.html` atomically and returns its path.
pub fn write_report(dir: &Path, settings: &ReportSettings) -> Result<PathBuf> {
    let page = render_report(dir, settings)?;
    let path = dir.join(REPORT_FILE);
    crate::sinks::parquet::write_bytes_atomically(&path, page.as_bytes())?;
    Ok(path)
}
