//! Draining a child's standard error on its own thread, keeping the last lines for errors.
//!
//! A child that writes more to stderr than the pipe holds (64 KiB on Linux) blocks until someone
//! reads it; if we are at the same time blocked writing frames to its stdin, both wait forever.
//! So stderr is always read on a separate thread, from spawn to exit. Lines end at `\n` or `\r`
//! (ffmpeg's progress lines use `\r`); each is logged at `debug` and the last
//! [`STDERR_TAIL_LINES`] non-empty ones are kept.

use std::collections::VecDeque;
use std::io::Read;
use std::thread::JoinHandle;

use super::STDERR_TAIL_LINES;

/// Longest line kept, in bytes; the rest of a longer line is dropped (and marked `…`).
const MAX_LINE_BYTES: usize = 2000;

/// A thread reading a child's stderr to its end.
#[derive(Debug)]
pub(crate) struct StderrTail {
    handle: JoinHandle<VecDeque<String>>,
}

impl StderrTail {
    /// Starts draining `stderr` on a thread named `name`.
    pub(crate) fn spawn(
        name: &str,
        stderr: impl Read + Send + 'static,
    ) -> std::io::Result<StderrTail> {
        let handle = std::thread::Builder::new()
            .name(name.to_owned())
            .spawn(move || drain(stderr))?;
        Ok(StderrTail { handle })
    }

    /// Waits for end of file (the child exited and closed stderr) and returns the last lines,
    /// joined with `\n`.
    pub(crate) fn join(self) -> String {
        match self.handle.join() {
            Ok(lines) => Vec::from(lines).join("\n"),
            Err(_) => String::from("(the thread reading ffmpeg's stderr failed)"),
        }
    }
}

fn drain(mut stderr: impl Read) -> VecDeque<String> {
    let mut tail = VecDeque::with_capacity(STDERR_TAIL_LINES + 1);
    let mut line = Vec::new();
    let mut truncated = false;
    let mut buf = [0_u8; 8192];
    loop {
        let n = match stderr.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => {
                push_line(
                    &mut tail,
                    format!("(reading stderr failed: {e})").as_bytes(),
                    false,
                );
                break;
            }
        };
        for &byte in &buf[..n] {
            if byte == b'\n' || byte == b'\r' {
                push_line(&mut tail, &line, truncated);
                line.clear();
                truncated = false;
            } else if line.len() < MAX_LINE_BYTES {
                line.push(byte);
            } else {
                truncated = true;
            }
        }
    }
    push_line(&mut tail, &line, truncated);
    tail
}

fn push_line(tail: &mut VecDeque<String>, line: &[u8], truncated: bool) {
    let text = String::from_utf8_lossy(line);
    let text = text.trim();
    if text.is_empty() {
        return;
    }
    tracing::debug!(target: "autoact::video::ffmpeg", "{text}");
    let mut text = text.to_owned();
    if truncated {
        text.push('…');
    }
    tail.push_back(text);
    while tail.len() > STDERR_TAIL_LINES {
        tail.pop_front();
    }
}

/// The last [`STDERR_TAIL_LINES`] non-empty lines of captured stderr, joined with `\n`.
pub(crate) fn tail_of_text(stderr: &[u8]) -> String {
    Vec::from(drain(stderr)).join("\n")
}

#[cfg(test)]
mod tests {
    use super::tail_of_text;

    #[test]
    fn keeps_the_last_lines_split_at_cr_and_lf() {
        let mut text = String::new();
        for i in 0..30 {
            text.push_str(&format!("line {i}\r\n"));
        }
        text.push_str("frame=1\rframe=2\rlast without newline");
        let tail = tail_of_text(text.as_bytes());
        let lines: Vec<&str> = tail.lines().collect();
        assert_eq!(lines.len(), super::STDERR_TAIL_LINES);
        assert_eq!(lines.last(), Some(&"last without newline"));
        assert_eq!(lines[lines.len() - 2], "frame=2");
        assert!(!tail.contains("line 12"));
        assert!(tail.contains("line 29"));
    }

    #[test]
    fn long_lines_are_cut_and_marked() {
        let text = "x".repeat(5000);
        let tail = tail_of_text(text.as_bytes());
        assert!(tail.ends_with('…'));
        assert!(tail.len() < 2100);
    }
}
