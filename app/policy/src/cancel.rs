//! Stopping long work from outside: a caller runs work under a flag
//! ([`scoped`]), and the loops that take seconds to minutes (finetuning on
//! demonstrations) ask [`check`] once a step and stop with
//! [`PolicyError::Stopped`] once the flag is raised. The debugger raises it
//! when the page that asked for a replay leaves while the replay's models
//! are being finetuned; nothing half made is kept.
//!
//! The flag is the calling thread's: work outside [`scoped`] never stops.

use std::cell::RefCell;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::error::PolicyError;

thread_local! {
    static FLAG: RefCell<Option<(Arc<AtomicBool>, String)>> = const { RefCell::new(None) };
}

/// Runs `work` on this thread with `flag` as its stop flag; `why` says, in
/// the stop's error, what raised it. The previous flag is restored after.
pub fn scoped<T>(flag: Arc<AtomicBool>, why: &str, work: impl FnOnce() -> T) -> T {
    let before = FLAG.with_borrow_mut(|f| f.replace((flag, why.to_owned())));
    struct Restore(Option<(Arc<AtomicBool>, String)>);
    impl Drop for Restore {
        fn drop(&mut self) {
            let before = self.0.take();
            FLAG.with_borrow_mut(|f| *f = before);
        }
    }
    let _restore = Restore(before);
    work()
}

/// `Err(PolicyError::Stopped)` once this thread's flag is raised.
pub fn check(what: &str) -> Result<(), PolicyError> {
    FLAG.with_borrow(|f| match f {
        Some((flag, why)) if flag.load(Ordering::Relaxed) => Err(PolicyError::Stopped {
            what: what.to_owned(),
            why: why.clone(),
        }),
        _ => Ok(()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn work_stops_once_its_flag_is_raised_and_only_inside_its_scope() {
        let flag = Arc::new(AtomicBool::new(false));
        assert!(check("x").is_ok());
        let e = scoped(flag.clone(), "the page left", || {
            assert!(check("finetuning").is_ok());
            flag.store(true, Ordering::Relaxed);
            check("finetuning").expect_err("raised")
        });
        assert_eq!(e.to_string(), "finetuning stopped: the page left");
        assert!(check("x").is_ok(), "the flag ends with its scope");
    }
}
