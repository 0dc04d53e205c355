//! Helpers shared by the integration tests: sound example messages and proptest strategies.
//!
//! Each test file uses only part of this, hence the `dead_code` allowances.

#[allow(dead_code)]
pub mod checks;
#[allow(dead_code)]
pub mod examples;
#[allow(dead_code)]
pub mod strategies;

use std::path::PathBuf;

/// True when the tests should rewrite generated files instead of comparing against them.
#[allow(dead_code)]
pub fn regenerate() -> bool {
    std::env::var("REGENERATE").is_ok_and(|v| v == "1")
}

/// A path relative to the `proto` crate's directory.
#[allow(dead_code)]
pub fn crate_path(relative: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(relative)
}
