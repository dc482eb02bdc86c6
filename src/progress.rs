//! Progress on stderr for long jobs: a bar for jobs that know their length (`render`, `trim`)
//! and a status line for open-ended ones (`record`). Both stay silent with `-q` (warnings off);
//! the bar draws only on a terminal.

use std::io::{IsTerminal, Write};

/// A progress bar on stderr: `⠁ <verb> [=====>    ] 12/40 <unit>  ETA 3s`.
#[derive(Debug)]
pub struct Progress {
    bar: indicatif::ProgressBar,
}

impl Progress {
    /// A bar counting `total` `unit`s while `verb`-ing; `show_rate` adds the rate per second.
    #[must_use]
    pub fn bar(verb: &str, unit: &str, show_rate: bool, total: u64) -> Progress {
        let rate = if show_rate { "  {per_sec}" } else { "" };
        let template =
            format!("{{spinner}} {verb} [{{bar:30}}] {{pos}}/{{len}} {unit}{rate}  ETA {{eta}}");
        let bar = indicatif::ProgressBar::new(total);
        bar.set_style(
            indicatif::ProgressStyle::with_template(&template)
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        if !tracing::enabled!(tracing::Level::WARN) {
            bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
        }
        Progress { bar }
    }

    /// `done` of `total` are done (the total may grow as the job learns it).
    pub fn update(&self, done: u64, total: u64) {
        self.bar.set_length(total);
        self.bar.set_position(done);
    }

    /// `done` are done.
    pub fn set_done(&self, done: u64) {
        self.bar.set_position(done);
    }

    /// Removes the bar (the job's summary follows on stdout).
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// Shows one status line on stderr: rewritten in place on a terminal, one line per call
/// otherwise; nothing with `-q`.
pub fn status_line(line: &str) {
    if !tracing::enabled!(tracing::Level::WARN) {
        return;
    }
    let mut err = std::io::stderr().lock();
    let _ = if err.is_terminal() {
        write!(err, "\r{line}\x1b[K")
    } else {
        writeln!(err, "{line}")
    };
}
