//! Choosing files: the system's file dialog where there is one, the in-app browser
//! otherwise.
//!
//! The system dialog is an XDG desktop portal's `org.freedesktop.portal.FileChooser`
//! through `rfd` (no GTK at build time: rfd loads libdbus at run time), or, where no
//! portal answers, `zenity --file-selection`, which this module runs itself (see
//! [`SystemFileDialog`] for what rfd's own zenity fallback gets wrong). Either
//! blocks until the person answers, so it runs on a thread of its own and the UI
//! keeps drawing; the answer arrives over a channel and asks for a repaint.
//!
//! rfd answers "no file" both when the person cancels and when it could show
//! nothing, so before the first dialog this module asks which back-end is there
//! ([`native_dialog_backend`]). Where neither is (a bare X session, Xvfb in CI),
//! the request opens the in-app browser instead and the status line says why,
//! once; the rest of the session uses the browser. The browser stays reachable
//! from the File menu ("Use the system file dialog" off). A zenity still showing
//! when the app closes is closed with it.
//!
//! The dialog is a trait object ([`NativeFileDialog`]) so the tests can stand in
//! for the system: a path, a cancel, or no dialog at all.

use std::ffi::OsString;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc::{Receiver, TryRecvError, channel};
use std::sync::{Arc, Mutex, OnceLock, PoisonError};

use super::file_browser::{FileBrowser, FilePurpose};

/// What a file dialog is asked for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DialogRequest {
    pub purpose: FilePurpose,
    /// The window title.
    pub title: String,
    /// The file types offered ("Design" → ["toml"]).
    pub filter_name: String,
    pub extensions: Vec<String>,
    /// Where the dialog starts.
    pub directory: PathBuf,
    /// The suggested file name (empty when opening).
    pub file_name: String,
    /// Whether a new file is named (save) rather than an existing one chosen.
    pub save: bool,
}

impl DialogRequest {
    /// The dialog for `purpose` (its title, filter and kind), starting in
    /// `directory` with `file_name` suggested.
    pub fn for_purpose(purpose: FilePurpose, directory: PathBuf, file_name: String) -> Self {
        Self {
            purpose,
            title: purpose.title().to_owned(),
            filter_name: purpose.filter_name().to_owned(),
            extensions: purpose
                .extensions()
                .iter()
                .map(|e| (*e).to_owned())
                .collect(),
            directory,
            file_name,
            save: purpose.is_save(),
        }
    }
}

/// How a file dialog ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DialogOutcome {
    /// The person chose this file.
    Chosen(PathBuf),
    /// The person closed the dialog without choosing.
    Cancelled,
    /// No dialog could be shown, and why.
    Unavailable(String),
}

/// A file dialog outside the app. `ask` blocks until the person answers; the app
/// calls it on a thread of its own, never on the UI thread.
pub trait NativeFileDialog: Send + Sync {
    fn ask(&self, request: &DialogRequest) -> DialogOutcome;

    /// Closes a dialog that is showing (the app is closing); `ask` then returns.
    fn close(&self) {}
}

/// Which system dialog answers on this machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NativeBackend {
    /// An XDG desktop portal's FileChooser on the session bus (through rfd).
    Portal,
    /// `zenity --file-selection`, run by this module.
    Zenity,
}

/// The system's file dialog: the XDG portal through rfd, else zenity run here.
///
/// Zenity is run by this module rather than through rfd's own fallback, which (rfd
/// 0.17) drops the title and the starting directory, reports a zenity that could
/// not open as a cancel, fails on a non-UTF-8 path, and first asks the portal again
/// with libdbus's default 25 s timeout when the bus is there but no portal answers.
#[derive(Debug, Default)]
pub struct SystemFileDialog {
    /// Which back-end is there, asked once per process: starting a portal or
    /// installing zenity later in the session is not noticed (the in-app browser
    /// serves).
    backend: OnceLock<Result<NativeBackend, String>>,
    /// The zenity process showing now, so that closing the app closes its dialog.
    running: Mutex<Option<Child>>,
}

