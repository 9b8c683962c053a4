//! How a run of a command-line program ended: its output on success, its exit
//! status and message on failure. Shared by the tests of `coatlab` and of the xtask
//! (`xtask/tests/`, which include this file by path), whose exit statuses agree.
#![allow(dead_code)] // each test crate uses its own subset

use std::process::Output;

pub fn stdout(output: &Output) -> String {
    assert!(
        output.status.success(),
        "the command failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout.clone()).expect("UTF-8 output")
}

/// The exit statuses of `coatlab` (README, "Exit status") and of the xtask.
pub mod exit {
    pub const USAGE: i32 = 2;
    pub const DATA: i32 = 65;
    pub const NO_INPUT: i32 = 66;
    pub const CANT_CREATE: i32 = 73;
    pub const BROKEN_PIPE: i32 = 141;
}

/// The stderr of a run that must have failed with exactly `code` (a panic's 101,
/// a signal or another class fails the test), printed no panic, and said why.
pub fn failure(output: &Output, code: i32) -> String {
    let stderr = String::from_utf8(output.stderr.clone()).expect("UTF-8 stderr");
    assert_eq!(
        output.status.code(),
        Some(code),
        "expected exit status {code}; stderr: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!stderr.trim().is_empty(), "a failure says why");
    stderr
}

/// Asserts that `text` (a message or an output line) says every one of `fragments`,
/// naming the first one it lacks.
#[track_caller]
pub fn assert_mentions(text: &str, fragments: &[&str]) {
    if let Some(missing) = fragments.iter().find(|f| !text.contains(**f)) {
        panic!("expected {missing:?} in:\n{text}");
    }
}
