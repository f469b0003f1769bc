//! cargo-fuzz target: `lobe_tests::fuzz::run("ply", ...)`.
#![no_main]
mod common;
lobe_target!("ply");