impl NativeFileDialog for SystemFileDialog {
    fn ask(&self, request: &DialogRequest) -> DialogOutcome {
        match self.backend.get_or_init(native_dialog_backend).clone() {
            Err(reason) => DialogOutcome::Unavailable(reason),
            Ok(NativeBackend::Portal) => ask_portal(request),
            Ok(NativeBackend::Zenity) => self.ask_zenity(request),
        }
    }

    fn close(&self) {
        let mut running = self.running.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(child) = running.as_mut() {
            // Already gone is fine: the dialog's thread reaps it either way.
            let _ = child.kill();
        }
    }
}

/// The portal's dialog through rfd (which blocks until the person answers).
fn ask_portal(request: &DialogRequest) -> DialogOutcome {
    let extensions: Vec<&str> = request.extensions.iter().map(String::as_str).collect();
    let mut dialog = rfd::FileDialog::new()
        .set_title(&request.title)
        .add_filter(&request.filter_name, &extensions);
    if request.directory.is_dir() {
        dialog = dialog.set_directory(&request.directory);
    }
    if !request.file_name.is_empty() {
        dialog = dialog.set_file_name(&request.file_name);
    }
    let chosen = if request.save {
        dialog.save_file()
    } else {
        dialog.pick_file()
    };
    // The portal answered the probe, so "no file" is the person's cancel (should
    // the portal fail after all, rfd runs zenity, whose cancel reads the same).
    match chosen {
        Some(path) => DialogOutcome::Chosen(path),
        None => DialogOutcome::Cancelled,
    }
}

/// zenity's command line for `request`.
pub fn zenity_args(request: &DialogRequest) -> Vec<OsString> {
    let mut args: Vec<OsString> = vec!["--file-selection".into()];
    let mut title = OsString::from("--title=");
    title.push(&request.title);
    args.push(title);
    // `--filename` is where the dialog starts: a directory with its trailing slash
    // (open), or the suggested file in it (save). A bare name would be taken
    // relative to zenity's working directory, not the request's.
    let start = match (request.directory.is_dir(), request.file_name.is_empty()) {
        (true, true) => {
            let mut dir = request.directory.clone().into_os_string();
            if !dir.to_string_lossy().ends_with('/') {
                dir.push("/");
            }
            Some(dir)
        }
        (true, false) => Some(request.directory.join(&request.file_name).into_os_string()),
        (false, false) => Some(OsString::from(&request.file_name)),
        (false, true) => None,
    };
    if let Some(start) = start {
        let mut arg = OsString::from("--filename=");
        arg.push(start);
        args.push(arg);
    }
    if !request.extensions.is_empty() {
        // zenity's filter is "NAME | PATTERN PATTERN…": a '|' in the name would
        // split it, so it becomes '/'.
        let patterns: Vec<String> = request
            .extensions
            .iter()
            .map(|e| format!("*.{e}"))
            .collect();
        args.push(
            format!(
                "--file-filter={} ({}) | {}",
                request.filter_name.replace('|', "/"),
                patterns.join(", "),
                patterns.join(" ")
            )
            .into(),
        );
        args.push("--file-filter=All files | *".into());
    }
    if request.save {
        // zenity 3 asks before overwriting only when told; zenity 4 always asks and
        // ignores the flag (with a notice on stderr).
        args.push("--save".into());
        args.push("--confirm-overwrite".into());
    }
    args
}

