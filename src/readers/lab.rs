//! Readers of laboratory records (issue 37): the tables lab data
//! acquisition writes — delimited text (a header of names, optionally with
//! units as `force [kN]` or `force (kN)`; or a bare series, one value per
//! line or all on one line), JSON (`{"data": [[…], …], "columns": […],
//! "units": {…}, "dt": …}`, or named arrays `{"force": […], …}`, and the
//! layout of the ARTS-Laboratory friction-damper dataset), and MAT v5
//! ([`super::mat5`]). Values stay in the file's units: the event folder
//! applies the manifest's (or inferred) units and roles.

use crate::error::{Error, Location, Result};

/// Largest lab file read, bytes (a day of 16 channels at 1 kHz as text is
/// ~1 GB; lab tests are minutes to hours).
pub const MAX_LAB_FILE_BYTES: u64 = 1 << 30;

/// One column of a lab table.
#[derive(Debug, Clone, PartialEq)]
pub struct LabColumn {
    pub name: String,
    /// Units the file states for it.
    pub units: Option<String>,
    pub values: Vec<f64>,
}

/// A lab file's columns (equal lengths) and the time step it states.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LabTable {
    pub columns: Vec<LabColumn>,
    pub dt_s: Option<f64>,
    /// Which layout was recognised (for `inferred`).
    pub layout: String,
}

impl LabTable {
    pub fn column(&self, name: &str) -> Option<&LabColumn> {
        self.columns.iter().find(|c| c.name == name).or_else(|| {
            self.columns
                .iter()
                .find(|c| c.name.eq_ignore_ascii_case(name))
        })
    }
}

fn split_units(header: &str) -> (String, Option<String>) {
    let h = header.trim().trim_matches('"');
    for (open, close) in [('[', ']'), ('(', ')')] {
        if let (Some(a), true) = (h.rfind(open), h.ends_with(close)) {
            let units = h[a + 1..h.len() - 1].trim().to_string();
            return (
                h[..a].trim().to_string(),
                (!units.is_empty()).then_some(units),
            );
        }
    }
    (h.to_string(), None)
}

fn tokens(line: &str) -> Vec<&str> {
    let sep: &[char] = if line.contains(',') {
        &[',']
    } else if line.contains(';') {
        &[';']
    } else if line.contains('\t') {
        &['\t']
    } else {
        &[' ']
    };
    let mut t: Vec<&str> = line.split(sep).map(str::trim).collect();
    if sep == [' '] {
        t.retain(|s| !s.is_empty());
    }
    // A trailing delimiter (`1,2,3,`) is not an empty last column.
    while t.last().is_some_and(|s| s.is_empty()) {
        t.pop();
    }
    t
}

