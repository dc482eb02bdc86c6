//! One module per command; the only layer that prints. Each has its `Args` next to its `run`.

pub mod layouts;
pub mod rig;

use std::process::ExitCode;

use crate::cli::{Command, EXIT_DATA_LOST};

/// How a command ended, when it did not fail.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Everything done.
    Success,
    /// Done, but some input was lost (exit code 3).
    DataLost,
}

impl Outcome {
    /// The process exit code for this outcome.
    #[must_use]
    pub fn exit_code(self) -> ExitCode {
        match self {
            Outcome::Success => ExitCode::SUCCESS,
            Outcome::DataLost => ExitCode::from(EXIT_DATA_LOST),
        }
    }
}

/// Runs a command.
///
/// # Errors
/// Whatever the command reports; the caller prints it and exits with code 1.
pub fn dispatch(command: Command) -> anyhow::Result<Outcome> {
    match command {
        Command::Rig(args) => rig::run(args),
        Command::Layouts(args) => layouts::run(args),
    }
}

/// Writes `text` to stdout (results go to stdout, diagnostics to stderr).
pub(crate) fn print_stdout(text: &str) -> std::io::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()
}

/// Formats rows as a left-aligned table with a header and a rule.
pub(crate) fn table(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut widths: Vec<usize> = header.iter().map(|h| h.chars().count()).collect();
    for r in rows {
        for (w, c) in widths.iter_mut().zip(r) {
            *w = (*w).max(c.chars().count());
        }
    }
    let line = |cells: Vec<&str>| {
        let mut s = String::new();
        for (i, (c, w)) in cells.iter().zip(&widths).enumerate() {
            if i + 1 == widths.len() {
                s.push_str(c);
            } else {
                s.push_str(&format!("{c:<w$}  "));
            }
        }
        s.trim_end().to_string() + "\n"
    };
    let mut out = line(header.to_vec());
    out.push_str(&line(
        widths
            .iter()
            .map(|w| "-".repeat(*w))
            .collect::<Vec<_>>()
            .iter()
            .map(String::as_str)
            .collect(),
    ));
    for r in rows {
        out.push_str(&line(r.iter().map(String::as_str).collect()));
    }
    out
}
