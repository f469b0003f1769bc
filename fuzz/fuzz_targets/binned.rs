//! cargo-fuzz target: `lobe_tests::fuzz::run("binned", ...)`.
#![no_main]
mod common;
lobe_target!("binned");
