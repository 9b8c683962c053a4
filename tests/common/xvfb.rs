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

/// `coatlab` set to run on `display` with `runtime` as its XDG_RUNTIME_DIR, its
/// standard output and error to `log`, and no Wayland display or session bus of the
/// person running the tests in reach; the caller adds arguments and spawns it.
pub fn coatlab_on(display: &str, runtime: &Path, log: &Path) -> Command {
    let log = std::fs::File::create(log).expect("log file");
    let mut command = Command::new(env!("CARGO_BIN_EXE_coatlab"));
    command
        .env("DISPLAY", display)
        .env("XDG_RUNTIME_DIR", runtime)
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("DBUS_SESSION_BUS_ADDRESS")
        .stdout(log.try_clone().expect("log"))
        .stderr(log);
    command
}

/// A `coatlab` process under test on a virtual display, with `S`, the test's own
/// state beside it: the polling, window look-ups, log reading and screenshots that
/// the tests which drive the real binary share.
pub struct UnderX<S> {
    pub display: String,
    pub app: Reaped,
    /// The file the app's standard output and error go to.
    pub log: PathBuf,
    /// Where a timeout leaves a screenshot; none where `None`.
    pub shots: Option<PathBuf>,
    pub state: S,
}

impl<S> UnderX<S> {
    pub fn log_text(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// The first top-level window whose name matches `regex`.
    pub fn first_window(&self, regex: &str) -> Option<String> {
        let out = xdotool(&self.display, &["search", "--name", regex]);
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .next()
            .map(str::to_owned)
    }

    pub fn window_name(&self, id: &str) -> String {
        let out = xdotool(&self.display, &["getwindowname", id]);
        String::from_utf8_lossy(&out.stdout).trim_end().to_owned()
    }

    /// The whole screen to `<shots>/<name>.png`, where ImageMagick is installed:
    /// the file's path, or why there is none.
    pub fn screenshot(&self, name: &str) -> String {
        let Some(shots) = &self.shots else {
            return "no folder for screenshots".into();
        };
        if !have("import") {
            return "no ImageMagick for a screenshot".into();
        }
        let path = shots.join(format!("{name}.png"));
        let taken = Command::new("import")
            .args(["-display", &self.display, "-window", "root"])
            .arg(&path)
            .status()
            .is_ok_and(|s| s.success());
        if taken {
            path.display().to_string()
        } else {
            "import failed".into()
        }
    }

    /// Polls `check` every 100 ms until it gives a value; fails with `what`, the
    /// app's log and a screenshot after `timeout`, or as soon as the app exits.
    pub fn wait<T>(
        &mut self,
        what: &str,
        timeout: Duration,
        mut check: impl FnMut(&Self) -> Option<T>,
    ) -> T {
        let start = std::time::Instant::now();
        loop {
            if let Some(v) = check(self) {
                return v;
            }
            if let Some(status) = self.app.0.try_wait().expect("poll coatlab") {
                panic!(
                    "coatlab exited ({status}) waiting for {what}:\n{}",
                    self.log_text()
                );
            }
            if start.elapsed() > timeout {
                panic!(
                    "no {what} after {:.0} s (screen: {}); coatlab's log:\n{}",
                    timeout.as_secs_f64(),
                    self.screenshot("timeout"),
                    self.log_text()
                );
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}
