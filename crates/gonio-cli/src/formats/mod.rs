//! File formats the commands read, each with errors that name the file, line and column.

pub mod certificate;
pub mod elcomat;
pub mod frames;
pub mod instrument;
pub mod meta;
pub mod plan;
pub mod replay;
pub mod report;

use anyhow::anyhow;
use std::path::Path;

/// Line and column (1-based, columns in characters) of a byte offset in `text`.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |s| s.chars().count()) + 1;
    (line, col)
}

/// A TOML error as `FILE:LINE:COL: message`.
pub fn toml_error(path: &Path, text: &str, e: &toml::de::Error) -> anyhow::Error {
    let (l, c) = e.span().map_or((1, 1), |s| line_col(text, s.start));
    anyhow!("{}:{l}:{c}: {}", path.display(), e.message().trim_end())
}

/// A JSON error as `FILE:LINE:COL: message (what was expected)`.
pub fn json_error(path: &Path, e: &serde_json::Error, expected: &str) -> anyhow::Error {
    anyhow!(
        "{}:{}:{}: {} ({expected})",
        path.display(),
        e.line(),
        e.column(),
        strip_position(&e.to_string())
    )
}

/// serde_json appends " at line L column C" to its messages: the prefix already says where.
fn strip_position(msg: &str) -> &str {
    match msg.rfind(" at line ") {
        Some(i) => &msg[..i],
        None => msg,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_and_column_of_an_offset() {
        let t = "a = 1\nbé = x\n";
        assert_eq!(line_col(t, 0), (1, 1));
        assert_eq!(line_col(t, t.find('x').unwrap()), (2, 6));
    }
}
