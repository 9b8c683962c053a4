//! The paint list: the scene's materials with their surface areas and the areas
//! the current view sees of them (measured on the render thread), each toggled
//! to carry the design or not (a real body is split across materials). The
//! loader's choice stays until a box is changed; "Automatic" goes back to it.
//! The list only says what the user chose: the preview sends it to the engine.

use coatlab_core::engine::events::{MaterialInfo, SceneInfo};
use coatlab_core::render::pick::toggled;
use egui::Ui;

/// A material's line in the list: its name and area.
pub fn material_label(material: &MaterialInfo) -> String {
    format!("{} ({:.2} m²)", material.name, material.area_m2)
}

/// What the view shows of a material: its visible area, or that it is being
/// measured.
pub fn visible_label(visible: Option<f32>) -> String {
    match visible {
        Some(area) => format!("visible {area:.2} m²"),
        None => "visible …".to_owned(),
    }
}

/// Draws the list of `scene`'s materials, largest first, with `painted` checked
/// (`automatic`: that is the loader's choice) and the area the view sees of each
/// (`visible`, per material, once measured). Returns the choice the user made
/// this frame: `Some(None)` for the loader's, `Some(Some(list))` for a list.
pub fn paint_materials_ui(
    ui: &mut Ui,
    scene: &SceneInfo,
    painted: &[u32],
    automatic: bool,
    visible: Option<&[f32]>,
) -> Option<Option<Vec<u32>>> {
    let mut choice = None;
    if ui
        .add_enabled(!automatic, egui::Button::new("Automatic"))
        .on_hover_text("The loader's choice: the largest glossy, coloured material")
        .clicked()
    {
        choice = Some(None);
    }
    let mut order: Vec<usize> = (0..scene.materials.len()).collect();
    let area = |i: usize| scene.materials[i].area_m2;
    order.sort_by(|&a, &b| area(b).total_cmp(&area(a)));
    egui::ScrollArea::vertical()
        .max_height(320.0)
        .show(ui, |ui| {
            for i in order {
                let mut on = painted.contains(&(i as u32));
                let label = material_label(&scene.materials[i]);
                ui.horizontal(|ui| {
                    if ui.checkbox(&mut on, label).changed() {
                        choice = Some(Some(toggled(painted, i as u32)));
                    }
                    let seen = visible.and_then(|v| v.get(i).copied());
                    ui.weak(visible_label(seen))
                        .on_hover_text("The area the current view sees of it");
                });
            }
        });
    choice
}
