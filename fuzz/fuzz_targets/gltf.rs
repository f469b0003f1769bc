//! cargo-fuzz target: `lobe_tests::fuzz::run("gltf", ...)`.
#![no_main]
mod common;
lobe_target!("gltf");
