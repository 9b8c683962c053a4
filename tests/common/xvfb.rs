//! A private virtual X server (Xvfb) and the directories the `coatlab` binary runs
//! in under it: shared by the smoke test (tests/gui_smoke.rs), the crash-recovery test
//! (tests/gui_crash.rs), the system file dialog test and the real-window
//! part of the responsiveness bench (crates/coatlab-app/benches/gui_responsiveness.rs).
#![allow(dead_code)] // each crate uses its own subset

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

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

/// Starts Xvfb (1600×1000×24) on a display number it picks itself and returns the
/// server and its `DISPLAY` once it accepts connections.
///
/// `-displayfd` makes Xvfb choose a free display and write its number to our pipe
/// only when it is listening. Choosing a number ourselves and waiting for its
/// socket file raced: servers killed by an earlier run leave `/tmp/.X11-unix/XN`
/// behind, the file "exists" before the new server listens, and the app then
/// failed with "Failed to open connection to X server" (seen in a CI run). That
/// message was still seen now and then with `-displayfd` on a machine where other
/// test runs start and kill X servers too, so the server must also answer an X11
/// connection set-up the way a client makes it ([`accepts_clients`]); a server that
/// does not is killed and another started.
pub fn start_xvfb() -> Result<(Reaped, String), String> {
    let mut failures = Vec::new();
    for _ in 0..3 {
        let (xvfb, number) = spawn_xvfb()?;
        if accepts_clients(number, Duration::from_secs(10)) {
            return Ok((xvfb, format!(":{number}")));
        }
        failures.push(format!(":{number}"));
        drop(xvfb);
    }
    Err(format!(
        "Xvfb reported displays {} but none accepted an X11 connection",
        failures.join(", ")
    ))
}

fn spawn_xvfb() -> Result<(Reaped, u32), String> {
    use std::io::BufRead;
    let mut child = Command::new("Xvfb")
        .args([
            "-displayfd",
            "1",
            "-screen",
            "0",
            "1600x1000x24",
            "-nolisten",
            "tcp",
            // Without it the server resets whenever its last client disconnects
            // (our connection check, or an app killed by a test), and a client
            // connecting during the reset fails with "Failed to open connection to
            // X server".
            "-noreset",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .map_err(|e| format!("cannot start Xvfb: {e}"))?;
    let stdout = child.stdout.take();
    let xvfb = Reaped(child);
    let Some(stdout) = stdout else {
        return Err("Xvfb's standard output is not a pipe".into());
    };
    // Read on a thread so a server that never answers costs a timeout, not a hang;
    // the thread ends when the server is killed and its pipe closes.
    let (sender, receiver) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let read = std::io::BufReader::new(stdout).read_line(&mut line);
        let _ = sender.send(read.map(|_| line));
    });
    match receiver.recv_timeout(Duration::from_secs(20)) {
        Ok(Ok(line)) => match line.trim().parse::<u32>() {
            Ok(number) => Ok((xvfb, number)),
            Err(_) => Err(format!("Xvfb wrote {line:?} instead of its display number")),
        },
        Ok(Err(e)) => Err(format!("cannot read Xvfb's display number: {e}")),
        Err(_) => Err("Xvfb did not report a display within 20 s".into()),
    }
}

/// Whether display `number` completes an X11 connection set-up (no authorisation)
/// within `timeout`: over the abstract socket where it can be connected, else the
/// socket file, which is the order libxcb tries them in on Linux.
#[cfg(target_os = "linux")]
pub fn accepts_clients(number: u32, timeout: Duration) -> bool {
    use std::io::{Read, Write};
    use std::os::linux::net::SocketAddrExt;
    use std::os::unix::net::{SocketAddr, UnixStream};
    let path = format!("/tmp/.X11-unix/X{number}");
    let connect = || {
        SocketAddr::from_abstract_name(path.as_bytes())
            .and_then(|a| UnixStream::connect_addr(&a))
            .or_else(|_| UnixStream::connect(&path))
    };
    // Byte order 'l' (little-endian), protocol 11.0, no authorisation.
    let request = [b'l', 0, 11, 0, 0, 0, 0, 0, 0, 0, 0, 0];
    let start = std::time::Instant::now();
    while start.elapsed() < timeout {
        let answered = connect().and_then(|mut stream| {
            stream.set_read_timeout(Some(Duration::from_secs(2)))?;
            stream.write_all(&request)?;
            let mut status = [0u8; 1];
            stream.read_exact(&mut status)?;
            Ok(status[0])
        });
        // 1: Success (0 would be Failed, 2 Authenticate).
        if let Ok(1) = answered {
            return true;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    false
}

#[cfg(not(target_os = "linux"))]
pub fn accepts_clients(_number: u32, _timeout: Duration) -> bool {
    true
}

/// Runs `xdotool args` on `display`; killed after 20 s (a `--sync` that never sees
/// its event would otherwise hang the test).
pub fn xdotool(display: &str, args: &[&str]) -> std::process::Output {
    let mut child = Command::new("xdotool")
        .args(args)
        .env("DISPLAY", display)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run xdotool");
    let start = std::time::Instant::now();
    while child.try_wait().expect("poll xdotool").is_none() {
        if start.elapsed() > Duration::from_secs(20) {
            let _ = child.kill();
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().expect("xdotool's output")
}

/// Whether the tests that drive the real binary must run: CI (`CI`, which
/// `.ci/run` exports) or `COATLAB_REQUIRE_GUI_SMOKE` set to anything but empty.
pub fn gui_tools_required() -> bool {
    ["CI", "COATLAB_REQUIRE_GUI_SMOKE"]
        .iter()
        .any(|v| std::env::var_os(v).is_some_and(|x| !x.is_empty()))
}
