//! cargo-fuzz target: `lobe_tests::fuzz::run("obj", ...)`.
#![no_main]
mod common;
lobe_target!("obj");
