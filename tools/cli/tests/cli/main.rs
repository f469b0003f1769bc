//! The `lobe` binary as a user meets it: a render writes EXR, PNG and JSON atomically;
//! bad input gives one line on stderr and a non-zero exit, and leaves nothing behind.

mod common;
mod compare;
mod eval;
mod figures;
mod fit;
mod measured;
mod render;
mod safety;
mod stability;
mod study;
