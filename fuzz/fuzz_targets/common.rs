//! Shared by the cargo-fuzz targets: one scratch folder per process, and the macro that
//! makes a target of `lobe_tests::fuzz::run(NAME, ...)`.

pub fn scratch() -> &'static std::path::Path {
    static DIR: std::sync::OnceLock<tempfile::TempDir> = std::sync::OnceLock::new();
    DIR.get_or_init(|| tempfile::tempdir().expect("scratch folder")).path()
}

#[macro_export]
macro_rules! lobe_target {
    ($name:literal) => {
        libfuzzer_sys::fuzz_target!(|data: &[u8]| {
            lobe_tests::fuzz::run($name, data, common::scratch());
        });
    };
}
