//! Is a named thread of this process still running? The recorder's watchdog over RustDDS.
//!
//! RustDDS receives on two threads of its own, the participant's event loop and discovery. When
//! one of them ends (RustDDS 0.15.1 ended both on any `poll` error, EINTR after a stop and
//! continue included: `third_party/rustdds-0.15.1/PATCHES.md`), it logs an error and nothing
//! more arrives; no status, listener or handle in its API says so. What is observable is the
//! thread itself: on Linux every thread of the process is a directory `/proc/self/task/<tid>`
//! whose `comm` file holds its name (the first 15 bytes, which is what `std::thread::Builder`
//! gives the kernel).
//!
//! [`TaskSnapshot::now`] lists the threads before the participant is built;
//! [`ThreadWatch::started_since`] then watches the threads that appeared meanwhile under each
//! watched name prefix (so the threads of another participant in the same process are not
//! mistaken for this one's), and [`ThreadWatch::check`] reports one that no longer runs.
//!
//! Where `/proc/self/task` cannot be read (not Linux) or no new thread had a prefix (RustDDS
//! renamed its threads), that prefix is not watched: [`ThreadWatch::unwatched`] names it so the
//! caller can say so. A read that fails later is taken as "still running": the watchdog never
//! ends a recording on a guess.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Where Linux lists the threads of the calling process.
pub const PROC_SELF_TASK: &str = "/proc/self/task";

/// Thread-name prefixes of RustDDS 0.15.1, as the kernel holds them (15 bytes), and what each
/// thread does: "RustDDS Participant {id} event loop" and "RustDDS discovery thread".
pub const RUSTDDS_THREADS: [(&str, &str); 2] = [
    ("RustDDS Partici", "event loop (sockets, readers, writers)"),
    ("RustDDS discove", "discovery loop"),
];

/// The thread ids listed in a task directory at one moment (empty if it cannot be read).
#[derive(Debug, Clone, Default)]
pub struct TaskSnapshot {
    tids: BTreeSet<String>,
}

impl TaskSnapshot {
    /// The threads in `task_dir` (normally [`PROC_SELF_TASK`]) now.
    #[must_use]
    pub fn now(task_dir: &Path) -> TaskSnapshot {
        TaskSnapshot {
            tids: thread_names(task_dir)
                .unwrap_or_default()
                .into_iter()
                .map(|(tid, _)| tid)
                .collect(),
        }
    }
}

/// Threads to keep an eye on, by thread id, grouped by name prefix.
#[derive(Debug, Clone)]
pub struct ThreadWatch {
    task_dir: PathBuf,
    /// (prefix, what the thread does, ids of the threads it names), for prefixes that matched.
    watched: Vec<(String, String, Vec<String>)>,
    unwatched: Vec<String>,
}

/// A watched thread that is no longer running.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EndedThread {
    /// Name prefix of the thread, as in `/proc/self/task/*/comm`.
    pub prefix: String,
    /// What the thread did.
    pub role: String,
    /// How many such threads were watched.
    pub started: usize,
    /// How many of them run now.
    pub running: usize,
}

impl ThreadWatch {
    /// Watches the threads in `task_dir` that are not in `before` and whose name starts with a
    /// `(prefix, role)` of `threads`.
    #[must_use]
    pub fn started_since(
        task_dir: &Path,
        before: &TaskSnapshot,
        threads: &[(&str, &str)],
    ) -> ThreadWatch {
        let names = thread_names(task_dir).unwrap_or_default();
        let mut watch = ThreadWatch {
            task_dir: task_dir.to_path_buf(),
            watched: Vec::new(),
            unwatched: Vec::new(),
        };
        for &(prefix, role) in threads {
            let tids: Vec<String> = (names.iter())
                .filter(|(tid, name)| !before.tids.contains(tid) && name.starts_with(prefix))
                .map(|(tid, _)| tid.clone())
                .collect();
            if tids.is_empty() {
                watch.unwatched.push(prefix.to_owned());
            } else {
                (watch.watched).push((prefix.to_owned(), role.to_owned(), tids));
            }
        }
        watch
    }

    /// Prefixes that cannot be watched: no new thread of that name, or no `task_dir`.
    #[must_use]
    pub fn unwatched(&self) -> &[String] {
        &self.unwatched
    }