/// Delimited text: a header line of names (optional) and rows of numbers;
/// or one series (one value per line, or all values on a single line).
pub fn read_text(bytes: &[u8], location: &Location, stem: &str) -> Result<LabTable> {
    let text = std::str::from_utf8(bytes)
        .map_err(|e| Error::input(location.clone(), format!("lab text file is not UTF-8: {e}")))?;
    let lines: Vec<(usize, &str)> = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#') && !l.starts_with('%'))
        .collect();
    let Some(&(_, first)) = lines.first() else {
        return Err(Error::input(
            location.clone(),
            "lab text file holds no values",
        ));
    };
    let first_tokens = tokens(first);
    let header = first_tokens.iter().any(|t| t.parse::<f64>().is_err());
    let (names, units, rows): (Vec<String>, Vec<Option<String>>, &[(usize, &str)]) = if header {
        let (n, u) = first_tokens.iter().map(|t| split_units(t)).unzip();
        (n, u, &lines[1..])
    } else {
        (Vec::new(), Vec::new(), &lines[..])
    };
    let parse_row = |(line_no, line): &(usize, &str)| -> Result<Vec<f64>> {
        tokens(line)
            .iter()
            .map(|t| {
                t.parse::<f64>().map_err(|_| {
                    Error::input(
                        location.clone().at_line(*line_no),
                        format!("{t:?} is not a number"),
                    )
                })
            })
            .collect()
    };
    if !header && rows.len() == 1 {
        // The whole series on one line (`experimentForce.csv` of the PEER example).
        let values = parse_row(&rows[0])?;
        return Ok(LabTable {
            columns: vec![LabColumn {
                name: stem.to_string(),
                units: None,
                values,
            }],
            dt_s: None,
            layout: "one series on a single line".into(),
        });
    }
    let width = if header {
        names.len()
    } else {
        tokens(rows.first().map_or("", |r| r.1)).len()
    };
    let mut columns: Vec<Vec<f64>> = vec![Vec::with_capacity(rows.len()); width];
    for row in rows {
        let v = parse_row(row)?;
        if v.len() != width {
            return Err(Error::input(
                location.clone().at_line(row.0),
                format!("{} values where the file has {width} columns", v.len()),
            ));
        }
        for (c, x) in columns.iter_mut().zip(v) {
            c.push(x);
        }
    }
    let names = if header {
        names
    } else if width == 1 {
        vec![stem.to_string()]
    } else {
        (0..width).map(|i| i.to_string()).collect()
    };
    let units = if header { units } else { vec![None; width] };
    Ok(LabTable {
        columns: names
            .into_iter()
            .zip(units)
            .zip(columns)
            .map(|((name, units), values)| LabColumn {
                name,
                units,
                values,
            })
            .collect(),
        dt_s: None,
        layout: if header {
            "delimited text with a header".into()
        } else if width == 1 {
            "one value per line".into()
        } else {
            "delimited text without a header (columns named by index)".into()
        },
    })
}

/// The column layout of the ARTS-Laboratory friction-damper JSON files
/// (Coble et al. 2022, repository README): recognised by its unit keys.
const ARTS_COLUMNS: [(&str, &str); 6] = [
    ("time", "time units"),
    ("displacement", "displacement units"),
    ("friction_force", "friction force units"),
    ("velocity", ""),
    ("actuator_force_1", "actuator force units"),
    ("actuator_force_2", "actuator force units"),
];

