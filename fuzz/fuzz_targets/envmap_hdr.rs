//! cargo-fuzz target: `lobe_tests::fuzz::run("envmap_hdr", ...)`.
#![no_main]
mod common;
lobe_target!("envmap_hdr");
