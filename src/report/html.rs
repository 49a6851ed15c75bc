//! Small HTML building blocks: escaping, number formatting, tables, notes.

use super::table::{Column, Table};

/// Escapes text for HTML element content and attribute values.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// Human-readable number: 4 significant digits, scientific notation outside
/// [1e-3, 1e5).  The exact value goes into the cell's `data-value`.
pub fn format_number(x: f64) -> String {
    if !x.is_finite() {
        return if x.is_nan() {
            "NaN".into()
        } else if x > 0.0 {
            "∞".into()
        } else {
            "−∞".into()
        };
    }
    if x == 0.0 {
        return "0".into();
    }
    let a = x.abs();
    if (1e-3..1e5).contains(&a) {
        let digits = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
        format!("{x:.digits$}")
    } else {
        format!("{x:.3e}")
    }
}

/// A direction as every table and caption of the page writes it: the
/// building axes `X`, `Y`, `Z` (and mode labels such as `torsion`) as they
/// are, a compass azimuth `<deg>deg` — a channel whose relation to the
/// building axes is unknown — as "azimuth <deg>°".
pub fn direction_text(raw: &str) -> String {
    match raw.strip_suffix("deg") {
        Some(deg) if deg.parse::<f64>().is_ok() => format!("azimuth {deg}°"),
        _ => raw.to_string(),
    }
}

