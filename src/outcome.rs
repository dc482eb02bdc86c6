//! How a run ended, and the one rule for lost input: input lost anywhere ⇒ a warning naming the
//! file and the place (the run logs it), and exit code 3.
//!
//! Every command's result answers one question, [`LostInput::lost_input`], and
//! [`Outcome::from_run`] is the one place that turns the answer into the exit code. The
//! conversion paths collect what they lose as [`crate::loss::Losses`]; `trim`, `record`,
//! `recover` and `info` answer from their own counts (segments a video does not cover, dropped or
//! rejected samples, unreadable chunks). This module depends on nothing else in the crate, so
//! every result type can implement [`LostInput`].

use std::process::ExitCode;

/// A finished run's account of its input.
pub trait LostInput {
    /// Whether any input was lost: unreadable, skipped, dropped, or left out.
    fn lost_input(&self) -> bool;
}

/// Exit code for a failure that produced no usable result.
pub const EXIT_FAILURE: u8 = 1;
/// Exit code clap uses for a usage error.
pub const EXIT_USAGE: u8 = 2;
/// Exit code for a run that finished but lost input data (skipped frames or records).
pub const EXIT_DATA_LOST: u8 = 3;

/// How a command ended, when it did not fail.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Everything done.
    Success,
    /// Done, but some input was lost (exit code 3).
    DataLost,
}

impl Outcome {
    /// The one rule for lost input: done, and exit code 3 when any input was lost.
    #[must_use]
    pub fn from_run(run: &impl LostInput) -> Outcome {
        if run.lost_input() {
            Outcome::DataLost
        } else {
            Outcome::Success
        }
    }

    /// The process exit code for this outcome.
    #[must_use]
    pub fn exit_code(self) -> ExitCode {
        match self {
            Outcome::Success => ExitCode::SUCCESS,
            Outcome::DataLost => ExitCode::from(EXIT_DATA_LOST),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Run(bool);

    impl LostInput for Run {
        fn lost_input(&self) -> bool {
            self.0
        }
    }

    #[test]
    fn lost_input_and_only_lost_input_makes_exit_code_3() {
        assert_eq!(Outcome::from_run(&Run(false)), Outcome::Success);
        assert_eq!(Outcome::from_run(&Run(true)), Outcome::DataLost);
        assert_eq!(EXIT_DATA_LOST, 3);
        assert_eq!(
            Outcome::DataLost.exit_code(),
            ExitCode::from(EXIT_DATA_LOST)
        );
    }
}
