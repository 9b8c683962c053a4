//! The preview's controls above the picture: lighting, model, comparison and
//! its layout, the second design, the ΔE00 scale; the scene and its paint
//! material; export.

use coatlab_core::design::presets::Preset;
use coatlab_core::paint::phong::PhongVariant;
use coatlab_core::render::film::{Exposure, ToneMapping};
use coatlab_core::render::lighting::Lighting;
use coatlab_core::render::material::ShadingModel;
use coatlab_core::render::view::{NamedView, ViewChoice};
use egui::{RichText, Ui};

use super::super::compare::{CompareLayout, CompareMode, SCALES};
use super::super::paint_materials::paint_materials_ui;
use super::{Preview, PreviewRequest, panes};

impl Preview {
    /// The first row: lighting, model, comparison.
    pub(super) fn toolbar_ui(
        &mut self,
        ui: &mut Ui,
        presets: &[Preset],
        requests: &mut Vec<PreviewRequest>,
    ) {
        ui.horizontal_wrapped(|ui| {
            self.lighting_ui(ui, requests);
            ui.separator();
            self.model_ui(ui);
            ui.separator();
            self.compare_ui(ui, presets);
            if self.compare == CompareMode::Designs {
                self.second_design_ui(ui, presets, requests);
            }
            if self.compare != CompareMode::Off && self.layout == CompareLayout::DeltaE {
                self.scale_ui(ui);
            }
        });
    }

    /// The lighting setups, and the map opened last.
    fn lighting_ui(&mut self, ui: &mut Ui, requests: &mut Vec<PreviewRequest>) {
        let mut lighting = self.lighting.clone();
        let map = self
            .map
            .as_ref()
            .map(|(path, name)| (Lighting::Map(path.clone()), format!("Map: {name}")));
        let shown = match (&lighting, &map) {
            (Lighting::Map(_), Some((_, label))) => label.clone(),
            (Lighting::Map(_), None) => String::new(),
            (setup, _) => setup.label(),
        };
        egui::ComboBox::from_label("Lighting")
            .selected_text(shown)
            .show_ui(ui, |ui| {
                for setup in Lighting::SETUPS {
                    let label = setup.label();
                    ui.selectable_value(&mut lighting, setup, label);
                }
                if let Some((entry, label)) = map {
                    ui.selectable_value(&mut lighting, entry, label);
                }
            });
        self.set_lighting(lighting);
        request_button(
            ui,
            "Open map…",
            "An equirectangular environment map (.hdr or .exr)",
            PreviewRequest::OpenEnvironment,
            requests,
        );
    }

    /// The model of the view, or the Phong variant against the paint model.
    fn model_ui(&mut self, ui: &mut Ui) {
        if self.compare == CompareMode::Models {
            let mut phong = self.phong;
            ui.label("against");
            for v in [PhongVariant::Naive, PhongVariant::BestFit] {
                ui.selectable_value(&mut phong, v, v.label());
            }
            if phong != self.phong {
                self.phong = phong;
                self.send_views();
            }
            return;
        }
        let mut model = self.model;
        for m in [
            ShadingModel::Paint,
            ShadingModel::Phong(PhongVariant::Naive),
            ShadingModel::Phong(PhongVariant::BestFit),
        ] {
            ui.selectable_value(&mut model, m, m.label());
        }
        if model != self.model {
            self.model = model;
            self.send_views();
        }
    }

    /// The comparison mode and its layout.
    fn compare_ui(&mut self, ui: &mut Ui, presets: &[Preset]) {
        let mut mode = self.compare;
        egui::ComboBox::from_label("Compare")
            .selected_text(mode.label())
            .show_ui(ui, |ui| {
                for m in CompareMode::ALL {
                    ui.selectable_value(&mut mode, m, m.label());
                }
            });
        if mode == CompareMode::Designs && self.second.is_none() {
            // Something to compare with at once: the first preset unlike the
            // design; the combo beside it changes it.
            if let Some(p) = presets.iter().find(|p| p.design.name != self.design_name) {
                self.second = Some((p.design.name.clone(), p.design.clone()));
            }
        }
        if mode != self.compare {
            self.set_compare(mode, self.layout);
        }
        if self.compare != CompareMode::Off {
            let mut layout = self.layout;
            for l in CompareLayout::ALL {
                ui.selectable_value(&mut layout, l, l.label());
            }
            self.layout = layout;
        }
    }

    /// The second design: a preset, or a file.
    fn second_design_ui(
        &mut self,
        ui: &mut Ui,
        presets: &[Preset],
        requests: &mut Vec<PreviewRequest>,
    ) {
        let current = self
            .second
            .as_ref()
            .map(|(l, _)| l.clone())
            .unwrap_or_default();
        let mut chosen = None;
        egui::ComboBox::from_label("Second design")
            .selected_text(current)
            .show_ui(ui, |ui| {
                for (i, p) in presets.iter().enumerate() {
                    if ui.selectable_label(false, &p.design.name).clicked() {
                        chosen = Some(i);
                    }
                }
            });
        if let Some(p) = chosen.and_then(|i| presets.get(i)) {
            let (name, design) = (p.design.name.clone(), p.design.clone());
            self.set_second_design(&name, &design);
        }
        if ui.button("Second design from file…").clicked() {
            requests.push(PreviewRequest::SecondDesignFile);
        }
    }

