//! Helpers shared by the text-format readers (COSMOS, CSMIP/DMG, SMC, AT2,
//! GeoNet): line access with 1-based line numbers for error messages,
//! Fortran-style number parsing (fixed-width fields that may touch, `D`
//! exponents, leading-dot reals), unit words and civil-time fragments.
//!
//! Written by hand because these are tiny, format-specific rules (Fortran
//! edit descriptors such as `8F10.5` applied to lines that may be truncated
//! or padded); no crate reads Fortran formatted records from memory.

use super::FileContents;
use crate::error::{Error, Location, Result};
use crate::vocab::{epoch_ns_from_civil, SourceRef, Units};

/// Largest file the fixed-format text readers take (COSMOS, CSMIP/DMG,
/// SMC, AT2, GeoNet), bytes: a day of one channel at 200 Hz in COSMOS is
/// ≈ 170 MB; a larger "record" is something else, and its lines would cost
/// memory several times its size.  It also keeps every line offset in a
/// `u32` ([`Lines`]).
pub const MAX_TEXT_RECORD_BYTES: usize = 256 << 20;

/// The lines of a text file, `\r` stripped, with helpers that build errors
/// naming the file, member and 1-based line.  Lines are kept as the byte
/// offsets where they start (4 bytes a line, not the 16 of a slice: a
/// 300 MB file of short lines held 400 MB of slices).
pub(crate) struct Lines<'a> {
    text: &'a str,
    /// Start of each line, and one past the end of the last (`len + 1` entries).
    starts: Vec<u32>,
    source: &'a SourceRef,
}

impl<'a> Lines<'a> {
    /// The lines of `text` (at most [`MAX_TEXT_RECORD_BYTES`]: [`decode`]
    /// refuses more; a longer text is cut there rather than overflow).
    pub fn new(text: &'a str, source: &'a SourceRef) -> Self {
        let mut end = text.len().min(MAX_TEXT_RECORD_BYTES);
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        let text = &text[..end];
        // Counted first: sized once, not doubled (a doubling vector of
        // 25 M offsets held twice its size at its last growth).
        let mut starts: Vec<u32> = Vec::with_capacity(newline_offsets(text).count() + 2);
        starts.push(0);
        starts.extend(newline_offsets(text).map(|i| (i + 1) as u32));
        // After a final newline the last start (the text's end) closes the
        // last line; without one, a start one past the end closes it.
        if !text.is_empty() && !text.ends_with('\n') {
            starts.push(text.len() as u32 + 1);
        }
        Lines {
            text,
            starts,
            source,
        }
    }
    /// Characters of text in all lines (an upper bound on what a block can hold).
    pub fn text_len(&self) -> usize {
        self.text.len()
    }
    pub fn len(&self) -> usize {
        self.starts.len() - 1
    }
    /// Line `i` (0-based), `""` past the end.
    pub fn get(&self, i: usize) -> &'a str {
        if i + 1 >= self.starts.len() {
            return "";
        }
        let (from, to) = (self.starts[i] as usize, self.starts[i + 1] as usize - 1);
        let line = &self.text[from..to.min(self.text.len())];
        line.strip_suffix('\r').unwrap_or(line)
    }
    pub fn exists(&self, i: usize) -> bool {
        i < self.len()
    }
    pub fn location(&self) -> Location {
        super::location(self.source)
    }
    /// Error at 0-based line `i` (reported 1-based).
    pub fn err(&self, i: usize, message: impl Into<String>) -> Error {
        Error::input(self.location().at_line(i + 1), message)
    }
    /// Error at 0-based line `i` for a channel.
    /// The file (and zip member) the lines come from.
    pub fn source(&self) -> &SourceRef {
        self.source
    }

    pub fn err_ch(&self, i: usize, channel: &str, message: impl Into<String>) -> Error {
        Error::input(
            self.location().with_channel(channel).at_line(i + 1),
            message,
        )
    }
    /// Error about the file as a whole.
    pub fn err_file(&self, message: impl Into<String>) -> Error {
        Error::input(self.location(), message)
    }
}

/// Reader of the channel block that starts at a 0-based line: adds what it reads to the
/// contents and returns the 0-based line after the block.
pub(crate) type ChannelBlockReader =
    fn(&Lines, usize, &SourceRef, &mut FileContents) -> Result<usize>;

