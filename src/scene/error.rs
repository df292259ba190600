//! The error type of the case-file layer: every variant names the case file and, where it applies, the
//! dotted key path (`bodies.block.material.nu`, arrays indexed as `stages.0.steps`) and the line.

use std::fmt;
use std::path::PathBuf;
use thiserror::Error;

/// One semantic problem found by validation: the key it concerns and what is wrong with it.
#[derive(Debug, Clone, PartialEq)]
pub struct Issue {
    /// Dotted key path into the case, arrays indexed by position: `bcs.1.value`.
    pub key: String,
    /// 1-based line in the case file, when the key is written there as `name = ...`.
    pub line: Option<usize>,
    pub message: String,
}

impl fmt::Display for Issue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "line {l}: `{}`: {}", self.key, self.message),
            None => write!(f, "`{}`: {}", self.key, self.message),
        }
    }
}

/// Everything that can go wrong between a case file on disk and a validated [`crate::scene::Case`].
#[derive(Debug, Error)]
pub enum SceneError {
    #[error("{}: cannot read case file: {source}", .file.display())]
    Read {
        file: PathBuf,
        #[source]
        source: std::io::Error,
    },

    /// The file is not valid TOML.
    #[error("{}{}: TOML syntax error: {message}", .file.display(), line_suffix(.line))]
    Syntax {
        file: PathBuf,
        line: Option<usize>,
        message: String,
    },

    /// The TOML is valid but does not fit the schema: unknown key, wrong type, missing value, bad name.
    #[error("{}{}: `{key}`: {message}", .file.display(), line_suffix(.line))]
    Schema {
        file: PathBuf,
        key: String,
        line: Option<usize>,
        message: String,
    },

    /// A `--set key.path=value` override could not be applied.
    #[error("{}: override `{arg}`: `{key}`: {message}", .file.display())]
    Override {
        file: PathBuf,
        arg: String,
        key: String,
        message: String,
    },

    /// The case parsed but is not meaningful (bad material constants, dangling references, ...).
    #[error("{}: invalid case:{}", .file.display(), list_issues(.issues))]
    Invalid { file: PathBuf, issues: Vec<Issue> },

    #[error("cannot serialise the resolved case to TOML: {0}")]
    Serialize(#[from] toml::ser::Error),
}

impl SceneError {
    /// The key paths this error concerns (empty for read/syntax/serialise errors); used by tests and by
    /// front ends that want to highlight keys.
    pub fn keys(&self) -> Vec<&str> {
        match self {
            SceneError::Schema { key, .. } | SceneError::Override { key, .. } => vec![key.as_str()],
            SceneError::Invalid { issues, .. } => issues.iter().map(|i| i.key.as_str()).collect(),
            _ => Vec::new(),
        }
    }
}

fn line_suffix(line: &Option<usize>) -> String {
    match line {
        Some(l) => format!(":{l}"),
        None => String::new(),
    }
}

fn list_issues(issues: &[Issue]) -> String {
    issues.iter().map(|i| format!("\n  {i}")).collect()
}
