//! Is a named thread of this process still running? The recorder's watchdog over RustDDS.
//!
//! RustDDS receives on two threads of its own, the participant's event loop and discovery. When
//! one of them ends (RustDDS 0.15.1 ended both on any `poll` error, EINTR after a stop and
//! continue included: `third_party/rustdds-0.15.1/PATCHES.md`), it logs an error and nothing
//! more arrives; no status, listener or handle in its API says so. What is observable is the
//! thread itself: on Linux every thread of the process is a directory in `/proc/self/task`
//! whose `comm` file holds its name (the first 15 bytes, which is what `std::thread::Builder`
//! gives the kernel). A [`ThreadWatch`] counts the threads whose name starts with each watched
//! prefix when it is made, and [`ThreadWatch::check`] reports a prefix that has fewer now.
//!
//! Where `/proc/self/task` cannot be read (not Linux) or a prefix matched nothing at the start
//! (RustDDS renamed its threads), that prefix is not watched: [`ThreadWatch::unwatched`] names
//! it so the caller can say so once. A read that fails later is taken as "still running": the
//! watchdog never ends a recording on a guess.

use std::path::{Path, PathBuf};

/// Where Linux lists the threads of the calling process.
pub const PROC_SELF_TASK: &str = "/proc/self/task";

/// Thread-name prefixes of RustDDS 0.15.1, as the kernel holds them (15 bytes) and what each
/// thread does: "RustDDS Participant {id} event loop" and "RustDDS discovery thread".
pub const RUSTDDS_THREADS: [(&str, &str); 2] = [
    ("RustDDS Partici", "event loop (sockets, readers, writers)"),
    ("RustDDS discove", "discovery loop"),
];

/// Counts of named threads at one moment, to notice when one of them ends.
#[derive(Debug, Clone)]
pub struct ThreadWatch {
    task_dir: PathBuf,
    /// (prefix, what the thread does, how many ran at the start), for prefixes that matched.
    watched: Vec<(String, String, usize)>,
    unwatched: Vec<String>,
}

/// A watched thread that is no longer running.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EndedThread {
    /// Name prefix of the thread, as in `/proc/self/task/*/comm`.
    pub prefix: String,
    /// What the thread did.
    pub role: String,
    /// How many such threads ran when the watch started.
    pub started: usize,
    /// How many run now.
    pub running: usize,
}

impl ThreadWatch {
    /// Counts now, in `task_dir` (normally [`PROC_SELF_TASK`]), the threads whose name starts
    /// with each `(prefix, role)` of `threads`.
    #[must_use]
    pub fn new(task_dir: &Path, threads: &[(&str, &str)]) -> ThreadWatch {
        let names = thread_names(task_dir);
        let mut watch = ThreadWatch {
            task_dir: task_dir.to_path_buf(),
            watched: Vec::new(),
            unwatched: Vec::new(),
        };
        for &(prefix, role) in threads {
            let count = names.as_ref().map_or(0, |n| count_prefixed(n, prefix));
            if count == 0 {
                watch.unwatched.push(prefix.to_owned());
            } else {
                watch
                    .watched
                    .push((prefix.to_owned(), role.to_owned(), count));
            }
        }
        watch
    }

    /// Prefixes that cannot be watched: no such thread at the start, or no `task_dir`.
    #[must_use]
    pub fn unwatched(&self) -> &[String] {
        &self.unwatched
    }

    /// The first watched thread that has ended since [`ThreadWatch::new`], if any. `None` also
    /// when `task_dir` cannot be read now.
    #[must_use]
    pub fn check(&self) -> Option<EndedThread> {
        let names = thread_names(&self.task_dir)?;
        self.watched.iter().find_map(|(prefix, role, started)| {
            let running = count_prefixed(&names, prefix);
            (running < *started).then(|| EndedThread {
                prefix: prefix.clone(),
                role: role.clone(),
                started: *started,
                running,
            })
        })
    }
}

fn count_prefixed(names: &[String], prefix: &str) -> usize {
    names.iter().filter(|n| n.starts_with(prefix)).count()
}

