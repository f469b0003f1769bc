//! cargo-fuzz target: `lobe_tests::fuzz::run("scene_json", ...)`.
#![no_main]
mod common;
lobe_target!("scene_json");