    /// The top of the ΔE00 map's scale.
    fn scale_ui(&mut self, ui: &mut Ui) {
        let mut scale = self.map_scale;
        egui::ComboBox::from_label("Scale")
            .selected_text(format!("0–{scale:.0} ΔE00"))
            .show_ui(ui, |ui| {
                for s in SCALES {
                    ui.selectable_value(&mut scale, s, format!("0–{s:.0} ΔE00"));
                }
            });
        self.map_scale = scale;
    }

    /// The second row: the scene, its paint material, export.
    pub(super) fn scene_ui(&mut self, ui: &mut Ui, requests: &mut Vec<PreviewRequest>) {
        ui.horizontal_wrapped(|ui| {
            let name = self
                .scene
                .as_ref()
                .map(|s| s.name.clone())
                .unwrap_or_else(|| "Built-in car".into());
            ui.label(format!("Scene: {name}"));
            request_button(
                ui,
                "Open scene…",
                "A glTF 2.0 scene (.glb or .gltf); or drop one on the window",
                PreviewRequest::OpenScene,
                requests,
            );
            if self.scene.as_ref().is_some_and(|s| s.path.is_some())
                && ui.button("Built-in car").clicked()
            {
                self.built_in_scene();
            }
            self.view_ui(ui);
            self.display_ui(ui);
            self.paint_material_ui(ui);
            ui.separator();
            request_button(
                ui,
                "Export image…",
                "The preview as PNG (as shown) or EXR (linear)",
                PreviewRequest::Export,
                requests,
            );
        });
    }

    /// The named views and the scene file's own cameras.
    fn view_ui(&mut self, ui: &mut Ui) {
        let cameras = self
            .scene
            .as_ref()
            .map(|s| s.cameras.clone())
            .unwrap_or_default();
        let label_of = |choice: ViewChoice| match choice {
            ViewChoice::Named(view) => view.label().to_owned(),
            ViewChoice::SceneCamera(i) => format!(
                "Camera: {}",
                cameras.get(i).map_or("(none)", String::as_str)
            ),
            ViewChoice::Free(free) => format!(
                "Free: {:.0}°, {:.0}°, {:.1} m, {:.0}°",
                free.yaw_deg, free.pitch_deg, free.distance_m, free.fov_deg
            ),
        };
        let mut picked = None;
        egui::ComboBox::from_label("View")
            .selected_text(label_of(self.view))
            .show_ui(ui, |ui| {
                let choices = NamedView::ALL
                    .into_iter()
                    .map(ViewChoice::Named)
                    .chain((0..cameras.len()).map(ViewChoice::SceneCamera));
                for choice in choices {
                    // A click sends even the current view: it undoes an orbit.
                    if ui
                        .selectable_label(choice == self.view, label_of(choice))
                        .clicked()
                    {
                        picked = Some(choice);
                    }
                }
            })
            .response
            .on_hover_text("Named views of the car, and the scene file's own cameras");
        if let Some(choice) = picked {
            self.set_view(choice);
        }
    }

    /// The tone mapping and the exposure: automatic, adjusted in stops.
    fn display_ui(&mut self, ui: &mut Ui) {
        let mut display = self.display();
        egui::ComboBox::from_label("Tone map")
            .selected_text(display.tone_mapping.label())
            .show_ui(ui, |ui| {
                for t in ToneMapping::CHOICES {
                    ui.selectable_value(&mut display.tone_mapping, t, t.label());
                }
            })
            .response
            .on_hover_text(
                "PBR Neutral keeps the colours that fit the display as they are and \
                 compresses only highlights; Reinhard is the earlier mapping; Clip shows \
                 the values as they are",
            );
        let mut adjust = match display.exposure {
            Exposure::Auto { adjust_stops } => adjust_stops,
            Exposure::Fixed { stops } => stops,
        };
        ui.add(
            egui::DragValue::new(&mut adjust)
                .range(-8.0..=8.0)
                .speed(0.05)
                .fixed_decimals(1)
                .prefix("exposure auto ")
                .suffix(" stops"),
        )
        .on_hover_text("The automatic exposure (the image's log-average to middle grey), adjusted");
        display.exposure = Exposure::Auto {
            adjust_stops: adjust,
        };
        self.set_display(display);
    }

    /// Which of the scene's materials carry the paint (a list to toggle), and the
    /// load's warnings.
    fn paint_material_ui(&mut self, ui: &mut Ui) {
        let Some(scene) = self.scene.clone() else {
            return;
        };
        let painted = self.paint_materials();
        let automatic = self.paint_is_automatic();
        let mut choice = None;
        let mut open = false;
        let visible = self.visible_areas().map(<[f32]>::to_vec);
        ui.menu_button("Paint materials", |ui| {
            open = true;
            choice = paint_materials_ui(ui, &scene, &painted, automatic, visible.as_deref());
        })
        .response
        .on_hover_text(format!(
            "Painted: {}{}",
            panes::names_of(&scene.materials, &painted),
            if automatic { " (automatic)" } else { "" }
        ));
        if open {
            self.ask_visible_areas();
        }
        if let Some(choice) = choice {
            self.set_paint_materials(choice);
        }
        if !scene.warnings.is_empty() {
            ui.label(
                RichText::new(format!("{} warning(s)", scene.warnings.len()))
                    .color(ui.visuals().warn_fg_color),
            )
            .on_hover_text(scene.warnings.join("\n"));
        }
    }
}

/// A button with `hover` text that asks the window for `request` when clicked.
fn request_button(
    ui: &mut Ui,
    label: &str,
    hover: &str,
    request: PreviewRequest,
    requests: &mut Vec<PreviewRequest>,
) {
    if ui.button(label).on_hover_text(hover).clicked() {
        requests.push(request);
    }
}
