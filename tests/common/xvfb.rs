//! A private virtual X server (Xvfb) and the directories the `coatlab` binary runs
//! in under it: shared by the smoke test (tests/gui_smoke.rs) and the real-window
//! part of the responsiveness bench (crates/coatlab-app/benches/gui_responsiveness.rs).
#![allow(dead_code)] // each crate uses its own subset

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Kills and reaps the child when dropped, so a failing assertion leaves nothing behind.
pub struct Reaped(pub Child);

impl Drop for Reaped {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

pub fn have(tool: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {tool}")])
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// `dir/runtime` (mode 0700, as XDG_RUNTIME_DIR must be) and a fresh `dir/state`
/// (the app's autosave and recent files), so a run never touches the user's.
pub fn app_dirs(dir: &Path) -> std::io::Result<(PathBuf, PathBuf)> {
    let runtime = dir.join("runtime");
    let state = dir.join("state");
    let _ = std::fs::remove_dir_all(&state);
    std::fs::create_dir_all(&runtime)?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let _ = std::fs::set_permissions(&runtime, std::fs::Permissions::from_mode(0o700));
    }
    Ok((runtime, state))
}

/// Starts Xvfb (1600×1000×24) on a display number of our own, `base` + the process
/// id modulo 500, so parallel runs do not meet, and waits up to 10 s for its
/// socket. Returns the server and its `DISPLAY`.
pub fn start_xvfb(base: u32) -> Result<(Reaped, String), String> {
    let display = format!(":{}", base + std::process::id() % 500);
    let xvfb = Command::new("Xvfb")
        .args([
            display.as_str(),
            "-screen",
            "0",
            "1600x1000x24",
            "-nolisten",
            "tcp",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .map(Reaped)
        .map_err(|e| format!("cannot start Xvfb: {e}"))?;
    let socket = PathBuf::from(format!("/tmp/.X11-unix/X{}", &display[1..]));
    let start = Instant::now();
    while !socket.exists() && start.elapsed() < Duration::from_secs(10) {
        std::thread::sleep(Duration::from_millis(100));
    }
    if !socket.exists() {
        return Err(format!("Xvfb did not start on {display}"));
    }
    Ok((xvfb, display))
}
