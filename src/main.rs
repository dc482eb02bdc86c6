//! The `autoact` command: parse arguments, set up logging, run, map the outcome to an exit code.

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let cli = autoact::cli::Cli::parse();
    autoact::cli::init_logging(&cli.global);
    match cli.command.run() {
        Ok(outcome) => outcome.exit_code(),
        Err(err) if autoact::cli::is_broken_pipe(&err) => ExitCode::SUCCESS,
        Err(err) => {
            autoact::cli::report_error(&err);
            ExitCode::from(autoact::cmd::EXIT_FAILURE)
        }
    }
}