    /// The first watched thread that no longer runs, if any. `None` also when `task_dir`
    /// cannot be read now.
    #[must_use]
    pub fn check(&self) -> Option<EndedThread> {
        let names: Vec<(String, String)> = thread_names(&self.task_dir)?;
        self.watched.iter().find_map(|(prefix, role, tids)| {
            let running = (tids.iter())
                .filter(|tid| {
                    (names.iter()).any(|(t, name)| t == *tid && name.starts_with(prefix.as_str()))
                })
                .count();
            (running < tids.len()).then(|| EndedThread {
                prefix: prefix.clone(),
                role: role.clone(),
                started: tids.len(),
                running,
            })
        })
    }
}

/// (thread id, name) of every thread listed in `task_dir`; `None` if it cannot be listed.
/// A thread that ends while this reads is skipped.
fn thread_names(task_dir: &Path) -> Option<Vec<(String, String)>> {
    let entries = std::fs::read_dir(task_dir).ok()?;
    Some(
        entries
            .filter_map(Result::ok)
            .filter_map(|e| {
                let name = std::fs::read_to_string(e.path().join("comm")).ok()?;
                let tid = e.file_name().to_string_lossy().into_owned();
                Some((tid, name.trim_end_matches('\n').to_owned()))
            })
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
        let task = Path::new(PROC_SELF_TASK);
        let before = TaskSnapshot::now(task);
        let (stop_a, a) = fake_loop("watchtest loopA");
        let (_stop_b, _b) = fake_loop("watchtest loopB");
        let threads = [
            ("watchtest loopA", "fake event loop"),
            ("watchtest loopB", "fake discovery"),
            ("watchtest none", "never started"),
        ];
        let watch = ThreadWatch::started_since(task, &before, &threads);
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
    fn threads_that_ran_before_the_snapshot_are_not_watched() {
        // Another participant's loop (same name) that ends is not this one's.
        let task = Path::new(PROC_SELF_TASK);
        let (stop_old, old) = fake_loop("watchtest3 loop");
        let before = TaskSnapshot::now(task);
        let (_stop_new, _new) = fake_loop("watchtest3 loop");
        let watch = ThreadWatch::started_since(task, &before, &[("watchtest3 loop", "x")]);
        assert!(watch.unwatched().is_empty());
        drop(stop_old);
        old.join().expect("join");
        std::thread::sleep(Duration::from_millis(50));
        assert_eq!(watch.check(), None);
        // Nothing new since the snapshot: nothing to watch.
        let later = TaskSnapshot::now(task);
        let none = ThreadWatch::started_since(task, &later, &[("watchtest3 loop", "x")]);
        assert_eq!(none.unwatched(), ["watchtest3 loop".to_owned()]);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn long_thread_names_are_matched_by_their_first_15_bytes() {
        // What RustDDS does: a long name, of which the kernel keeps 15 bytes.
        let task = Path::new(PROC_SELF_TASK);
        let before = TaskSnapshot::now(task);
        let (_stop, _t) = fake_loop("watchtest2 Participant 0 event loop");
        let watch = ThreadWatch::started_since(task, &before, &[("watchtest2 Part", "x")]);
        assert!(watch.unwatched().is_empty());
        assert_eq!(watch.check(), None);
    }

    #[test]
    fn without_a_task_directory_nothing_is_watched_and_nothing_is_reported() {
        let dir = tempfile::tempdir().expect("tempdir");
        let missing = dir.path().join("no-such-dir");
        let before = TaskSnapshot::now(&missing);
        let watch = ThreadWatch::started_since(&missing, &before, &RUSTDDS_THREADS);
        assert_eq!(watch.unwatched().len(), RUSTDDS_THREADS.len());
        assert_eq!(watch.check(), None);
    }

    #[test]
    fn a_task_directory_that_disappears_is_not_taken_for_a_dead_thread() {
        // A fake /proc/self/task: a thread that was there before, and one started after.
        let dir = tempfile::tempdir().expect("tempdir");
        let task = dir.path().join("task");
        let thread = |tid: &str, name: &str| {
            std::fs::create_dir_all(task.join(tid)).expect("mkdir");
            std::fs::write(task.join(tid).join("comm"), format!("{name}\n")).expect("write");
        };
        thread("100", "main");
        let before = TaskSnapshot::now(&task);
        thread("101", "RustDDS Partici");
        let watch = ThreadWatch::started_since(&task, &before, &RUSTDDS_THREADS);
        assert_eq!(watch.unwatched(), ["RustDDS discove".to_owned()]);
        assert_eq!(watch.check(), None);
        std::fs::remove_dir_all(&task).expect("rm");
        assert_eq!(watch.check(), None, "unreadable is not dead");
        thread("100", "main");
        thread("102", "RustDDS Partici"); // another thread of that name is not the one watched
        assert_eq!(watch.check().map(|e| (e.started, e.running)), Some((1, 0)));
    }
}
