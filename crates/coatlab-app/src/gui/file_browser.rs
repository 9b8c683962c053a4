//! The in-app file browser: a path field plus a directory listing. It is what
//! [`super::dialogs`] falls back to where no system file dialog can be shown (no
//! desktop portal and no zenity, as under Xvfb in CI), and what the File menu's
//! "Use the system file dialog" setting switches to. It builds with nothing, works
//! anywhere egui draws, and egui_kittest can drive it. Files can also be dropped on
//! the window.

use std::path::{Path, PathBuf};

use coatlab_core::export::ExportFormat;
use egui::{RichText, Ui};

/// What the chosen path is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FilePurpose {
    OpenDesign,
    SaveDesign,
    ImportAlbedoCsv,
    /// A target: a design, or a measurement file (CGATS.17, CxF3).
    Target,
    ExportMeasurement,
    ExportPreviewImage,
    /// The design as an exchange file (CxF3, CGATS.17, glTF).
    ExportDesign(ExportFormat),
    OpenScene,
    OpenEnvironment,
    SecondDesign,
}

impl FilePurpose {
    /// The dialog's title.
    pub fn title(self) -> &'static str {
        match self {
            FilePurpose::OpenDesign => "Open design",
            FilePurpose::SaveDesign => "Save design as",
            FilePurpose::ImportAlbedoCsv => "Import ρ(λ) from a spectral CSV",
            FilePurpose::Target => "Choose a target (a design or a measurement)",
            FilePurpose::ExportMeasurement => "Export readings (.csv or .json)",
            FilePurpose::ExportPreviewImage => "Export preview (.png or .exr)",
            FilePurpose::ExportDesign(ExportFormat::Cxf) => "Export the design as CxF3 (.cxf)",
            FilePurpose::ExportDesign(ExportFormat::Cgats) => {
                "Export the design's readings as CGATS.17 (.txt)"
            }
            FilePurpose::ExportDesign(ExportFormat::Gltf) => {
                "Export the car with the design as glTF (.glb)"
            }
            FilePurpose::OpenScene => "Open a glTF scene (.glb or .gltf)",
            FilePurpose::OpenEnvironment => "Open an environment map (.hdr or .exr)",
            FilePurpose::SecondDesign => "Choose a design to compare with",
        }
    }

    /// The file types offered, as extensions without the dot.
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            FilePurpose::OpenDesign | FilePurpose::SaveDesign | FilePurpose::SecondDesign => {
                &["toml"]
            }
            // CGATS files come as .cgats, .txt, .it8 or .ti3, CxF3 as .cxf (or .xml).
            FilePurpose::Target => &["toml", "cgats", "txt", "it8", "ti3", "cxf", "xml", "csv"],
            FilePurpose::ImportAlbedoCsv => &["csv"],
            FilePurpose::ExportMeasurement => &["csv", "json"],
            FilePurpose::ExportPreviewImage => &["png", "exr"],
            FilePurpose::ExportDesign(format) => format.extensions(),
            FilePurpose::OpenScene => &["glb", "gltf"],
            FilePurpose::OpenEnvironment => &["hdr", "exr"],
        }
    }

    /// What the file types are called in a system dialog's filter.
    pub fn filter_name(self) -> &'static str {
        match self {
            FilePurpose::OpenDesign | FilePurpose::SaveDesign | FilePurpose::SecondDesign => {
                "Coatlab design"
            }
            FilePurpose::Target => "Design or measurement (CGATS, CxF3, spectral CSV)",
            FilePurpose::ImportAlbedoCsv => "Spectral CSV",
            FilePurpose::ExportMeasurement => "Readings (CSV, JSON)",
            FilePurpose::ExportPreviewImage => "Image (PNG, EXR)",
            FilePurpose::ExportDesign(ExportFormat::Cxf) => "CxF3",
            FilePurpose::ExportDesign(ExportFormat::Cgats) => "CGATS.17",
            FilePurpose::ExportDesign(ExportFormat::Gltf) => "glTF binary",
            FilePurpose::OpenScene => "glTF scene",
            FilePurpose::OpenEnvironment => "Environment map (HDR, EXR)",
        }
    }

    /// Whether the path names a file to create (a name may be typed).
    pub fn is_save(self) -> bool {
        matches!(
            self,
            FilePurpose::SaveDesign
                | FilePurpose::ExportMeasurement
                | FilePurpose::ExportPreviewImage
                | FilePurpose::ExportDesign(_)
        )
    }
}

#[derive(Debug, Clone)]
struct Entry {
    name: String,
    is_dir: bool,
}

/// The browser's state; closed when `purpose` is `None`.
#[derive(Debug, Clone, Default)]
pub struct FileBrowser {
    purpose: Option<FilePurpose>,
    dir: PathBuf,
    dir_text: String,
    file_name: String,
    entries: Vec<Entry>,
    error: Option<String>,
}