/// Reads a text file made of consecutive channel blocks (COSMOS, CSMIP/DMG, GeoNet): blank
/// lines between blocks are skipped and `read_channel` reads each block.  A file without any
/// block is the error `empty_message`, naming the file.
pub(crate) fn read_channel_blocks(
    bytes: &[u8],
    source: &SourceRef,
    empty_message: &str,
    read_channel: ChannelBlockReader,
) -> Result<FileContents> {
    let text = decode(bytes, source)?;
    let lines = Lines::new(&text, source);
    let mut contents = FileContents::default();
    let mut b = 0;
    let mut blocks = 0;
    while b < lines.len() {
        if lines.get(b).trim().is_empty() {
            b += 1;
            continue;
        }
        b = read_channel(&lines, b, source, &mut contents)?;
        blocks += 1;
    }
    if blocks == 0 {
        return Err(lines.err_file(empty_message));
    }
    Ok(contents)
}

/// Byte offsets of the newlines of `text`.
fn newline_offsets(text: &str) -> impl Iterator<Item = usize> + '_ {
    text.bytes()
        .enumerate()
        .filter(|&(_, b)| b == b'\n')
        .map(|(i, _)| i)
}

/// Decodes file bytes as text: UTF-8 when valid (borrowed, not copied),
/// otherwise Latin-1 (old strong-motion files are 7-bit ASCII, but degree
/// signs and the like occur).  A DOS end-of-file byte (Ctrl-Z, 0x1A) and
/// anything after it is dropped: old CDMG files are padded with them.  A
/// file above [`MAX_TEXT_RECORD_BYTES`] is an error naming it.
pub(crate) fn decode<'b>(bytes: &'b [u8], source: &SourceRef) -> Result<std::borrow::Cow<'b, str>> {
    let end = bytes.iter().position(|&b| b == 0x1a).unwrap_or(bytes.len());
    let bytes = &bytes[..end];
    if bytes.len() > MAX_TEXT_RECORD_BYTES {
        return Err(Error::input(
            super::location(source),
            format!(
                "{} bytes of text: more than the {MAX_TEXT_RECORD_BYTES} bytes a record of this format can hold (a day of one channel at 200 Hz is ≈ 170 MB)",
                bytes.len()
            ),
        ));
    }
    Ok(match std::str::from_utf8(bytes) {
        Ok(s) => std::borrow::Cow::Borrowed(s),
        Err(_) => std::borrow::Cow::Owned(bytes.iter().map(|&b| b as char).collect()),
    })
}

/// Why a field is not a usable number.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NumError {
    NotANumber,
    NonFinite,
}

/// Parses one Fortran numeric field: surrounding blanks, `D`/`d` exponents,
/// leading-dot reals (`-.8075668E-03`), and the exponent-without-letter form
/// Fortran writes for three-digit exponents (`1.234-105`).
pub fn parse_number(field: &str) -> Result<f64, NumError> {
    let t = field.trim();
    if t.is_empty() {
        return Err(NumError::NotANumber);
    }
    // Fortran ignores blanks inside a numeric field (`.302E 00` is 0.302).
    let normalised: String = t
        .chars()
        .filter(|c| !c.is_whitespace())
        .map(|c| if c == 'D' || c == 'd' { 'E' } else { c })
        .collect();
    let value = match normalised.parse::<f64>() {
        Ok(v) => v,
        Err(_) => {
            // `1.234-105` → `1.234E-105`: a sign after a digit with no exponent letter.
            let b = normalised.as_bytes();
            let pos = (1..b.len()).find(|&i| {
                matches!(b[i], b'+' | b'-') && (b[i - 1].is_ascii_digit() || b[i - 1] == b'.')
            });
            match pos {
                Some(i) if !normalised.contains(['E', 'e']) => {
                    let fixed = format!("{}E{}", &normalised[..i], &normalised[i..]);
                    fixed.parse::<f64>().map_err(|_| NumError::NotANumber)?
                }
                _ => return Err(NumError::NotANumber),
            }
        }
    };
    // Rust accepts "inf", "NaN": data files must not smuggle them in.
    if !value.is_finite()
        || t.chars()
            .any(|c| c.is_ascii_alphabetic() && !matches!(c, 'E' | 'e' | 'D' | 'd'))
    {
        return Err(NumError::NonFinite);
    }
    Ok(value)
}

