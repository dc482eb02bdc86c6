//! Progress of a whole dataset: captures and clips done of their totals, frames rendered per
//! second and the time left. A bar on a terminal; otherwise (a log file, a Slurm job's output) a
//! plain line every few seconds. Nothing with `-q`.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Seconds between two plain progress lines.
const LINE_EVERY: Duration = Duration::from_secs(5);

/// What the dataset (or this shard of it) holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Totals {
    /// Capture sessions.
    pub captures: u64,
    /// Clips.
    pub clips: u64,
    /// Frames to render.
    pub frames: u64,
}

/// The dataset's progress, shared by the stages (the renderer reports from its threads).
#[derive(Debug)]
pub struct DatasetProgress {
    totals: Totals,
    captures: AtomicU64,
    clips: AtomicU64,
    /// Frames of sessions rendered before the current one.
    frames_before: AtomicU64,
    /// Frames of the session being rendered.
    frames_now: AtomicU64,
    /// Clips of the session being trimmed.
    clips_now: AtomicU64,
    /// Frames done when this run started (they do not count in the rate).
    frames_at_start: AtomicU64,
    started: Instant,
    bar: Option<indicatif::ProgressBar>,
    /// When the last plain line was written (`None`: plain lines off).
    last_line: Option<Mutex<Instant>>,
}

impl DatasetProgress {
    /// Progress over `totals`, drawn as a bar on a terminal, as lines otherwise, or not at all
    /// when warnings are off (`-q`).
    #[must_use]
    pub fn new(totals: Totals) -> DatasetProgress {
        let shown = tracing::enabled!(tracing::Level::WARN);
        let terminal = std::io::stderr().is_terminal();
        let bar = (shown && terminal).then(|| {
            let bar = indicatif::ProgressBar::new(totals.frames);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} generating [{bar:30}] {msg}  ETA {eta}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                .progress_chars("=> "),
            );
            bar
        });
        let now = Instant::now();
        DatasetProgress {
            totals,
            captures: AtomicU64::new(0),
            clips: AtomicU64::new(0),
            frames_before: AtomicU64::new(0),
            frames_now: AtomicU64::new(0),
            clips_now: AtomicU64::new(0),
            frames_at_start: AtomicU64::new(0),
            started: now,
            bar,
            last_line: (shown && !terminal).then(|| Mutex::new(now)),
        }
    }

    /// A session found finished (or rendered) by an earlier run: its frames, and its clips when
    /// they are final too.
    pub fn already_done(&self, frames: u64, clips: Option<u64>) {
        self.frames_before.fetch_add(frames, Ordering::Relaxed);
        self.frames_at_start.fetch_add(frames, Ordering::Relaxed);
        if let Some(c) = clips {
            self.captures.fetch_add(1, Ordering::Relaxed);
            self.clips.fetch_add(c, Ordering::Relaxed);
        }
        self.show(false);
    }

    /// `k` frames of the session being rendered are done.
    pub fn rendering(&self, k: u64) {
        self.frames_now.store(k, Ordering::Relaxed);
        self.show(false);
    }

    /// The session being rendered is done: `frames` in all.
    pub fn rendered(&self, frames: u64) {
        self.frames_now.store(0, Ordering::Relaxed);
        self.frames_before.fetch_add(frames, Ordering::Relaxed);
        self.show(false);
    }

    /// `k` clips of the session being trimmed are done.
    pub fn trimming(&self, k: u64) {
        self.clips_now.store(k, Ordering::Relaxed);
        self.show(false);
    }

    /// The session being trimmed is done: `clips` in all.
    pub fn session_done(&self, clips: u64) {
        self.clips_now.store(0, Ordering::Relaxed);
        self.clips.fetch_add(clips, Ordering::Relaxed);
        self.captures.fetch_add(1, Ordering::Relaxed);
        self.show(false);
    }

    /// Removes the bar and writes a last line (the summary follows on stdout).
    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
        self.show(true);
    }

    /// Frames rendered by this run per second of its wall time.
    fn rate(&self, frames: u64) -> f64 {
        let new = frames.saturating_sub(self.frames_at_start.load(Ordering::Relaxed));
        #[expect(clippy::cast_precision_loss, reason = "display only")]
        let rate = new as f64 / self.started.elapsed().as_secs_f64().max(1e-3);
        rate
    }

    fn show(&self, last: bool) {
        let frames =
            self.frames_before.load(Ordering::Relaxed) + self.frames_now.load(Ordering::Relaxed);
        let clips = self.clips.load(Ordering::Relaxed) + self.clips_now.load(Ordering::Relaxed);
        let t = self.totals;
        let rate = self.rate(frames);
        let text = format!(
            "captures {}/{}, clips {clips}/{}, frames {frames}/{} ({rate:.0} frames/s)",
            self.captures.load(Ordering::Relaxed),
            t.captures,
            t.clips,
            t.frames
        );
        if let Some(bar) = &self.bar {
            bar.set_position(frames);
            bar.set_message(text);
            return;
        }
        let Some(last_line) = &self.last_line else {
            return;
        };
        let mut at = last_line
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if !last && at.elapsed() < LINE_EVERY {
            return;
        }
        *at = Instant::now();
        #[expect(
            clippy::cast_precision_loss,
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "display only"
        )]
        let eta = if rate > 0.0 {
            let s = (t.frames.saturating_sub(frames) as f64 / rate).round() as u64;
            format!("ETA {}:{:02}", s / 60, s % 60)
        } else {
            "ETA unknown".to_owned()
        };
        let elapsed = self.started.elapsed().as_secs();
        crate::progress::status_line(&format!(
            "generate {}:{:02}: {text}, {eta}",
            elapsed / 60,
            elapsed % 60
        ));
    }
}