impl FileBrowser {
    /// Opens the browser in `dir` with a suggested file name.
    pub fn open(&mut self, purpose: FilePurpose, dir: &Path, file_name: &str) {
        self.purpose = Some(purpose);
        self.file_name = file_name.to_owned();
        self.set_dir(dir.to_owned());
    }

    /// Whether it is showing.
    pub fn is_open(&self) -> bool {
        self.purpose.is_some()
    }

    fn set_dir(&mut self, dir: PathBuf) {
        self.error = None;
        let Some(purpose) = self.purpose else { return };
        match std::fs::read_dir(&dir) {
            Ok(read) => {
                let mut entries: Vec<Entry> = read
                    .filter_map(Result::ok)
                    .filter_map(|e| {
                        let name = e.file_name().to_string_lossy().into_owned();
                        let is_dir = e.path().is_dir();
                        let wanted = is_dir
                            || Path::new(&name)
                                .extension()
                                .and_then(|x| x.to_str())
                                .is_some_and(|x| {
                                    purpose
                                        .extensions()
                                        .iter()
                                        .any(|w| x.eq_ignore_ascii_case(w))
                                });
                        (wanted && !name.starts_with('.')).then_some(Entry { name, is_dir })
                    })
                    .collect();
                entries.sort_by(|a, b| b.is_dir.cmp(&a.is_dir).then_with(|| a.name.cmp(&b.name)));
                self.entries = entries;
                self.dir_text = dir.display().to_string();
                self.dir = dir;
            }
            Err(e) => {
                self.error = Some(format!("cannot list {}: {e}", dir.display()));
                self.dir_text = self.dir.display().to_string();
            }
        }
    }

    /// Shows the browser window if open; returns the purpose and path once the user
    /// confirms (the browser then closes).
    pub fn show(&mut self, ctx: &egui::Context) -> Option<(FilePurpose, PathBuf)> {
        let purpose = self.purpose?;
        let mut chosen = None;
        let mut open = true;
        egui::Window::new(purpose.title())
            .id(egui::Id::unique("file_browser"))
            .open(&mut open)
            .collapsible(false)
            .default_size([520.0, 420.0])
            .show(ctx, |ui| chosen = self.contents_ui(ui, purpose));
        if !open {
            self.purpose = None;
        }
        if chosen.is_some() {
            self.purpose = None;
        }
        chosen.map(|path| (purpose, path))
    }

    fn contents_ui(&mut self, ui: &mut Ui, purpose: FilePurpose) -> Option<PathBuf> {
        let mut chosen = None;
        let mut go_to = None;
        ui.horizontal(|ui| {
            if ui.button("Up").clicked()
                && let Some(parent) = self.dir.parent()
            {
                go_to = Some(parent.to_owned());
            }
            let r =
                ui.add(egui::TextEdit::singleline(&mut self.dir_text).desired_width(f32::INFINITY));
            if r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)) {
                go_to = Some(PathBuf::from(self.dir_text.trim()));
            }
        });
        if let Some(e) = &self.error {
            ui.label(RichText::new(e).color(ui.visuals().error_fg_color));
        }
        let list_height = (ui.available_height() - 60.0).max(120.0);
        egui::ScrollArea::vertical()
            .max_height(list_height)
            .auto_shrink([false, false])
            .show(ui, |ui| {
                for entry in &self.entries {
                    let text = if entry.is_dir {
                        format!("[dir] {}", entry.name)
                    } else {
                        entry.name.clone()
                    };
                    let r =
                        ui.selectable_label(!entry.is_dir && entry.name == self.file_name, text);
                    if entry.is_dir {
                        if r.clicked() {
                            go_to = Some(self.dir.join(&entry.name));
                        }
                    } else {
                        if r.clicked() {
                            self.file_name = entry.name.clone();
                        }
                        if r.double_clicked() {
                            chosen = Some(self.dir.join(&entry.name));
                        }
                    }
                }
            });
        ui.horizontal(|ui| {
            ui.label("File name");
            let r = ui.add(egui::TextEdit::singleline(&mut self.file_name).desired_width(260.0));
            let enter = r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            let label = if purpose.is_save() { "Save" } else { "Open" };
            if (ui.button(label).clicked() || enter) && !self.file_name.trim().is_empty() {
                // A typed absolute path wins over the listed directory.
                let typed = PathBuf::from(self.file_name.trim());
                chosen = Some(if typed.is_absolute() {
                    typed
                } else {
                    self.dir.join(typed)
                });
            }
        });
        ui.label(RichText::new(format!("Shows *.{}", purpose.extensions().join(", *."))).weak());
        if let Some(dir) = go_to {
            self.set_dir(dir);
        }
        chosen
    }
}
