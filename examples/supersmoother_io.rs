//! Smooths series read from standard input with [`autoact::dsi::supersmoother`], for comparing
//! with other implementations (`tools/check_supersmoother.py` drives it).
//!
//! One series per input line (whitespace-separated numbers); one line of smoothed values per
//! input line on standard output, each printed so that it parses back to the same `f64`.
//!
//! Usage: `supersmoother_io [--bass ALPHA] [--spans TWEETER,MIDRANGE,WOOFER] [--middle SPAN]
//! [--final SPAN] < series.txt` (defaults: Friedman's 0.05,0.2,0.5 / 0.2 / 0.05, no bass).

use std::io::{BufRead, BufWriter, Write};
use std::process::ExitCode;

use autoact::dsi::supersmoother::{SmoothPlan, SmoothScratch, SuperSmoother};

fn number(flag: &str, text: &str) -> Result<f64, String> {
    text.trim()
        .parse()
        .map_err(|e| format!("{flag}: {text:?} is not a number ({e})"))
}

fn parse_args(args: impl Iterator<Item = String>) -> Result<SuperSmoother, String> {
    let mut smoother = SuperSmoother::default();
    let mut args = args;
    while let Some(flag) = args.next() {
        let mut value = || args.next().ok_or_else(|| format!("{flag} needs a value"));
        match flag.as_str() {
            "--bass" => smoother.bass = Some(number(&flag, &value()?)?),
            "--middle" => smoother.middle_span = number(&flag, &value()?)?,
            "--final" => smoother.final_span = number(&flag, &value()?)?,
            "--spans" => {
                let text = value()?;
                let spans = text
                    .split(',')
                    .map(|s| number(&flag, s))
                    .collect::<Result<Vec<_>, _>>()?;
                smoother.primary_spans = spans.try_into().map_err(|_| {
                    format!("--spans takes three comma-separated spans, not {text:?}")
                })?;
            }
            _ => {
                return Err(format!(
                    "unknown argument {flag:?}; usage: supersmoother_io [--bass ALPHA] \
                     [--spans A,B,C] [--middle SPAN] [--final SPAN] < series"
                ));
            }
        }
    }
    smoother.validate().map_err(|e| e.to_string())?;
    Ok(smoother)
}

fn run() -> Result<(), String> {
    let smoother = parse_args(std::env::args().skip(1))?;
    let stdin = std::io::stdin().lock();
    let mut out = BufWriter::new(std::io::stdout().lock());
    let write_error = |e: std::io::Error| format!("writing standard output: {e}");
    let mut plan: Option<SmoothPlan> = None;
    let mut scratch = SmoothScratch::default();
    let (mut series, mut smoothed) = (Vec::new(), Vec::new());
    for (number_of_line, line) in stdin.lines().enumerate() {
        let line = line.map_err(|e| format!("reading standard input: {e}"))?;
        series.clear();
        for token in line.split_whitespace() {
            series.push(number(&format!("line {}", number_of_line + 1), token)?);
        }
        let n = series.len();
        if plan.as_ref().is_none_or(|p| p.len() != n) {
            plan = Some(smoother.plan(n));
        }
        smoothed.resize(n, 0.0);
        if let Some(plan) = &plan {
            plan.smooth_into(&series, &mut smoothed, &mut scratch);
        }
        for (i, v) in smoothed.iter().enumerate() {
            let sep = if i == 0 { "" } else { " " };
            write!(out, "{sep}{v:e}").map_err(write_error)?;
        }
        writeln!(out).map_err(write_error)?;
    }
    out.flush().map_err(write_error)
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            // Reporting the error is this program's whole error handling.
            let mut stderr = std::io::stderr().lock();
            let _ = writeln!(stderr, "supersmoother_io: {message}");
            ExitCode::FAILURE
        }
    }
}
