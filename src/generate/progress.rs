//! Progress of a whole dataset: captures and clips done of their totals, timeline frames done,
//! frames drawn per second and the time left (the timeline left at this run's pace). A bar on a terminal; otherwise (a log file, a Slurm job's output) a
//! plain line at once and then every few seconds. Nothing with `-q`.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::sync::atomic::{AtomicI64, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Seconds between two plain progress lines.
const LINE_EVERY: Duration = Duration::from_secs(5);

/// What the dataset (or this shard of it) holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Totals {
    /// Capture sessions.
    pub captures: u64,
    /// Clips, as the plan counts them (one a segment; a policy that cuts windows or instances
    /// makes more or fewer, counted as each capture is cut).
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
    /// Real clips less the plan's segments, of the sessions cut by this run.
    clips_extra: AtomicI64,
    /// The same of the session being trimmed.
    clips_extra_now: AtomicI64,
    /// Frames drawn by this run (a render of some frames skips the others).
    drawn: AtomicU64,
    /// Frames done when this run started (they do not count in the rate).
    frames_at_start: AtomicU64,
    started: Instant,
    bar: Option<indicatif::ProgressBar>,
    /// When the last plain line was written (`None`: plain lines off; inside, `None` until
    /// the first line, which is written at once so a log shows the job's size from the start).
    last_line: Option<Mutex<Option<Instant>>>,
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
            clips_extra: AtomicI64::new(0),
            clips_extra_now: AtomicI64::new(0),
            drawn: AtomicU64::new(0),
            frames_at_start: AtomicU64::new(0),
            started: now,
            bar,
            last_line: (shown && !terminal).then(|| Mutex::new(None)),
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

    /// `n` frames are about to be drawn.
    pub fn drawing(&self, n: u64) {
        self.drawn.fetch_add(n, Ordering::Relaxed);
    }

    /// `k` of the `total` clips of the session being trimmed are done; the plan has `segments`
    /// for it.
    pub fn trimming(&self, k: u64, total: u64, segments: u64) {
        self.clips_now.store(k, Ordering::Relaxed);
        self.clips_extra_now
            .store(difference(total, segments), Ordering::Relaxed);
        self.show(false);
    }

    /// The session being trimmed is done: `clips` cut of the plan's `segments`.
    pub fn session_done(&self, segments: u64, clips: u64) {
        self.clips_now.store(0, Ordering::Relaxed);
        self.clips_extra_now.store(0, Ordering::Relaxed);
        self.clips_extra
            .fetch_add(difference(clips, segments), Ordering::Relaxed);
        self.clips.fetch_add(clips, Ordering::Relaxed);
        self.captures.fetch_add(1, Ordering::Relaxed);
        self.show(false);
    }

    /// Clips in all: the plan's, corrected by the sessions cut (done or under way).
    fn clips_total(&self) -> u64 {
        let extra =
            self.clips_extra.load(Ordering::Relaxed) + self.clips_extra_now.load(Ordering::Relaxed);
        self.totals.clips.saturating_add_signed(extra)
    }

    /// Removes the bar and writes a last line (the summary follows on stdout).
    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
        self.show(true);
    }

    /// Timeline frames done by this run, and frames drawn, per second of its wall time.
    fn rates(&self, frames: u64) -> (f64, f64) {
        let new = frames.saturating_sub(self.frames_at_start.load(Ordering::Relaxed));
        let seconds = self.started.elapsed().as_secs_f64().max(1e-3);
        #[expect(clippy::cast_precision_loss, reason = "display only")]
        let rates = (
            new as f64 / seconds,
            self.drawn.load(Ordering::Relaxed) as f64 / seconds,
        );
        rates
    }

    fn show(&self, last: bool) {
        let frames =
            self.frames_before.load(Ordering::Relaxed) + self.frames_now.load(Ordering::Relaxed);
        let clips = self.clips.load(Ordering::Relaxed) + self.clips_now.load(Ordering::Relaxed);
        let t = self.totals;
        let (rate, drawn) = self.rates(frames);
        let text = format!(
            "captures {}/{}, clips {clips}/{}, frames {frames}/{} ({drawn:.0} drawn/s)",
            self.captures.load(Ordering::Relaxed),
            t.captures,
            self.clips_total().max(clips),
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
        if !last && at.is_some_and(|at| at.elapsed() < LINE_EVERY) {
            return;
        }
        *at = Some(Instant::now());
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

/// `a - b`, signed (saturating).
fn difference(a: u64, b: u64) -> i64 {
    let wide = i128::from(a) - i128::from(b);
    i64::try_from(wide).unwrap_or(if wide < 0 { i64::MIN } else { i64::MAX })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A windows policy cuts more clips than the plan has segments: the total grows with them,
    /// so the counter never reads "205/100".
    #[test]
    fn the_clip_total_follows_the_clips_cut() {
        let p = DatasetProgress::new(Totals {
            captures: 2,
            clips: 100,
            frames: 1_000,
        });
        p.trimming(205, 210, 50);
        let seen = p.clips.load(Ordering::Relaxed) + p.clips_now.load(Ordering::Relaxed);
        assert_eq!((seen, p.clips_total()), (205, 260));
        p.session_done(50, 210);
        p.trimming(10, 20, 50);
        assert_eq!(p.clips_total(), 210 + 20);
        p.session_done(50, 20);
        assert_eq!(
            (p.clips.load(Ordering::Relaxed), p.clips_total()),
            (230, 230)
        );
    }
}