/// A stated setting (a threshold) as written: [`format_number`] without
/// trailing zeros ("0.005", not "0.005000").
pub fn short_number(x: f64) -> String {
    let s = format_number(x);
    if s.contains('.') && !s.contains('e') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// An ISO 8601 UTC time as people read it: "2026-02-01 08:00:00 UTC"
/// (fractional seconds kept only when not zero); other text as it is.
pub fn time_text(iso: &str) -> String {
    let Some(body) = iso.strip_suffix('Z') else {
        return iso.to_string();
    };
    let Some((date, time)) = body.split_once('T') else {
        return iso.to_string();
    };
    let time = match time.split_once('.') {
        Some((whole, frac)) if frac.chars().all(|c| c == '0') => whole.to_string(),
        Some((whole, frac)) => format!("{whole}.{}", frac.trim_end_matches('0')),
        None => time.to_string(),
    };
    format!("{date} {time} UTC")
}

/// A table column's heading in words: a column name of our tables
/// (`pga_m_s2`, `peak_drift_ratio`) becomes "PGA (m/s²)", "peak drift
/// ratio"; a heading already in words (no underscore) is kept.
pub fn column_heading(name: &str) -> String {
    const SPECIAL: [(&str, &str); 15] = [
        ("omega_rad_s", "ω (rad/s)"),
        ("channel_id", "channel"),
        ("pga_m_s2", "PGA (m/s²)"),
        ("pgv_m_s", "PGV (m/s)"),
        ("pgd_m", "PGD (m)"),
        ("arias_m_s", "Arias intensity (m/s)"),
        ("d5_95_s", "duration D5–95 (s)"),
        ("cav_m_s", "CAV (m/s)"),
        ("snr_db", "SNR (dB)"),
        ("qa_flags", "QA flags"),
        ("npts", "samples"),
        ("sampling_rate_hz", "sampling rate (Hz)"),
        ("storey_height_m", "height (m)"),
        ("height_source", "height from"),
        ("mpd_deg", "MPD (°)"),
    ];
    if let Some((_, w)) = SPECIAL.iter().find(|(n, _)| *n == name) {
        return w.to_string();
    }
    if !name.contains('_') || name.contains(' ') {
        return name.to_string();
    }
    const UNITS: [(&str, &str); 10] = [
        ("_m_s2", "m/s²"),
        ("_m_s", "m/s"),
        ("_n_m", "N/m"),
        ("_hz", "Hz"),
        ("_deg", "°"),
        ("_db", "dB"),
        ("_m", "m"),
        ("_s", "s"),
        ("_n", "N"),
        ("_j", "J"),
    ];
    let (stem, unit) = UNITS
        .iter()
        .find_map(|(suffix, unit)| name.strip_suffix(suffix).map(|s| (s, Some(*unit))))
        .unwrap_or((name, None));
    let words = stem.replace('_', " ");
    match unit {
        Some(u) => format!("{words} ({u})"),
        None => words,
    }
}

/// One table cell.
#[derive(Debug, Clone, Default)]
pub struct Cell {
    /// Already-escaped HTML content.
    pub html: String,
    /// Exact value (shortest round-trip decimal) for numeric cells.
    pub value: Option<f64>,
    pub class: Option<&'static str>,
}

impl Cell {
    pub fn text(s: &str) -> Cell {
        Cell {
            html: escape(s),
            ..Default::default()
        }
    }
    pub fn raw(html: String) -> Cell {
        Cell {
            html,
            ..Default::default()
        }
    }
    pub fn number(x: Option<f64>) -> Cell {
        match x {
            Some(v) => Cell {
                html: format_number(v),
                value: Some(v),
                class: Some("num"),
            },
            None => Cell {
                html: "—".into(),
                value: None,
                class: Some("null"),
            },
        }
    }
    pub fn integer(x: Option<f64>) -> Cell {
        match x {
            Some(v) if v.fract() == 0.0 && v.abs() < 9.0e15 => Cell {
                html: format!("{}", v as i64),
                value: Some(v),
                class: Some("num"),
            },
            other => Cell::number(other),
        }
    }
    /// A direction cell of a loaded table column ([`direction_text`]).
    pub fn direction(table: &Table, column: &str, row: usize) -> Cell {
        match table.key(column, row) {
            Some(d) => Cell::text(&direction_text(&d)),
            None => Cell::number(None),
        }
    }
    /// Any cell of a loaded table column.
    pub fn of(table: &Table, column: &str, row: usize) -> Cell {
        match table.columns.get(column) {
            Some(Column::Number { values, integer }) => {
                let v = values.get(row).copied().flatten();
                if *integer {
                    Cell::integer(v)
                } else {
                    Cell::number(v)
                }
            }
            Some(Column::Bool(v)) => match v.get(row).copied().flatten() {
                Some(b) => Cell::text(if b { "yes" } else { "no" }),
                None => Cell::number(None),
            },
            Some(Column::Text(v)) => match v.get(row).cloned().flatten() {
                Some(s) => Cell::text(&s),
                None => Cell::number(None),
            },
            Some(Column::TextList(v)) => match v.get(row).cloned().flatten() {
                Some(l) if l.is_empty() => Cell::text(""),
                Some(l) => Cell::raw(
                    l.iter()
                        .map(|s| format!("<span class=\"tag\">{}</span>", escape(s)))
                        .collect::<Vec<_>>()
                        .join(" "),
                ),
                None => Cell::number(None),
            },
            Some(Column::NumberList(v)) => match v.get(row).cloned().flatten() {
                Some(l) => Cell::text(&format!(
                    "[{}]",
                    l.iter()
                        .map(|x| format_number(*x))
                        .collect::<Vec<_>>()
                        .join(", ")
                )),
                None => Cell::number(None),
            },
            Some(Column::Unsupported(t)) => Cell::text(&format!("({t})")),
            None => Cell::number(None),
        }
    }
}

/// An HTML table with a header row; `id` optional.
pub fn table(id: Option<&str>, headers: &[String], rows: &[Vec<Cell>]) -> String {
    let mut s = String::new();
    match id {
        Some(id) => s.push_str(&format!("<table id=\"{}\">", escape(id))),
        None => s.push_str("<table>"),
    }
    s.push_str("<thead><tr>");
    for h in headers {
        let words = column_heading(h);
        if words == *h {
            s.push_str(&format!("<th>{}</th>", escape(h)));
        } else {
            // The column's name stays on the element (for tools and tests).
            s.push_str(&format!(
                "<th data-column=\"{}\">{}</th>",
                escape(h),
                escape(&words)
            ));
        }
    }
    s.push_str("</tr></thead><tbody>");
    for row in rows {
        s.push_str("<tr>");
        for c in row {
            s.push_str("<td");
            if let Some(class) = c.class {
                s.push_str(&format!(" class=\"{class}\""));
            }
            if let Some(v) = c.value {
                s.push_str(&format!(" data-value=\"{v}\""));
            }
            s.push('>');
            s.push_str(&c.html);
            s.push_str("</td>");
        }
        s.push_str("</tr>");
    }
    s.push_str("</tbody></table>");
    s
}

/// Every column of a table (in file order), at most `max_rows` rows.
pub fn whole_table(t: &Table, max_rows: usize) -> String {
    let headers: Vec<String> = t.names.clone();
    let rows = cells(t, &t.names, max_rows);
    let mut s = format!(
        "<div class=\"scroll\">{}</div>",
        table(None, &headers, &rows)
    );
    if t.rows > max_rows {
        s.push_str(&note(&format!("Showing {max_rows} of {} rows.", t.rows)));
    }
    s
}

/// Cells of the first `max_rows` rows of `t` in the columns `cols`.
pub fn cells(t: &Table, cols: &[String], max_rows: usize) -> Vec<Vec<Cell>> {
    (0..t.rows.min(max_rows))
        .map(|r| cols.iter().map(|c| Cell::of(t, c, r)).collect())
        .collect()
}

pub fn note(text: &str) -> String {
    format!("<p class=\"note\">{}</p>", escape(text))
}

/// The message a section shows when its stage's output is absent: the
/// output named in words (`label`), the stage that writes it.
pub fn absent(label: &str, stage: &str) -> String {
    format!(
        "<p class=\"absent\">Stage not run / output absent: {} (stage <i>{}</i>).</p>",
        escape(label),
        escape(stage)
    )
}

/// The message a section shows when a file exists but cannot be read: the
/// output in words; the file and the reason go to the appendix's table
/// checks ([`diagnostic`]).
pub fn unreadable(label: &str, file: &str, error: &str) -> String {
    diagnostic(&format!("{file}: unreadable — {error}"));
    format!(
        "<p class=\"absent\">Output unreadable: {} — the file could not be read (appendix, table checks).</p>",
        escape(label)
    )
}

thread_local! {
    /// Notes for whoever maintains the outputs (columns missing or unknown,
    /// types not the declared ones, unreadable files), gathered while a page
    /// is drawn and listed in its appendix — not in the sections a reader
    /// decides on.
    static DIAGNOSTICS: std::cell::RefCell<Vec<String>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Records a note for the appendix's table checks (once per text).
pub fn diagnostic(text: &str) {
    DIAGNOSTICS.with(|d| {
        let mut d = d.borrow_mut();
        if !d.iter().any(|x| x == text) {
            d.push(text.to_string());
        }
    });
}

/// The table checks gathered since the last call (emptied).
pub fn take_diagnostics() -> Vec<String> {
    DIAGNOSTICS.with(|d| std::mem::take(&mut *d.borrow_mut()))
}

/// Records "<file>: expected column(s) not present: …" for the appendix
/// when an `expected` column is missing; nothing on the page.
pub fn missing_columns_note(t: &Table, expected: &[&str]) -> String {
    let missing = t.missing(expected);
    if !missing.is_empty() {
        diagnostic(&format!(
            "{}: expected column(s) not present: {}.",
            t.file_name(),
            missing.join(", ")
        ));
    }
    String::new()
}

/// Records expected-but-missing and unknown columns of a table for the
/// appendix's table checks; nothing on the page.
pub fn column_notes(t: &Table, expected: &[&str]) -> String {
    let unknown = t.unknown(expected);
    missing_columns_note(t, expected);
    if !unknown.is_empty() {
        diagnostic(&format!(
            "{}: further column(s): {}.",
            t.file_name(),
            unknown.join(", ")
        ));
    }
    String::new()
}

/// Numeric-aware ordering of names (channel ids): runs of digits compare as
/// numbers, so `CE24386.02` comes before `CE24386.10`, and `F2` before `F10`;
/// ties (`01` vs `1`) and everything else by the text.
pub fn natural_cmp(a: &str, b: &str) -> std::cmp::Ordering {
    use std::cmp::Ordering;
    let (mut x, mut y) = (a.as_bytes(), b.as_bytes());
    loop {
        match (x.first(), y.first()) {
            (None, None) => return a.cmp(b),
            (None, Some(_)) => return Ordering::Less,
            (Some(_), None) => return Ordering::Greater,
            (Some(c), Some(d)) if c.is_ascii_digit() && d.is_ascii_digit() => {
                let run = |s: &[u8]| s.iter().take_while(|c| c.is_ascii_digit()).count();
                let (n, m) = (run(x), run(y));
                let strip = |s: &[u8]| {
                    let z = s.iter().take_while(|c| **c == b'0').count();
                    s[z.min(s.len().saturating_sub(1))..].to_vec()
                };
                let (p, q) = (strip(&x[..n]), strip(&y[..m]));
                let ord = p.len().cmp(&q.len()).then_with(|| p.cmp(&q));
                if ord != Ordering::Equal {
                    return ord;
                }
                x = &x[n..];
                y = &y[m..];
            }
            (Some(c), Some(d)) => {
                let ord = c.to_ascii_lowercase().cmp(&d.to_ascii_lowercase());
                if ord != Ordering::Equal {
                    return ord;
                }
                x = &x[1..];
                y = &y[1..];
            }
        }
    }
}
