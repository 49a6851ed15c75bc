//! Matrix Market (coordinate, real, general or symmetric) reading and writing, so models
//! assembled by other FE codes can be brought in as K(θ) = K0 + Σ θ_g K_g (see `file`), and
//! the one writer of every `.mtx` output (the test design's prototype and PS basis).
//! Hand-written: the format is a few lines of text and no maintained crate reads it into
//! faer 0.24.

use std::fmt::Write as _;
use std::path::Path;

use faer::MatRef;

use super::sparse::CscMatrix;
use crate::error::{Error, Location};
use crate::Result;

/// Parse Matrix Market text. `source` names the file in errors. Indices are 1-based in the
/// file; a `symmetric` file lists one triangle and is mirrored.
pub fn parse_matrix_market(text: &str, source: &str) -> Result<CscMatrix> {
    let loc = |line: usize| Location::file(source.to_string()).at_line(line);
    let mut lines = text.lines().enumerate();
    let (hl, header) = lines
        .next()
        .ok_or_else(|| Error::input(loc(1), "empty Matrix Market file"))?;
    let h: Vec<String> = header
        .split_whitespace()
        .map(|s| s.to_ascii_lowercase())
        .collect();
    if h.len() < 5 || h[0] != "%%matrixmarket" || h[1] != "matrix" {
        return Err(Error::input(
            loc(hl + 1),
            "not a Matrix Market header (%%MatrixMarket matrix ...)",
        ));
    }
    if h[2] != "coordinate" {
        return Err(Error::input(
            loc(hl + 1),
            format!("only 'coordinate' storage is supported, found '{}'", h[2]),
        ));
    }
    if h[3] != "real" && h[3] != "integer" {
        return Err(Error::input(
            loc(hl + 1),
            format!("only real matrices are supported, found '{}'", h[3]),
        ));
    }
    let symmetric = match h[4].as_str() {
        "symmetric" => true,
        "general" => false,
        other => {
            return Err(Error::input(
                loc(hl + 1),
                format!("unsupported symmetry '{other}'"),
            ))
        }
    };
    let mut size: Option<(usize, usize, usize)> = None;
    let mut triplets = Vec::new();
    for (i, line) in lines {
        let t = line.trim();
        if t.is_empty() || t.starts_with('%') {
            continue;
        }
        let parts: Vec<&str> = t.split_whitespace().collect();
        match size {
            None => {
                let nums: Vec<usize> = parts.iter().filter_map(|p| p.parse().ok()).collect();
                if nums.len() != 3 || parts.len() != 3 {
                    return Err(Error::input(loc(i + 1), "expected 'rows cols entries'"));
                }
                if nums[0] != nums[1] {
                    return Err(Error::input(
                        loc(i + 1),
                        format!("matrix must be square, is {}×{}", nums[0], nums[1]),
                    ));
                }
                size = Some((nums[0], nums[1], nums[2]));
                triplets.reserve(nums[2] * if symmetric { 2 } else { 1 });
            }
            Some((n, _, _)) => {
                if parts.len() != 3 {
                    return Err(Error::input(loc(i + 1), "expected 'row col value'"));
                }
                let r: usize = parts[0]
                    .parse()
                    .map_err(|_| Error::input(loc(i + 1), "bad row index"))?;
                let c: usize = parts[1]
                    .parse()
                    .map_err(|_| Error::input(loc(i + 1), "bad column index"))?;
                let v: f64 = parts[2]
                    .parse()
                    .map_err(|_| Error::input(loc(i + 1), "bad value"))?;
                if r == 0 || c == 0 || r > n || c > n {
                    return Err(Error::input(
                        loc(i + 1),
                        format!("index ({r}, {c}) outside 1..={n}"),
                    ));
                }
                if !v.is_finite() {
                    return Err(Error::input(loc(i + 1), "non-finite value"));
                }
                triplets.push((r - 1, c - 1, v));
                if symmetric && r != c {
                    triplets.push((c - 1, r - 1, v));
                }
            }
        }
    }
    let (n, _, nnz) = size.ok_or_else(|| Error::input(loc(1), "missing size line"))?;
    let listed = if symmetric {
        triplets.iter().filter(|t| t.0 >= t.1).count()
    } else {
        triplets.len()
    };
    if listed != nnz {
        return Err(Error::input(
            loc(1),
            format!("size line announces {nnz} entries, file has {listed}"),
        ));
    }
    Ok(CscMatrix::from_triplets(n, &triplets))
}

pub fn read_matrix_market(path: &Path) -> Result<CscMatrix> {
    let text = crate::input_file::read_to_string(path, crate::input_file::MAX_INPUT_BYTES)?;
    parse_matrix_market(&text, &path.display().to_string())
}

/// Matrix Market coordinate text: the banner of `symmetry`, `comments` as `% ` lines after
/// it, the size line and the 1-based entries with 17 significant digits (exact round trip).
fn format_coordinate(
    symmetry: &str,
    rows: usize,
    cols: usize,
    comments: &[String],
    entries: &[(usize, usize, f64)],
) -> String {
    let mut s = String::with_capacity(entries.len() * 44 + 64 * (comments.len() + 2));
    let _ = writeln!(s, "%%MatrixMarket matrix coordinate real {symmetry}");
    for line in comments {
        let _ = writeln!(s, "% {line}");
    }
    let _ = writeln!(s, "{rows} {cols} {}", entries.len());
    for &(r, c, v) in entries {
        let _ = writeln!(s, "{} {} {:.17e}", r + 1, c + 1, v);
    }
    s
}

/// Matrix Market text of a symmetric matrix (lower triangle, `symmetric`), values with 17
/// significant digits so the round trip is exact.
pub fn format_matrix_market_symmetric(a: &CscMatrix) -> String {
    let mut entries = Vec::new();
    for c in 0..a.n {
        for p in a.col_ptr[c]..a.col_ptr[c + 1] {
            let r = a.row_idx[p];
            if r >= c {
                entries.push((r, c, a.values[p]));
            }
        }
    }
    format_coordinate("symmetric", a.n, a.n, &[], &entries)
}

/// Matrix Market text of a dense rectangular matrix (`coordinate real general`, exact zeros
/// left out, column-major order, 17 significant digits), with `comments` as `%` lines after
/// the banner.
pub fn format_matrix_market_general(a: MatRef<'_, f64>, comments: &[String]) -> String {
    let mut entries = Vec::new();
    for c in 0..a.ncols() {
        for r in 0..a.nrows() {
            let v = a[(r, c)];
            if v != 0.0 {
                entries.push((r, c, v));
            }
        }
    }
    format_coordinate("general", a.nrows(), a.ncols(), comments, &entries)
}
