//! The log of a pseudo-dynamic or real-time hybrid test (docs/lab-tests.md, "Comparing a hybrid
//! test with its rehearsal"): per integration step and actuator the commanded and the measured
//! displacement and the measured restoring force, as the test's controller writes them. Text in,
//! text out (no file access: the caller reads and writes).
//!
//! CSV, one row per step and actuator, a header naming the columns (any order; lines starting
//! with `#` and blank lines are skipped):
//!
//! | column | unit | required |
//! |---|---|---|
//! | `step` | | yes: integration step, 0, 1, 2, … (0: the state the test starts from) |
//! | `time_s` | s | yes: simulation (prototype) time of the step |
//! | `lab_time_s` | s | no: laboratory time (λ × simulation time in a PsD test) |
//! | `actuator` | | yes: the design's 1-based actuator number |
//! | `command_m` or `command_mm` | m, mm | yes: commanded displacement |
//! | `measured_m` or `measured_mm` | m, mm | yes: measured displacement |
//! | `force_n` or `force_kn` | N, kN | yes: measured restoring force |
//! | `response_m` or `response_mm` | m, mm | no: the simulation's displacement of the actuated DoF relative to the base (seismic part) |
//!
//! Every value is checked: an error names the file, the line and the column.

use std::collections::BTreeMap;

use crate::error::{Error, Location, Result};

/// The name of the log inside a TEST_RECORDS folder.
pub const LOG_FILE: &str = "hybrid_log.csv";

/// A hybrid test's log, by actuator (`[actuator][step]`), SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct HybridLog {
    /// Where it came from (errors and table metadata name it).
    pub source: String,
    /// The design's actuator numbers, ascending.
    pub actuators: Vec<usize>,
    /// Simulation time of each step (s).
    pub time_s: Vec<f64>,
    /// Laboratory time of each step (s), when logged.
    pub lab_time_s: Option<Vec<f64>>,
    pub command_m: Vec<Vec<f64>>,
    pub measured_m: Vec<Vec<f64>>,
    pub force_n: Vec<Vec<f64>>,
    pub response_m: Option<Vec<Vec<f64>>>,
}

/// A quantity's accepted column names and their factor to SI.
const COMMAND: &[(&str, f64)] = &[("command_m", 1.0), ("command_mm", 1e-3)];
const MEASURED: &[(&str, f64)] = &[("measured_m", 1.0), ("measured_mm", 1e-3)];
const FORCE: &[(&str, f64)] = &[("force_n", 1.0), ("force_kn", 1e3)];
const RESPONSE: &[(&str, f64)] = &[("response_m", 1.0), ("response_mm", 1e-3)];

/// One parsed row: step, actuator, time, lab time, command, measured, force, response.
type Row = (usize, usize, [f64; 6]);

impl HybridLog {
    pub fn steps(&self) -> usize {
        self.time_s.len()
    }

    /// The simulation step Δt (s): uniform, checked at parse.
    pub fn dt_s(&self) -> f64 {
        if self.time_s.len() < 2 {
            return 0.0;
        }
        (self.time_s[self.time_s.len() - 1] - self.time_s[0]) / (self.time_s.len() - 1) as f64
    }

    /// λ = laboratory time / simulation time per step, when the laboratory time is logged.
    pub fn time_scale(&self) -> Option<f64> {
        let lab = self.lab_time_s.as_ref()?;
        let n = lab.len();
        (n >= 2).then(|| (lab[n - 1] - lab[0]) / (self.time_s[n - 1] - self.time_s[0]))
    }

