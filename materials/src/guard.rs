//! The last line of defence around third-party readers (gltf, exr, image): a panic
//! inside one becomes the usual one-line error naming the file instead of a crash.
//!
//! lobe validates what it can before handing bytes to a reader (glTF cross-references,
//! accessors and node graph, GLB and OpenEXR headers), but a reader crate can still panic
//! on input that nothing checks yet (gltf 1.4.1 reached `unreachable!()` on float indices;
//! its buffer-URI decoding unwraps). [`third_party`] runs such a call under
//! `std::panic::catch_unwind` with the panic message silenced on the calling thread (a
//! process-wide hook installed once defers to the previous hook on every other thread and
//! whenever no guard is active), and counts what it caught in [`caught_panics`]: the fuzz
//! targets assert that count stays zero, so reaching this fallback is still a bug to fix
//! with a proper check, while a user only ever sees one line.
//!
//! Unwinding must stay enabled: `panic = "abort"` in a build profile would turn every such
//! panic back into an abort, so this module refuses to compile under it.

#[cfg(panic = "abort")]
compile_error!(
    "lobe needs panic = \"unwind\": third-party readers run under catch_unwind (materials/src/guard.rs)"
);

use std::cell::Cell;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Once;
use std::sync::atomic::{AtomicUsize, Ordering};

thread_local! {
    /// Guards active on this thread (nested calls are allowed).
    static ACTIVE: Cell<usize> = const { Cell::new(0) };
}

static CAUGHT: AtomicUsize = AtomicUsize::new(0);
static HOOK: Once = Once::new();

/// Panics caught by [`third_party`] since the process started.
pub fn caught_panics() -> usize {
    CAUGHT.load(Ordering::Relaxed)
}

fn install_hook() {
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if ACTIVE.with(Cell::get) == 0 {
                previous(info);
            }
        }));
    });
}

/// Runs `f`, a call into the third-party reader `reader`; a panic inside it becomes
/// `Err("the <reader> reader failed (<first line of its message>); the file is probably
/// malformed")`, for the caller to prefix with the file name.
pub fn third_party<T>(reader: &str, f: impl FnOnce() -> T) -> Result<T, String> {
    install_hook();
    ACTIVE.with(|a| a.set(a.get() + 1));
    let r = catch_unwind(AssertUnwindSafe(f));
    ACTIVE.with(|a| a.set(a.get() - 1));
    r.map_err(|payload| {
        CAUGHT.fetch_add(1, Ordering::Relaxed);
        let msg = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "no message".into());
        let msg = msg.lines().next().unwrap_or("").to_string();
        format!("the {reader} reader failed ({msg}); the file is probably malformed")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_becomes_a_one_line_error() {
        let before = caught_panics();
        let r: Result<(), String> =
            third_party("gltf", || panic!("entered unreachable code\nmore"));
        assert_eq!(
            r.unwrap_err(),
            "the gltf reader failed (entered unreachable code); the file is probably malformed"
        );
        assert!(caught_panics() > before);
        assert_eq!(third_party("y", || 7), Ok(7));
    }
}
