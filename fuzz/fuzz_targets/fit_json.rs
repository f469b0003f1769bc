//! cargo-fuzz target: `lobe_tests::fuzz::run("fit_json", ...)`.
#![no_main]
mod common;
lobe_target!("fit_json");
