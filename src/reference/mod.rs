//! Generated reference pages: `nurbs-contact reference --out docs/reference` writes
//!
//! - `case-schema.json`: the JSON Schema of a case file ([`crate::scene::json_schema::case_schema`]),
//!   for editors (taplo / Even Better TOML) and validators;
//! - `case-keys.md`: every case-file key by its dotted path, with type, default, allowed values,
//!   unit and description, one section per table ([`case_keys`]);
//! - `cli.md`: every subcommand, argument and option of the command line ([`cli`]).
//!
//! The pages are derived from the types alone (the case schema's doc comments, the clap parser), so
//! a test compares the committed pages with a fresh generation.

pub mod case_keys;
pub mod cli;

use std::path::{Path, PathBuf};

/// Where the pages live in the repository, and the default of `reference --out`.
pub const DEFAULT_DIR: &str = "docs/reference";

/// The command that regenerates the committed pages (from the repository root).
pub const REGENERATE: &str = "cargo run --release -- reference --out docs/reference";

/// One generated page: its file name in the reference directory and its text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Page {
    pub file: &'static str,
    pub text: String,
}

/// Every page, generated from the case schema and from `cli`, the binary's clap command.
pub fn pages(cli: &clap::Command) -> Vec<Page> {
    let schema = crate::scene::json_schema::case_schema();
    let mut json = serde_json::to_string_pretty(&schema)
        .expect("a serde_json::Value always serialises to a string");
    json.push('\n');
    vec![
        Page {
            file: "case-schema.json",
            text: json,
        },
        Page {
            file: "case-keys.md",
            text: case_keys::render(&schema),
        },
        Page {
            file: "cli.md",
            text: cli::render(cli),
        },
    ]
}

/// Prose as Markdown: `<` outside code spans becomes `&lt;`, so that text such as
/// `out/<case name>/` is not read as an HTML tag.
pub fn escape_prose(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut in_code = false;
    for c in text.chars() {
        match c {
            '`' => {
                in_code = !in_code;
                out.push(c);
            }
            '<' if !in_code => out.push_str("&lt;"),
            c => out.push(c),
        }
    }
    out
}

/// Why the pages could not be written.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}: {source}", path.display())]
pub struct WriteError {
    pub path: PathBuf,
    pub source: std::io::Error,
}

/// Writes every page into `dir` (created if missing); returns the paths written.
pub fn write_pages(dir: &Path, cli: &clap::Command) -> Result<Vec<PathBuf>, WriteError> {
    std::fs::create_dir_all(dir).map_err(|source| WriteError {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut written = Vec::new();
    for page in pages(cli) {
        let path = dir.join(page.file);
        std::fs::write(&path, page.text).map_err(|source| WriteError {
            path: path.clone(),
            source,
        })?;
        written.push(path);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    #[test]
    fn prose_escapes_angle_brackets_outside_code() {
        assert_eq!(
            super::escape_prose("out/<case name>/ or `out/<name>/`"),
            "out/&lt;case name>/ or `out/<name>/`"
        );
    }
}