    /// Parses the CSV text of a log; `source` names it in errors.
    pub fn parse_csv(text: &str, source: &str) -> Result<HybridLog> {
        let at = |line: usize| Location::file(source).at_line(line);
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim()))
            .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
        let (header_line, header) = lines.next().ok_or_else(|| {
            Error::input(Location::file(source), "empty hybrid-test log: no header")
        })?;
        let names: Vec<&str> = header.split(',').map(|s| s.trim()).collect();
        let find = |name: &str| names.iter().position(|n| n.eq_ignore_ascii_case(name));
        let required = |name: &str| {
            find(name).ok_or_else(|| {
                Error::input(
                    at(header_line),
                    format!("missing column `{name}` (header: {header})"),
                )
            })
        };
        let quantity = |choices: &[(&str, f64)], needed: bool| -> Result<Option<(usize, f64)>> {
            let found: Vec<(usize, f64)> = choices
                .iter()
                .filter_map(|(n, f)| find(n).map(|i| (i, *f)))
                .collect();
            let list = choices
                .iter()
                .map(|(n, _)| format!("`{n}`"))
                .collect::<Vec<_>>()
                .join(" or ");
            match found.len() {
                0 if needed => Err(Error::input(
                    at(header_line),
                    format!("missing column {list} (header: {header})"),
                )),
                0 => Ok(None),
                1 => Ok(Some(found[0])),
                _ => Err(Error::input(
                    at(header_line),
                    format!("give one of {list}, not several"),
                )),
            }
        };
        let step_col = required("step")?;
        let actuator_col = required("actuator")?;
        let time_col = required("time_s")?;
        let lab_col = find("lab_time_s");
        let cols = [
            quantity(COMMAND, true)?,
            quantity(MEASURED, true)?,
            quantity(FORCE, true)?,
            quantity(RESPONSE, false)?,
        ];
        let mut rows: Vec<Row> = Vec::new();
        for (line, l) in lines {
            let fields: Vec<&str> = l.split(',').map(|s| s.trim()).collect();
            if fields.len() != names.len() {
                return Err(Error::input(
                    at(line),
                    format!("{} fields, the header has {}", fields.len(), names.len()),
                ));
            }
            let number = |i: usize| -> Result<f64> {
                let v: f64 = fields[i].parse().map_err(|_| {
                    Error::input(
                        at(line),
                        format!("column `{}`: `{}` is not a number", names[i], fields[i]),
                    )
                })?;
                if !v.is_finite() {
                    return Err(Error::input(
                        at(line),
                        format!("column `{}`: `{}` is not finite", names[i], fields[i]),
                    ));
                }
                Ok(v)
            };
            let index = |i: usize, what: &str| -> Result<usize> {
                fields[i].parse::<usize>().map_err(|_| {
                    Error::input(
                        at(line),
                        format!("column `{}`: `{}` is not {what}", names[i], fields[i]),
                    )
                })
            };
            let step = index(step_col, "a step number (0, 1, 2, …)")?;
            let actuator = index(actuator_col, "an actuator number (1, 2, …)")?;
            if actuator == 0 {
                return Err(Error::input(
                    at(line),
                    "column `actuator`: numbers start at 1",
                ));
            }
            let mut v = [number(time_col)?, f64::NAN, 0.0, 0.0, 0.0, f64::NAN];
            if let Some(i) = lab_col {
                v[1] = number(i)?;
            }
            for (k, c) in cols.iter().enumerate() {
                if let Some((i, factor)) = c {
                    v[2 + k] = number(*i)? * factor;
                }
            }
            rows.push((step, actuator, v));
        }
        Self::assemble(rows, source, lab_col.is_some(), cols[3].is_some())
    }

    /// Rows → per-actuator histories, checking that every actuator has every step once and
    /// that the times agree and advance uniformly.
    fn assemble(rows: Vec<Row>, source: &str, lab: bool, response: bool) -> Result<HybridLog> {
        let bad = |m: String| Err(Error::input(Location::file(source), m));
        let mut by: BTreeMap<usize, BTreeMap<usize, [f64; 6]>> = BTreeMap::new();
        for (step, a, v) in rows {
            if by.entry(a).or_default().insert(step, v).is_some() {
                return bad(format!("actuator {a} has step {step} twice"));
            }
        }
        let Some((first_actuator, first)) = by.iter().next() else {
            return bad("no data rows".into());
        };
        let n = first.len();
        for (a, steps) in &by {
            if steps.len() != n {
                return bad(format!(
                    "mismatched lengths: actuator {a} has {} steps, actuator {first_actuator} {n}",
                    steps.len()
                ));
            }
            if let Some((k, s)) = steps.keys().enumerate().find(|(k, s)| *k != **s) {
                return bad(format!(
                    "actuator {a}: steps must run 0, 1, 2, … without gaps; step {k} is missing (next logged: {s})"
                ));
            }
        }
        if n < 3 {
            return bad(format!("{n} steps: a log needs at least 3"));
        }
        let time: Vec<f64> = first.values().map(|v| v[0]).collect();
        let lab_time: Vec<f64> = first.values().map(|v| v[1]).collect();
        for (a, steps) in &by {
            if let Some((k, _)) = steps
                .values()
                .enumerate()
                .find(|(k, v)| v[0] != time[*k] || (lab && v[1] != lab_time[*k]))
            {
                return bad(format!(
                    "step {k}: actuator {a}'s time differs from actuator {first_actuator}'s"
                ));
            }
        }
        for (name, t) in [("time_s", &time), ("lab_time_s", &lab_time)] {
            if name == "lab_time_s" && !lab {
                continue;
            }
            let dt = (t[n - 1] - t[0]) / (n - 1) as f64;
            if dt.is_nan() || dt <= 0.0 {
                return bad(format!("`{name}` must increase"));
            }
            if let Some(k) = (1..n).find(|&k| {
                ((t[k] - t[k - 1]) - dt).abs() > 1e-6 * dt.max(1e-12) + 1e-9 * t[k].abs()
            }) {
                return bad(format!(
                    "`{name}` must advance by a constant step: step {k} is {} s after step {}, the mean step {dt} s",
                    t[k] - t[k - 1],
                    k - 1
                ));
            }
        }
        let column = |j: usize| -> Vec<Vec<f64>> {
            by.values()
                .map(|s| s.values().map(|v| v[j]).collect())
                .collect()
        };
        Ok(HybridLog {
            source: source.to_string(),
            actuators: by.keys().copied().collect(),
            lab_time_s: lab.then_some(lab_time),
            time_s: time,
            command_m: column(2),
            measured_m: column(3),
            force_n: column(4),
            response_m: response.then(|| column(5)),
        })
    }

    /// The log as CSV (SI columns, values in Rust's shortest round-trip form).
    pub fn to_csv(&self) -> String {
        let mut out = String::from("step,time_s");
        if self.lab_time_s.is_some() {
            out.push_str(",lab_time_s");
        }
        out.push_str(",actuator,command_m,measured_m,force_n");
        if self.response_m.is_some() {
            out.push_str(",response_m");
        }
        out.push('\n');
        for k in 0..self.steps() {
            for (i, a) in self.actuators.iter().enumerate() {
                out.push_str(&format!("{k},{}", self.time_s[k]));
                if let Some(l) = &self.lab_time_s {
                    out.push_str(&format!(",{}", l[k]));
                }
                out.push_str(&format!(
                    ",{a},{},{},{}",
                    self.command_m[i][k], self.measured_m[i][k], self.force_n[i][k]
                ));
                if let Some(r) = &self.response_m {
                    out.push_str(&format!(",{}", r[i][k]));
                }
                out.push('\n');
            }
        }
        out
    }
}
