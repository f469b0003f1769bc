//! cargo-fuzz target: `lobe_tests::fuzz::run("envmap_exr", ...)`.
#![no_main]
mod common;
lobe_target!("envmap_exr");