/// Parses an integer field (Fortran `I` descriptor): blanks around digits.
pub(crate) fn parse_int(field: &str) -> Option<i64> {
    field.trim().parse::<i64>().ok()
}

/// Splits a free-format line into number tokens: whitespace separates, and
/// a sign directly after a digit or a dot starts a new number (values that
/// touch, as in `-1.234E-02-5.678E-03` or `0.00630-0.00128`).
pub fn split_free(line: &str) -> Vec<&str> {
    let mut out = Vec::new();
    for token in line.split_whitespace() {
        let b = token.as_bytes();
        let mut start = 0;
        for i in 1..b.len() {
            if matches!(b[i], b'+' | b'-') && (b[i - 1].is_ascii_digit() || b[i - 1] == b'.') {
                out.push(&token[start..i]);
                start = i;
            }
        }
        out.push(&token[start..]);
    }
    out
}

/// Fixed-width fields of a line (Fortran `nFw.d`): `width` characters each,
/// at most `per_line`; trailing blank fields (a short last line) are dropped.
/// Works on characters, not bytes, so a stray non-ASCII byte cannot split a
/// character.
pub(crate) fn fixed_fields(line: &str, width: usize, per_line: usize) -> Vec<String> {
    let chars: Vec<char> = line.trim_end().chars().collect();
    let mut out = Vec::new();
    if width == 0 {
        return out;
    }
    let mut i = 0;
    while i < chars.len() && out.len() < per_line.max(1) {
        let end = (i + width).min(chars.len());
        out.push(chars[i..end].iter().collect::<String>());
        i = end;
    }
    // Anything beyond `per_line` fields is reported as one more (bad) field.
    if i < chars.len() {
        out.push(chars[i..].iter().collect::<String>());
    }
    while out.last().is_some_and(|f| f.trim().is_empty()) {
        out.pop();
    }
    out
}

/// How the values of a data block are laid out on their lines.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Layout {
    /// Fortran `per_line` F/E fields of `width` characters.
    Fixed { per_line: usize, width: usize },
    /// Whitespace-separated (touching values split at signs).
    Free,
}

impl Layout {
    /// Parses a Fortran format such as `(8F10.5)`, `(1E15.6)`, `(1I8)`,
    /// `8f10.6`, `(10I8)`, `(5E15.7)`: `(count, width)`.
    pub fn from_fortran(spec: &str) -> Option<Layout> {
        let s = spec
            .trim()
            .trim_start_matches('(')
            .trim_end_matches(')')
            .trim()
            .to_ascii_uppercase();
        let letter = s.find(['F', 'E', 'I', 'G', 'D'])?;
        let count: usize = if letter == 0 {
            1
        } else {
            s[..letter].trim().parse().ok()?
        };
        let rest = &s[letter + 1..];
        let width_str: String = rest.chars().take_while(|c| c.is_ascii_digit()).collect();
        let width: usize = width_str.parse().ok()?;
        (count > 0 && width > 0).then_some(Layout::Fixed {
            per_line: count,
            width,
        })
    }
}

/// Parses the numbers of one data line.  Fixed layouts cut fields by column;
/// if a field is not numeric the line is retried as free format (writers do
/// not always respect the declared widths), and only if that fails too is
/// the value reported bad.
pub fn line_values(line: &str, layout: Layout) -> Result<Vec<f64>, (String, NumError)> {
    let parse_free = |line: &str| -> Result<Vec<f64>, (String, NumError)> {
        split_free(line)
            .into_iter()
            .map(|t| parse_number(t).map_err(|e| (t.to_string(), e)))
            .collect()
    };
    match layout {
        Layout::Free => parse_free(line),
        Layout::Fixed { per_line, width } => {
            let fields = fixed_fields(line, width, per_line);
            let fixed: Result<Vec<f64>, (String, NumError)> = fields
                .iter()
                .map(|f| parse_number(f).map_err(|e| (f.trim().to_string(), e)))
                .collect();
            match fixed {
                Ok(v) if v.len() <= per_line => Ok(v),
                Ok(_) => parse_free(line),
                Err(first) => match parse_free(line) {
                    Ok(v) => Ok(v),
                    Err(e) if e.1 == NumError::NonFinite => Err(e),
                    Err(_) => Err(first),
                },
            }
        }
    }
}

/// A data block read from consecutive lines.
#[derive(Debug)]
pub(crate) struct Block {
    pub values: Vec<f64>,
    /// 0-based index of the first line after the block.
    pub next_line: usize,
    /// Values found on the block's last line beyond the requested count.
    pub extra_on_last_line: usize,
}