/// What zenity's exit status and output mean: 0 with a path: chosen; 1 (Cancel,
/// Escape, the window closed) or 5 (its timeout): cancelled; anything else,
/// including a signal: the dialog failed, and its last line on stderr says why.
pub fn zenity_outcome(status: ExitStatus, stdout: &[u8], stderr: &[u8]) -> DialogOutcome {
    // One path and a newline; a path may itself end in spaces, so no trim.
    let path = stdout.strip_suffix(b"\n").unwrap_or(stdout);
    match status.code() {
        Some(0) if !path.is_empty() => DialogOutcome::Chosen(path_from_bytes(path)),
        Some(0) | Some(1) | Some(5) => DialogOutcome::Cancelled,
        _ => {
            let stderr = String::from_utf8_lossy(stderr);
            // GTK and dconf chatter comes first; the reason is the last line.
            let why = stderr
                .lines()
                .rev()
                .map(str::trim)
                .find(|l| !l.is_empty())
                .unwrap_or("no message");
            DialogOutcome::Unavailable(format!("zenity failed ({status}): {why}"))
        }
    }
}

#[cfg(unix)]
fn path_from_bytes(bytes: &[u8]) -> PathBuf {
    use std::os::unix::ffi::OsStrExt;
    PathBuf::from(std::ffi::OsStr::from_bytes(bytes))
}

#[cfg(not(unix))]
fn path_from_bytes(bytes: &[u8]) -> PathBuf {
    PathBuf::from(String::from_utf8_lossy(bytes).into_owned())
}

impl SystemFileDialog {
    /// Runs zenity for `request` and waits for it; stdout and stderr are read while
    /// it runs (GTK's warnings could otherwise fill the pipe and stall it).
    fn ask_zenity(&self, request: &DialogRequest) -> DialogOutcome {
        let spawned = Command::new("zenity")
            .args(zenity_args(request))
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn();
        let mut child = match spawned {
            Ok(child) => child,
            Err(e) => return DialogOutcome::Unavailable(format!("cannot run zenity: {e}")),
        };
        let stdout = child.stdout.take();
        let stderr = child.stderr.take();
        *self.running.lock().unwrap_or_else(PoisonError::into_inner) = Some(child);
        let stderr_reader = std::thread::spawn(move || {
            let mut buf = Vec::new();
            if let Some(mut e) = stderr {
                let _ = e.read_to_end(&mut buf);
            }
            buf
        });
        let mut out = Vec::new();
        let read = stdout.map(|mut o| o.read_to_end(&mut out));
        let err = stderr_reader.join().unwrap_or_default();
        let Some(mut child) = self
            .running
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take()
        else {
            return DialogOutcome::Unavailable("the zenity process was lost".into());
        };
        let status = match child.wait() {
            Ok(status) => status,
            Err(e) => return DialogOutcome::Unavailable(format!("waiting for zenity: {e}")),
        };
        if let Some(Err(e)) = read {
            return DialogOutcome::Unavailable(format!("reading zenity's answer: {e}"));
        }
        zenity_outcome(status, &out, &err)
    }
}

/// Whether rfd can show a dialog here: an XDG desktop portal with a FileChooser
/// answers on the session bus, or `zenity` runs. `Err` says what is missing.
pub fn native_dialog_availability() -> Result<(), String> {
    native_dialog_backend().map(|_| ())
}

/// Which system dialog is there: a portal answering on the session bus first,
/// then zenity (which needs an X or Wayland display). `Err` says what is missing.
pub fn native_dialog_backend() -> Result<NativeBackend, String> {
    let portal = match portal_file_chooser() {
        Ok(()) => return Ok(NativeBackend::Portal),
        Err(portal) => portal,
    };
    let has_display = ["DISPLAY", "WAYLAND_DISPLAY"]
        .iter()
        .any(|v| std::env::var_os(v).is_some_and(|d| !d.is_empty()));
    if !has_display {
        return Err(format!(
            "{portal}, and no DISPLAY or WAYLAND_DISPLAY for zenity"
        ));
    }
    let zenity = Command::new("zenity")
        .arg("--version")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status();
    match zenity {
        Ok(status) if status.success() => Ok(NativeBackend::Zenity),
        Ok(status) => Err(format!("{portal}, and zenity failed ({status})")),
        Err(e) => Err(format!("{portal}, and zenity is not installed ({e})")),
    }
}

