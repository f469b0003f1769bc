//! cargo-fuzz target: `lobe_tests::fuzz::run("partial_render", ...)`.
#![no_main]
mod common;
lobe_target!("partial_render");
