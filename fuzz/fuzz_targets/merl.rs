//! cargo-fuzz target: `lobe_tests::fuzz::run("merl", ...)`.
#![no_main]
mod common;
lobe_target!("merl");