/// JSON lab files (see the module's documentation).
pub fn read_json(bytes: &[u8], location: &Location) -> Result<LabTable> {
    let doc: serde_json::Value = serde_json::from_slice(bytes).map_err(|e| {
        Error::input(
            location.clone(),
            format!("lab JSON file does not parse: {e}"),
        )
    })?;
    let obj = doc
        .as_object()
        .ok_or_else(|| Error::input(location.clone(), "lab JSON file is not an object"))?;
    let number = |v: &serde_json::Value, what: &str| -> Result<f64> {
        v.as_f64()
            .ok_or_else(|| Error::input(location.clone(), format!("{what}: {v} is not a number")))
    };
    let dt_s = obj.get("dt").map(|v| number(v, "dt")).transpose()?;
    let units_of = |key: &str| -> Option<String> {
        obj.get("units")
            .and_then(|u| u.get(key))
            .or_else(|| obj.get(&format!("{key} units")))
            .and_then(|u| u.as_str())
            .map(str::to_string)
    };
    if let Some(data) = obj.get("data") {
        let rows = data
            .as_array()
            .ok_or_else(|| Error::input(location.clone(), "`data` is not an array of rows"))?;
        let width = rows.first().and_then(|r| r.as_array()).map_or(0, Vec::len);
        if width == 0 {
            return Err(Error::input(
                location.clone(),
                "`data` holds no rows of numbers",
            ));
        }
        let mut columns = vec![Vec::with_capacity(rows.len()); width];
        for (i, r) in rows.iter().enumerate() {
            let r = r.as_array().filter(|r| r.len() == width).ok_or_else(|| {
                Error::input(
                    location.clone(),
                    format!("`data` row {i} is not an array of {width} numbers"),
                )
            })?;
            for (c, v) in columns.iter_mut().zip(r) {
                c.push(number(v, &format!("`data` row {i}"))?);
            }
        }
        let arts = width == ARTS_COLUMNS.len()
            && obj.contains_key("friction force units")
            && obj.contains_key("displacement units");
        let names: Vec<(String, Option<String>)> =
            if let Some(cols) = obj.get("columns").and_then(|c| c.as_array()) {
                if cols.len() != width {
                    return Err(Error::input(
                        location.clone(),
                        format!(
                            "`columns` names {} columns but the rows have {width}",
                            cols.len()
                        ),
                    ));
                }
                cols.iter()
                    .map(|c| {
                        let n = c.as_str().unwrap_or_default().to_string();
                        let u = units_of(&n);
                        (n, u)
                    })
                    .collect()
            } else if arts {
                ARTS_COLUMNS
                    .iter()
                    .map(|(n, key)| {
                        let u = if n == &"velocity" {
                            obj.get("displacement units")
                                .and_then(|u| u.as_str())
                                .map(|u| format!("{u}/s"))
                        } else {
                            obj.get(*key).and_then(|u| u.as_str()).map(str::to_string)
                        };
                        (n.to_string(), u)
                    })
                    .collect()
            } else {
                (0..width).map(|i| (i.to_string(), None)).collect()
            };
        return Ok(LabTable {
            columns: names
                .into_iter()
                .zip(columns)
                .map(|((name, units), values)| LabColumn {
                    name,
                    units,
                    values,
                })
                .collect(),
            dt_s,
            layout: if arts {
                "ARTS-Laboratory friction-damper JSON (rows: time, displacement, friction force, velocity, actuator forces 1 and 2)".into()
            } else {
                "JSON rows".into()
            },
        });
    }
    // Named arrays of numbers.
    let mut columns = Vec::new();
    for (k, v) in obj {
        if let Some(arr) = v.as_array() {
            if arr.iter().all(|x| x.is_number()) && !arr.is_empty() {
                let values = arr
                    .iter()
                    .map(|x| number(x, k))
                    .collect::<Result<Vec<_>>>()?;
                columns.push(LabColumn {
                    name: k.clone(),
                    units: units_of(k),
                    values,
                });
            }
        }
    }
    if columns.is_empty() {
        return Err(Error::input(
            location.clone(),
            "lab JSON file has neither `data` rows nor named arrays of numbers",
        ));
    }
    let n = columns[0].values.len();
    if let Some(c) = columns.iter().find(|c| c.values.len() != n) {
        return Err(Error::input(
            location.clone(),
            format!(
                "array {:?} has {} values, {:?} has {n}",
                c.name,
                c.values.len(),
                columns[0].name
            ),
        ));
    }
    Ok(LabTable {
        columns,
        dt_s,
        layout: "JSON named arrays".into(),
    })
}

/// A MAT v5/v7 file as a table: its numeric vectors (each a column; a 2-D
/// matrix gives one column per matrix column, `name(:,j)` with 1-based j).
pub fn read_mat(bytes: &[u8], location: &Location) -> Result<LabTable> {
    let mat = super::mat5::read(bytes, location)?;
    let mut columns = Vec::new();
    for a in mat.arrays {
        if a.values.is_empty() {
            continue;
        }
        if a.is_vector() {
            columns.push(LabColumn {
                name: a.name,
                units: None,
                values: a.values,
            });
        } else if a.dims.len() == 2 {
            for j in 0..a.dims[1] {
                columns.push(LabColumn {
                    name: format!("{}(:,{})", a.name, j + 1),
                    units: None,
                    values: a.column(j).unwrap_or_default().to_vec(),
                });
            }
        }
    }
    let dt_s = columns
        .iter()
        .find(|c| c.name == "dt" && c.values.len() == 1)
        .map(|c| c.values[0]);
    Ok(LabTable {
        columns,
        dt_s,
        layout: "MAT v5".into(),
    })
}
