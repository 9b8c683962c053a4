//! Choosing files: the system's file dialog where there is one, the in-app browser
//! otherwise.
//!
//! The system dialog is `rfd` with its XDG desktop portal back-end (no GTK at build
//! time: rfd loads libdbus at run time and asks `org.freedesktop.portal.FileChooser`;
//! when no portal answers it runs `zenity`). It blocks until the person answers, so
//! it runs on a thread of its own and the UI keeps drawing; the answer arrives over
//! a channel and asks for a repaint.
//!
//! rfd answers "no file" both when the person cancels and when it could show
//! nothing (no portal, no zenity), so before the first dialog this module asks
//! whether either is there ([`native_dialog_availability`]). Where neither is (a
//! bare X session, Xvfb in CI), the request opens the in-app browser instead and
//! the status line says why, once; the rest of the session uses the browser. The
//! browser stays reachable from the File menu ("Use the system file dialog" off).
//!
//! The dialog is a trait object ([`NativeFileDialog`]) so the tests can stand in
//! for the system: a path, a cancel, or no dialog at all.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc::{Receiver, TryRecvError, channel};
use std::sync::{Arc, OnceLock};

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
}

/// The system's file dialog through rfd (XDG portal, then zenity).
#[derive(Debug, Default)]
pub struct SystemFileDialog {
    /// Whether a portal or zenity is there, asked once per process: starting
    /// either later in the session is not noticed (the in-app browser serves).
    availability: OnceLock<Result<(), String>>,
}

impl NativeFileDialog for SystemFileDialog {
    fn ask(&self, request: &DialogRequest) -> DialogOutcome {
        if let Err(reason) = self
            .availability
            .get_or_init(native_dialog_availability)
            .clone()
        {
            return DialogOutcome::Unavailable(reason);
        }
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
        // Once a back-end is known to be there, "no file" is the person's cancel.
        match chosen {
            Some(path) => DialogOutcome::Chosen(path),
            None => DialogOutcome::Cancelled,
        }
    }
}

/// Whether rfd can show a dialog here: an XDG desktop portal with a FileChooser
/// answers on the session bus, or `zenity` runs. `Err` says what is missing.
pub fn native_dialog_availability() -> Result<(), String> {
    let portal = portal_file_chooser();
    if portal.is_ok() {
        return Ok(());
    }
    let zenity = Command::new("zenity")
        .arg("--version")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status();
    match (portal, zenity) {
        (_, Ok(status)) if status.success() => Ok(()),
        (Err(portal), Ok(status)) => Err(format!("{portal}, and zenity failed ({status})")),
        (Err(portal), Err(e)) => Err(format!("{portal}, and zenity is not installed ({e})")),
        (Ok(()), _) => Ok(()),
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
    browser: FileBrowser,
}

impl Default for FileDialogs {
    fn default() -> Self {
        Self::new(Some(Arc::new(SystemFileDialog::default())))
    }
}

impl FileDialogs {
    /// Uses `native` when set (and the setting is on); `None`: the browser only.
    pub fn new(native: Option<Arc<dyn NativeFileDialog>>) -> Self {
        Self {
            use_native: native.is_some(),
            native,
            pending: None,
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

    /// Shows the browser if open and takes up a system dialog's answer; call once
    /// per frame.
    pub fn show(&mut self, ctx: &egui::Context) -> Vec<DialogEvent> {
        let mut events = Vec::new();
        if let Some(pending) = &self.pending {
            match pending.answer.try_recv() {
                Ok(outcome) => {
                    let request = pending.request.clone();
                    self.pending = None;
                    match outcome {
                        DialogOutcome::Chosen(path) => {
                            events.push(DialogEvent::Chosen(request.purpose, path));
                        }
                        DialogOutcome::Cancelled => {}
                        DialogOutcome::Unavailable(reason) => {
                            // Once: the rest of the session goes to the browser.
                            self.use_native = false;
                            events.push(DialogEvent::Info(format!(
                                "No system file dialog ({reason}); using the in-app browser."
                            )));
                            self.open_browser(&request);
                        }
                    }
                }
                Err(TryRecvError::Empty) => {}
                Err(TryRecvError::Disconnected) => {
                    // The dialog's thread panicked: the browser instead.
                    let request = pending.request.clone();
                    self.pending = None;
                    self.use_native = false;
                    events.push(DialogEvent::Info(
                        "The system file dialog failed; using the in-app browser.".into(),
                    ));
                    self.open_browser(&request);
                }
            }
        }
        if let Some((purpose, path)) = self.browser.show(ctx) {
            events.push(DialogEvent::Chosen(purpose, path));
        }
        events
    }
}
