//! cargo-fuzz target: `lobe_tests::fuzz::run("rgl", ...)`.
#![no_main]
mod common;
lobe_target!("rgl");