/// Reads `count` numbers starting at 0-based line `start` (blank lines
/// skipped).  Errors name the line: a non-numeric or non-finite value, a
/// text line inside the block, or the end of the file before `count`
/// values (truncated file).
pub(crate) fn read_block(
    lines: &Lines,
    start: usize,
    count: usize,
    layout: Layout,
    channel: &str,
) -> Result<Block> {
    // `count` comes from a header: reserve no more than the text can hold
    // (a value takes at least two characters with its separator), so a
    // header claiming 10¹² values fails at the end of the file, not in the
    // allocator.
    let mut values = Vec::with_capacity(count.min(lines.text_len() / 2 + 1));
    let mut i = start;
    let mut extra = 0;
    while values.len() < count {
        if !lines.exists(i) {
            let last = i.saturating_sub(1);
            return Err(lines.err_ch(
                last,
                channel,
                format!("file ends after {} of the {count} values the header declares (truncated file?)", values.len()),
            ));
        }
        let line = lines.get(i);
        if line.trim().is_empty() {
            i += 1;
            continue;
        }
        let got = line_values(line, layout).map_err(|(field, e)| match e {
            NumError::NonFinite => lines.err_ch(i, channel, format!("non-finite value {field:?} in the data")),
            NumError::NotANumber => lines.err_ch(
                i,
                channel,
                format!(
                    "non-numeric value {field:?} after {} of the {count} values the header declares",
                    values.len()
                ),
            ),
        })?;
        let need = count - values.len();
        if got.len() > need {
            extra = got.len() - need;
        }
        values.extend(got.into_iter().take(need));
        i += 1;
    }
    Ok(Block {
        values,
        next_line: i,
        extra_on_last_line: extra,
    })
}

/// `(0-based line index, number of values read up to and including it)`.
pub(crate) type LineMark = (usize, usize);

/// Every number from 0-based line `start` to the end of the file (blank
/// lines skipped), with, for each line read, `(line index, values so far)`
/// so callers can name the line where a count went wrong.
pub(crate) fn read_to_end(
    lines: &Lines,
    start: usize,
    layout: Layout,
    channel: &str,
) -> Result<(Vec<f64>, Vec<LineMark>)> {
    let mut values = Vec::new();
    let mut marks = Vec::new();
    for i in start..lines.len() {
        let line = lines.get(i);
        if line.trim().is_empty() {
            continue;
        }
        let got = line_values(line, layout).map_err(|(field, e)| match e {
            NumError::NonFinite => lines.err_ch(
                i,
                channel,
                format!("non-finite value {field:?} in the data"),
            ),
            NumError::NotANumber => lines.err_ch(
                i,
                channel,
                format!("non-numeric value {field:?} in the data"),
            ),
        })?;
        values.extend(got);
        marks.push((i, values.len()));
    }
    Ok((values, marks))
}

/// The 0-based line holding value number `k` (0-based), from `read_to_end` marks.
pub(crate) fn line_of_value(marks: &[LineMark], k: usize) -> Option<usize> {
    marks.iter().find(|&&(_, upto)| upto > k).map(|&(i, _)| i)
}

/// True when a line holds only numbers (free format): data, not a header.
pub(crate) fn is_numeric_line(line: &str) -> bool {
    let t = line.trim();
    !t.is_empty() && split_free(t).iter().all(|f| parse_number(f).is_ok())
}

/// Maps a units word from a header to `Units` (`CM/SEC/SEC`, `cm/sec2`,
/// `(g)`, `G`, `mm/s/s`, `counts(50)`, `gal`…).
pub fn units_from_text(s: &str) -> Result<Units, String> {
    let mut t = s
        .trim()
        .trim_end_matches(['.', ',', ';', ':'])
        .trim()
        .to_string();
    // `(g)` → `g`; `counts(50)` → `counts`.
    if t.starts_with('(') && t.ends_with(')') && t.len() >= 2 {
        t = t[1..t.len() - 1].to_string();
    }
    if let Some(p) = t.find('(') {
        if p > 0 {
            t.truncate(p);
        }
    }
    t.trim().parse::<Units>()
}