/// Asks the session bus for the FileChooser portal's version property (which also
/// starts the portal if the bus can activate it), with the first of `dbus-send`,
/// `gdbus` and `busctl` that is installed. Each waits at most 3 s.
fn portal_file_chooser() -> Result<(), String> {
    let bus_socket = std::env::var_os("XDG_RUNTIME_DIR")
        .map(|d| Path::new(&d).join("bus"))
        .is_some_and(|p| p.exists());
    if std::env::var_os("DBUS_SESSION_BUS_ADDRESS").is_none() && !bus_socket {
        return Err("no D-Bus session bus for a desktop portal".into());
    }
    const DEST: &str = "org.freedesktop.portal.Desktop";
    const PATH: &str = "/org/freedesktop/portal/desktop";
    const IFACE: &str = "org.freedesktop.portal.FileChooser";
    let probes: [(&str, Vec<String>); 3] = [
        (
            "dbus-send",
            [
                "--session",
                "--print-reply",
                "--reply-timeout=3000",
                &format!("--dest={DEST}"),
                PATH,
                "org.freedesktop.DBus.Properties.Get",
                &format!("string:{IFACE}"),
                "string:version",
            ]
            .map(String::from)
            .to_vec(),
        ),
        (
            "gdbus",
            [
                "call",
                "--session",
                "--timeout",
                "3",
                "--dest",
                DEST,
                "--object-path",
                PATH,
                "--method",
                "org.freedesktop.DBus.Properties.Get",
                IFACE,
                "version",
            ]
            .map(String::from)
            .to_vec(),
        ),
        (
            "busctl",
            [
                "--user",
                "--timeout=3",
                "get-property",
                DEST,
                PATH,
                IFACE,
                "version",
            ]
            .map(String::from)
            .to_vec(),
        ),
    ];
    for (program, args) in probes {
        let status = Command::new(program)
            .args(&args)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status();
        match status {
            Ok(s) if s.success() => return Ok(()),
            Ok(_) => return Err("no desktop portal answers on the session bus".into()),
            // Not installed: try the next client.
            Err(_) => continue,
        }
    }
    Err("no dbus-send, gdbus or busctl to ask the session bus for a desktop portal".into())
}

/// What the app is told after a frame.
#[derive(Debug, Clone, PartialEq)]
pub enum DialogEvent {
    /// A file was chosen for this purpose.
    Chosen(FilePurpose, PathBuf),
    /// A line for the status line (the fallback's reason, once).
    Info(String),
}

/// A system dialog on its thread.
struct Pending {
    request: DialogRequest,
    answer: Receiver<DialogOutcome>,
}

/// The app's file choosing: the system dialog (if set and there) or the in-app
/// browser.
pub struct FileDialogs {
    native: Option<Arc<dyn NativeFileDialog>>,
    /// The person's setting (File menu); turned off for the session when the system
    /// dialog turns out to be unavailable.
    use_native: bool,
    pending: Option<Pending>,
    /// What a finished system dialog said, until `show` hands it to the app.
    answered: Vec<DialogEvent>,
    browser: FileBrowser,
}

impl Default for FileDialogs {
    fn default() -> Self {
        Self::new(Some(Arc::new(SystemFileDialog::default())))
    }
}

impl Drop for FileDialogs {
    /// A system dialog still showing when the app closes would outlive it (zenity
    /// is a process of its own): close it.
    fn drop(&mut self) {
        if let (Some(native), Some(_)) = (&self.native, &self.pending) {
            native.close();
        }
    }
}

impl FileDialogs {
    /// Uses `native` when set (and the setting is on); `None`: the browser only.
    pub fn new(native: Option<Arc<dyn NativeFileDialog>>) -> Self {
        Self {
            use_native: native.is_some(),
            native,
            pending: None,
            answered: Vec::new(),
            browser: FileBrowser::default(),
        }
    }

