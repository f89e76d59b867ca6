//! Line and token scanning shared by the text readers (no allocation per line).

use super::IoError;

/// Lines of `bytes` as `(1-based number, content without the line ending)`.
pub(crate) fn lines(bytes: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    bytes
        .split(|&b| b == b'\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix(b"\r").unwrap_or(l)))
}

/// Whitespace-separated tokens of a line.
pub(crate) fn tokens(line: &[u8]) -> Tokens<'_> {
    Tokens { rest: line }
}

/// Iterator of [`tokens`]: skips ASCII whitespace, yields the run up to the next.
pub(crate) struct Tokens<'a> {
    rest: &'a [u8],
}

impl<'a> Iterator for Tokens<'a> {
    type Item = &'a [u8];
    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        let start = self.rest.iter().position(|b| !b.is_ascii_whitespace())?;
        let rest = &self.rest[start..];
        let len = rest
            .iter()
            .position(|b| b.is_ascii_whitespace())
            .unwrap_or(rest.len());
        self.rest = &rest[len..];
        Some(&rest[..len])
    }
}

/// The token as text for an error message (at most 40 characters).
pub(crate) fn show(tok: &[u8]) -> String {
    let s = String::from_utf8_lossy(tok);
    if s.chars().count() > 40 {
        format!("{}…", s.chars().take(40).collect::<String>())
    } else {
        s.into_owned()
    }
}

pub(crate) fn parse_err(file: &str, line: usize, tok: &[u8], what: &'static str) -> IoError {
    IoError::Parse {
        file: file.to_string(),
        line,
        token: show(tok),
        what,
    }
}

/// Parses a number token as `T` (for floats, NaN and infinities are accepted here and
/// rejected by the caller with the vertex's index).
pub(crate) fn parse_num<T: std::str::FromStr>(
    tok: &[u8],
    file: &str,
    line: usize,
    what: &'static str,
) -> Result<T, IoError> {
    std::str::from_utf8(tok)
        .ok()
        .and_then(|s| s.parse::<T>().ok())
        .ok_or_else(|| parse_err(file, line, tok, what))
}

/// A float token: `fast-float2` first (correctly rounded, like `str::parse`), then
/// `str::parse` for what it declines (`nan`, `infinity`, …), so every token
/// `str::parse` accepts is accepted.
pub(crate) fn parse_f64(tok: &[u8]) -> Option<f64> {
    match fast_float2::parse::<f64, _>(tok) {
        Ok(v) => Some(v),
        Err(_) => std::str::from_utf8(tok).ok()?.parse().ok(),
    }
}

/// Fan-triangulates a polygon given as indices into `out`; returns whether it had more
/// than three corners.
pub(crate) fn fan(poly: &[u32], out: &mut Vec<[u32; 3]>) -> bool {
    for k in 1..poly.len().saturating_sub(1) {
        out.push([poly[0], poly[k], poly[k + 1]]);
    }
    poly.len() > 3
}

/// Checks that every position is finite; `line_of(v)` gives the line for the message.
pub(crate) fn check_finite(
    positions: &[[f64; 3]],
    file: &str,
    line_of: impl Fn(usize) -> usize,
) -> Result<(), IoError> {
    match positions
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        Some(v) => Err(IoError::NonFinite {
            file: file.to_string(),
            line: line_of(v),
            vertex: v,
        }),
        None => Ok(()),
    }
}
