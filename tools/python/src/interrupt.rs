//! Long work (renders, fits) from Python with progress and Ctrl-C: the work runs on a
//! thread of its own with the GIL released, and posts progress events; the calling thread
//! (Python's main thread in a script or a notebook) waits for them, and wakes at least
//! every [`POLL`] to hand them to Python and to check for signals. Python runs its signal
//! handlers only on the main thread, so this is where Ctrl-C (a notebook's interrupt) is
//! seen: a `KeyboardInterrupt`, or any exception from the Python progress callback, sets
//! the work's cancel flag (the renderer's and the fitter's own, the flag the CLI's Ctrl-C
//! handler sets), waits for it to stop and is raised. No Python code runs on the work's
//! threads.

use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

/// How long the calling thread sleeps at most between two checks for signals.
const POLL: Duration = Duration::from_millis(100);

/// What the work shares with the calling thread (a handle: clones share it): its progress
/// events, whether it has finished, and the flag that asks it to stop.
pub(crate) struct Events<P>(Arc<Shared<P>>);

pub(crate) struct Shared<P> {
    state: Mutex<(Vec<P>, bool)>,
    ready: Condvar,
    pub cancel: Arc<AtomicBool>,
}

impl<P> Clone for Events<P> {
    fn clone(&self) -> Self {
        Events(self.0.clone())
    }
}

impl<P> std::ops::Deref for Events<P> {
    type Target = Shared<P>;
    fn deref(&self) -> &Shared<P> {
        &self.0
    }
}

impl<P> Shared<P> {
    /// Hands an event to the calling thread (cheap: a lock and a push).
    pub fn post(&self, event: P) {
        let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        s.0.push(event);
        self.ready.notify_all();
    }

    fn finish(&self) {
        self.state.lock().unwrap_or_else(|e| e.into_inner()).1 = true;
        self.ready.notify_all();
    }

    /// The events posted since the last call (waiting up to `POLL` for one) and whether
    /// the work has finished.
    fn wait(&self) -> (Vec<P>, bool) {
        let s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        let (mut s, _) = self
            .ready
            .wait_timeout_while(s, POLL, |s| s.0.is_empty() && !s.1)
            .unwrap_or_else(|e| e.into_inner());
        (std::mem::take(&mut s.0), s.1)
    }
}

/// Marks the work finished when it returns or panics, so the calling thread never waits
/// for a thread that is gone.
struct Finish<'a, P>(&'a Shared<P>);

impl<P> Drop for Finish<'_, P> {
    fn drop(&mut self) {
        self.0.finish();
    }
}

/// Runs `work` without the GIL on a thread of its own, calling `on_events` (with the GIL,
/// on the calling thread, in order) with the events it posts. Returns its result, or the
/// first error of `on_events` or of the signal checks (after the work has stopped); a
/// panic of the work is resumed here (for `guarded`).
pub(crate) fn run<T: Send, P: Send>(
    py: Python<'_>,
    work: impl FnOnce(&Events<P>) -> T + Send,
    mut on_events: impl FnMut(Python<'_>, Vec<P>) -> PyResult<()>,
) -> PyResult<T> {
    let events = Events(Arc::new(Shared {
        state: Mutex::new((Vec::new(), false)),
        ready: Condvar::new(),
        cancel: Arc::new(AtomicBool::new(false)),
    }));
    std::thread::scope(|s| {
        let worker = s.spawn(|| {
            let _finish = Finish(&events);
            work(&events)
        });
        let mut failure: Option<PyErr> = None;
        loop {
            let (batch, finished) = py.detach(|| events.wait());
            if failure.is_none() {
                let shown = if batch.is_empty() {
                    Ok(())
                } else {
                    on_events(py, batch)
                };
                if let Err(e) = shown.and_then(|()| py.check_signals()) {
                    events.cancel.store(true, Ordering::SeqCst);
                    failure = Some(e);
                }
            }
            if finished {
                break;
            }
        }
        let joined = py.detach(|| worker.join());
        let result = joined.unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        match failure {
            Some(e) => Err(e),
            None => Ok(result),
        }
    })
}