/// The names (`comm`) of the threads listed in `task_dir`; `None` if it cannot be listed.
/// A thread that ends while this reads is skipped.
fn thread_names(task_dir: &Path) -> Option<Vec<String>> {
    let entries = std::fs::read_dir(task_dir).ok()?;
    Some(
        entries
            .filter_map(Result::ok)
            .filter_map(|e| std::fs::read_to_string(e.path().join("comm")).ok())
            .map(|name| name.trim_end_matches('\n').to_owned())
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc;
    use std::time::{Duration, Instant};

    /// A stand-in for an event loop: a named thread that runs until told to stop. Returns once
    /// it runs (a thread names itself when it starts, as RustDDS's do before their handshake).
    fn fake_loop(name: &str) -> (mpsc::Sender<()>, std::thread::JoinHandle<()>) {
        let (stop, stopped) = mpsc::channel::<()>();
        let (running, started) = mpsc::channel::<()>();
        let handle = std::thread::Builder::new()
            .name(name.to_owned())
            .spawn(move || {
                let _ = running.send(());
                let _ = stopped.recv();
            })
            .expect("spawn");
        started.recv().expect("the thread started");
        (stop, handle)
    }

    /// Waits for the kernel to drop an ended thread from `task_dir` (join returns slightly
    /// before), up to 5 s.
    fn check_until_ended(watch: &ThreadWatch) -> Option<EndedThread> {
        let deadline = Instant::now() + Duration::from_secs(5);
        loop {
            if let Some(ended) = watch.check() {
                return Some(ended);
            }
            if Instant::now() > deadline {
                return None;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn an_ended_loop_thread_is_reported_and_a_running_one_is_not() {
        // Names unique to this test (15 bytes are kept), so parallel tests do not interfere.
        let (stop_a, a) = fake_loop("watchtest loopA");
        let (_stop_b, _b) = fake_loop("watchtest loopB");
        let threads = [
            ("watchtest loopA", "fake event loop"),
            ("watchtest loopB", "fake discovery"),
            ("watchtest none", "never started"),
        ];
        let watch = ThreadWatch::new(Path::new(PROC_SELF_TASK), &threads);
        assert_eq!(watch.unwatched(), ["watchtest none".to_owned()]);
        assert_eq!(watch.check(), None);
        drop(stop_a);
        a.join().expect("join");
        let ended = check_until_ended(&watch).expect("the ended thread is noticed");
        assert_eq!(
            ended,
            EndedThread {
                prefix: "watchtest loopA".to_owned(),
                role: "fake event loop".to_owned(),
                started: 1,
                running: 0,
            }
        );
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn long_thread_names_are_matched_by_their_first_15_bytes() {
        // What RustDDS does: a long name, of which the kernel keeps 15 bytes.
        let (_stop, _t) = fake_loop("watchtest2 Participant 0 event loop");
        let watch = ThreadWatch::new(Path::new(PROC_SELF_TASK), &[("watchtest2 Part", "x")]);
        assert!(watch.unwatched().is_empty());
        assert_eq!(watch.check(), None);
    }

    #[test]
    fn without_a_task_directory_nothing_is_watched_and_nothing_is_reported() {
        let dir = tempfile::tempdir().expect("tempdir");
        let missing = dir.path().join("no-such-dir");
        let watch = ThreadWatch::new(&missing, &RUSTDDS_THREADS);
        assert_eq!(watch.unwatched().len(), RUSTDDS_THREADS.len());
        assert_eq!(watch.check(), None);
    }

    #[test]
    fn a_task_directory_that_disappears_is_not_taken_for_a_dead_thread() {
        // A fake /proc/self/task: one thread directory with a comm file.
        let dir = tempfile::tempdir().expect("tempdir");
        let task = dir.path().join("task");
        std::fs::create_dir_all(task.join("101")).expect("mkdir");
        std::fs::write(task.join("101/comm"), "RustDDS Partici\n").expect("write");
        let watch = ThreadWatch::new(&task, &RUSTDDS_THREADS[..1]);
        assert!(watch.unwatched().is_empty());
        assert_eq!(watch.check(), None);
        std::fs::remove_dir_all(&task).expect("rm");
        assert_eq!(watch.check(), None, "unreadable is not dead");
        std::fs::create_dir_all(task.join("102")).expect("mkdir");
        std::fs::write(task.join("102/comm"), "other\n").expect("write");
        assert_eq!(watch.check().map(|e| e.running), Some(0));
    }
}
