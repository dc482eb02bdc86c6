//! Ctrl-C and `SIGTERM` as a flag: long jobs (`record`, `render`, `trim`) poll it between steps
//! and end cleanly — what is complete is kept, partial files are removed — instead of dying
//! mid-write.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

/// The flag every handler sets; installed at most once per process.
static INSTALLED: Mutex<Option<Arc<AtomicBool>>> = Mutex::new(None);

/// Installing the signal handlers failed.
#[derive(Debug, thiserror::Error)]
#[error("cannot install the signal handler")]
pub struct InterruptError {
    /// The cause.
    #[source]
    source: std::io::Error,
}

/// Set once `SIGINT` (Ctrl-C) or `SIGTERM` arrived.
#[derive(Debug, Clone)]
pub struct Interrupt {
    flag: Arc<AtomicBool>,
}

impl Interrupt {
    /// Installs the `SIGINT` and `SIGTERM` handlers (the first call; later calls share the same
    /// flag) and returns the flag they set.
    ///
    /// # Errors
    /// [`InterruptError`] when the operating system refuses a handler.
    pub fn install() -> Result<Interrupt, InterruptError> {
        let mut installed = INSTALLED.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(flag) = installed.as_ref() {
            return Ok(Interrupt {
                flag: Arc::clone(flag),
            });
        }
        let flag = Arc::new(AtomicBool::new(false));
        for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
            signal_hook::flag::register(signal, Arc::clone(&flag))
                .map_err(|source| InterruptError { source })?;
        }
        *installed = Some(Arc::clone(&flag));
        Ok(Interrupt { flag })
    }

    /// A flag no signal sets, for jobs run without signal handling (tests, embedding).
    #[must_use]
    pub fn never() -> Interrupt {
        Interrupt {
            flag: Arc::new(AtomicBool::new(false)),
        }
    }

    /// Whether a signal arrived.
    #[must_use]
    pub fn is_set(&self) -> bool {
        self.flag.load(Ordering::Relaxed)
    }

    /// The flag itself, for library functions that poll an [`AtomicBool`].
    #[must_use]
    pub fn flag(&self) -> &AtomicBool {
        &self.flag
    }
}

#[cfg(test)]
mod tests {
    use super::Interrupt;

    #[test]
    fn installing_twice_shares_one_flag() {
        let a = Interrupt::install().unwrap();
        let b = Interrupt::install().unwrap();
        assert!(std::ptr::eq(a.flag(), b.flag()));
        assert!(!Interrupt::never().is_set());
    }
}