    /// Whether a system dialog is there to be used.
    pub fn has_native(&self) -> bool {
        self.native.is_some()
    }

    /// Whether requests go to the system dialog.
    pub fn use_native(&self) -> bool {
        self.use_native && self.native.is_some()
    }

    /// Sets whether requests go to the system dialog (the File menu's setting).
    pub fn set_use_native(&mut self, on: bool) {
        self.use_native = on;
    }

    /// Whether a system dialog is open (on its thread).
    pub fn is_waiting(&self) -> bool {
        self.pending.is_some()
    }

    /// Whether the in-app browser is showing.
    pub fn browser_is_open(&self) -> bool {
        self.browser.is_open()
    }

    /// Asks for a file: the system dialog on its own thread, or the browser.
    /// Returns a line for the status line when the request cannot be taken.
    /// `ctx` is asked for a repaint when the answer arrives (none before a first
    /// frame: the answer is then taken up at the next one).
    pub fn request(
        &mut self,
        ctx: Option<&egui::Context>,
        request: DialogRequest,
    ) -> Option<String> {
        // A dialog that has just closed (its answer not yet taken up by a frame)
        // is not "already open": the person may ask again within the same frame.
        self.take_answer();
        let native = match (&self.native, self.use_native) {
            (Some(native), true) => Arc::clone(native),
            _ => {
                self.open_browser(&request);
                return None;
            }
        };
        if self.pending.is_some() {
            return Some("A file dialog is already open; answer it first.".into());
        }
        let (send, answer) = channel();
        let ctx = ctx.cloned();
        let asked = request.clone();
        let spawned = std::thread::Builder::new()
            .name("coatlab-file-dialog".into())
            .spawn(move || {
                // The receiver is gone only if the app closed meanwhile.
                let _ = send.send(native.ask(&asked));
                if let Some(ctx) = ctx {
                    ctx.request_repaint();
                }
            });
        match spawned {
            Ok(_) => {
                self.pending = Some(Pending { request, answer });
                None
            }
            Err(e) => {
                self.use_native = false;
                self.open_browser(&request);
                Some(format!(
                    "Could not start the system file dialog ({e}); using the in-app browser."
                ))
            }
        }
    }

    fn open_browser(&mut self, request: &DialogRequest) {
        self.browser
            .open(request.purpose, &request.directory, &request.file_name);
    }

    /// Takes up a system dialog's answer if it has come: the dialog is then no
    /// longer pending, and what it said waits in `answered` for `show`.
    fn take_answer(&mut self) {
        let Some(pending) = &self.pending else {
            return;
        };
        let outcome = match pending.answer.try_recv() {
            Ok(outcome) => outcome,
            Err(TryRecvError::Empty) => return,
            // The dialog's thread panicked: the browser instead.
            Err(TryRecvError::Disconnected) => {
                DialogOutcome::Unavailable("its thread ended without an answer".into())
            }
        };
        let request = pending.request.clone();
        self.pending = None;
        match outcome {
            DialogOutcome::Chosen(path) => {
                self.answered
                    .push(DialogEvent::Chosen(request.purpose, path));
            }
            DialogOutcome::Cancelled => {}
            DialogOutcome::Unavailable(reason) => {
                // Once: the rest of the session goes to the browser.
                self.use_native = false;
                self.answered.push(DialogEvent::Info(format!(
                    "No system file dialog ({reason}); using the in-app browser."
                )));
                self.open_browser(&request);
            }
        }
    }

    /// Shows the browser if open and takes up a system dialog's answer; call once
    /// per frame.
    pub fn show(&mut self, ctx: &egui::Context) -> Vec<DialogEvent> {
        self.take_answer();
        let mut events = std::mem::take(&mut self.answered);
        if let Some((purpose, path)) = self.browser.show(ctx) {
            events.push(DialogEvent::Chosen(purpose, path));
        }
        events
    }
}
