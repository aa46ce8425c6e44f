//! Frontend errors: one line each, naming what was wrong, and an exit status.

use std::fmt;
use std::path::PathBuf;

/// Everything the frontend can report.
#[derive(Debug)]
pub enum Error {
    /// A configuration value breaks a rule.
    Config {
        /// The key (the config-file key; CLI flags use the same words).
        key: String,
        /// The offending value, as written.
        value: String,
        /// The rule it breaks.
        rule: String,
    },
    /// A file could not be read or written.
    Io {
        /// What was being done, e.g. `"read config"`.
        action: &'static str,
        /// The path involved.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The core refused the scene or the run diverged.
    Core(sph_core::error::Error),
    /// A run that had to reach its end ([`crate::couette::run`], each run of
    /// a study) stopped early: diverged or interrupted.
    Diverged(String),
    /// A run stopped early (diverged, or its state degenerated); its
    /// results up to then were written with `complete: false`.
    Stopped(String),
}

/// Shorthand result type.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// A configuration error.
    pub fn config(
        key: impl Into<String>,
        value: impl fmt::Display,
        rule: impl Into<String>,
    ) -> Self {
        // An offending value is quoted, not echoed in full: a huge one
        // (a number with 300 digits, a 50 MB string) is cut.
        const MAX: usize = 64;
        let mut value = value.to_string();
        if value.chars().count() > MAX {
            let cut: String = value.chars().take(MAX).collect();
            value = format!("{cut}... ({} characters)", value.chars().count());
        }
        Error::Config {
            key: key.into(),
            value,
            rule: rule.into(),
        }
    }

    /// An I/O error.
    pub fn io(action: &'static str, path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            action,
            path: path.into(),
            source,
        }
    }

    /// Process exit status: 2 for bad input (configuration, files, a scene
    /// the core rejects), 1 for a run that went wrong (diverged).
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Core(sph_core::error::Error::Unstable { .. })
            | Error::Stopped(_)
            | Error::Diverged(_) => 1,
            _ => 2,
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Config { key, value, rule } => write!(f, "invalid `{key}` = {value}: {rule}"),
            Error::Io {
                action,
                path,
                source,
            } => write!(f, "cannot {action} `{}`: {source}", path.display()),
            Error::Core(e) => write!(f, "{e}"),
            Error::Stopped(reason) => {
                write!(f, "{reason} (results up to then written, complete: false)")
            }
            Error::Diverged(reason) => write!(f, "{reason}"),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io { source, .. } => Some(source),
            Error::Core(e) => Some(e),
            Error::Config { .. } | Error::Stopped(_) | Error::Diverged(_) => None,
        }
    }
}

impl From<sph_core::error::Error> for Error {
    fn from(e: sph_core::error::Error) -> Self {
        Error::Core(e)
    }
}