/// Civil UTC time from a US-style date `m/d/yy` (or `m/d/yyyy`) and a time
/// `h:m:s.f` in a named zone (`UTC`, `GMT`, `UT`, `PDT`, `PST`).  Two-digit
/// years below 30 are 20yy (CSMIP records start in 1933).  `None` when a part
/// is missing or the zone is unknown.
pub fn us_datetime_ns(date: &str, time: &str, zone: &str) -> Option<i64> {
    let mut dp = date.trim().split('/');
    let month: u32 = dp.next()?.trim().parse().ok()?;
    let day: u32 = dp.next()?.trim().parse().ok()?;
    let year_raw: i64 = dp.next()?.trim().parse().ok()?;
    let year = match year_raw {
        0..=29 => 2000 + year_raw,
        30..=99 => 1900 + year_raw,
        y => y,
    };
    let (h, m, s) = hms(time)?;
    let offset_h: i64 = match zone.trim().to_ascii_uppercase().as_str() {
        "UTC" | "GMT" | "UT" | "Z" => 0,
        "PDT" => 7,
        "PST" => 8,
        _ => return None,
    };
    epoch_ns_from_civil(year, month, day, h, m, s)?.checked_add(offset_h * 3_600_000_000_000)
}

/// Parses `hh:mm:ss.f`, tolerating blanks inside fields (`15:26: 1.0`).
pub(crate) fn hms(time: &str) -> Option<(u32, u32, f64)> {
    let mut tp = time.trim().split(':');
    let h: u32 = tp.next()?.trim().parse().ok()?;
    let m: u32 = tp.next()?.trim().parse().ok()?;
    let s: f64 = tp
        .next()
        .map(|x| x.trim())
        .filter(|x| !x.is_empty())
        .unwrap_or("0")
        .parse()
        .ok()?;
    Some((h, m, s))
}

/// First number (free format) found after `key` in `line`
/// (e.g. `number_after("DT= .0050 SEC", "DT=")`).
pub(crate) fn number_after(line: &str, key: &str) -> Option<f64> {
    let upper = line.to_ascii_uppercase();
    let p = upper.find(&key.to_ascii_uppercase())? + key.len();
    let rest = &line[p..];
    let token: String = rest
        .trim_start()
        .chars()
        .take_while(|c| c.is_ascii_digit() || matches!(c, '.' | '-' | '+' | 'E' | 'e'))
        .collect();
    // A sentence may end right after the number (`DAMPING = .05.`, `.0050 SEC`
    // leaves no letter but `5.0E` of `5.0 EQ` would): trim such tails.
    let token = token.trim_end_matches(['E', 'e', '+', '-']);
    parse_number(token)
        .ok()
        .or_else(|| parse_number(token.strip_suffix('.')?).ok())
}

/// Latitude/longitude written `32.773N`, `115.448W`: signed decimal degrees.
pub fn signed_degrees(s: &str) -> Option<f64> {
    let t = s.trim().trim_end_matches(',');
    // The hemisphere letter is the last character (a damaged file may end
    // the field in a multi-byte one: split at a character boundary).
    let hemi = t.chars().last()?;
    let num = &t[..t.len() - hemi.len_utf8()];
    let v: f64 = num.trim().parse().ok()?;
    match hemi.to_ascii_uppercase() {
        'N' | 'E' => Some(v),
        'S' | 'W' => Some(-v),
        _ => None,
    }
}

/// `<tag=value>` and `<tag>value` fields of a header or comment line (SMC
/// comment lines `|<loclbl=Roof>`, COSMOS `|<SCNL>BMR.BNZ.AK.--`), read
/// leniently: any case (tags are returned lower-case), anywhere in the line,
/// spaces around `=` allowed.  For `<tag>value` the value runs to the next
/// `<` or the end of the line; empty values are left out.
pub fn angle_tags(line: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(open) = rest.find('<') {
        let after = &rest[open + 1..];
        let Some(close) = after.find('>') else { break };
        let inside = &after[..close];
        let tail = &after[close + 1..];
        let (tag, value) = match inside.split_once('=') {
            Some((t, v)) => (t.trim(), v.trim().to_string()),
            None => {
                let end = tail.find('<').unwrap_or(tail.len());
                (inside.trim(), tail[..end].trim().to_string())
            }
        };
        let tag_ok = !tag.is_empty()
            && tag
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
        if tag_ok && !value.is_empty() {
            out.push((tag.to_ascii_lowercase(), value));
        }
        rest = tail;
    }
    out
}
