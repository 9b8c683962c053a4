//! The preview's picture: one pane, two side by side, one split by a
//! draggable divider, or the ΔE00 map with its legend; the dark background
//! around them; mouse input that moves the camera.

use coatlab_core::engine::{Command, MaterialInfo};
use egui::{Color32, Ui};

use super::super::compare::{CompareLayout, CompareMode, legend_ui};
use super::Preview;

/// The preview's largest size in pixels (it renders at most this, scaled up on screen):
/// the default keeps the first image within reach of a 2-core machine.
const MAX_PREVIEW_PIXELS: (u32, u32) = (640, 400);
/// Gap between side-by-side panes, points.
const PANE_GAP: f32 = 4.0;
/// Width kept for the ΔE00 legend, points.
const LEGEND_WIDTH: f32 = 64.0;
/// Height kept below the picture for the status line, points.
const STATUS_HEIGHT: f32 = 22.0;

impl Preview {
    /// The picture below the controls, with room for the status line (and in a
    /// comparison the line on how its second view is made); asks the engine for
    /// the size that fits its panes.
    pub(super) fn picture_ui(&mut self, ui: &mut Ui) {
        let two = self.compare != CompareMode::Off;
        let line = ui.text_style_height(&egui::TextStyle::Body) + ui.spacing().item_spacing.y;
        let status_height = if two {
            STATUS_HEIGHT + line
        } else {
            STATUS_HEIGHT
        };
        let available = ui.available_size() - egui::vec2(0.0, status_height);
        let (rect, _) = ui.allocate_exact_size(available, egui::Sense::hover());
        let pane_size = match (two, self.layout) {
            (true, CompareLayout::SideBySide) => {
                egui::vec2((rect.width() - PANE_GAP) / 2.0, rect.height())
            }
            (true, CompareLayout::DeltaE) => egui::vec2(rect.width() - LEGEND_WIDTH, rect.height()),
            _ => rect.size(),
        };
        self.fit_to(ui, pane_size);
        // The dark background goes only where no opaque image covers it (filled in
        // below, once the images' rectangles are known): a software rasteriser
        // shades every pixel of every shape, hidden or not.
        let background = ui.painter().add(egui::Shape::Noop);
        let covered = self.panes_ui(ui, rect, pane_size);
        let fill = Color32::from_gray(20);
        ui.painter().set(
            background,
            egui::Shape::Vec(
                uncovered(rect, &covered)
                    .into_iter()
                    .map(|r| egui::Shape::rect_filled(r, 0.0, fill))
                    .collect(),
            ),
        );
        self.opaque = covered;
    }

    /// The panes of the layout in `rect`; returns where opaque images went.
    fn panes_ui(
        &mut self,
        ui: &mut Ui,
        rect: egui::Rect,
        pane_size: egui::Vec2,
    ) -> Vec<egui::Rect> {
        let mut covered: Vec<egui::Rect> = Vec::new();
        let labels = self.view_labels();
        let two = self.compare != CompareMode::Off;
        match (two, self.layout) {
            (false, _) => {
                let r = ui.interact(
                    rect,
                    ui.scope_id().with("pane-a"),
                    egui::Sense::click_and_drag(),
                );
                named(&r, "Preview pane");
                let shown = self.image_ui(ui, 0, rect, None);
                self.click_to_paint(&r, shown);
                covered.extend(shown);
                self.camera_input(ui, &r);
            }
            (true, CompareLayout::SideBySide) => {
                for (i, label) in labels.iter().enumerate() {
                    let pane = egui::Rect::from_min_size(
                        rect.min + egui::vec2(i as f32 * (pane_size.x + PANE_GAP), 0.0),
                        pane_size,
                    );
                    let r = ui.interact(
                        pane,
                        ui.scope_id().with(("pane", i)),
                        egui::Sense::click_and_drag(),
                    );
                    named(&r, &format!("Preview pane: {label}"));
                    let shown = self.image_ui(ui, i, pane, Some(label));
                    // Both panes show one camera: a click on either picks there.
                    self.click_to_paint(&r, shown);
                    covered.extend(shown);
                    self.camera_input(ui, &r);
                }
            }
            (true, CompareLayout::Split) => covered.extend(self.split_ui(ui, rect, &labels)),
            (true, CompareLayout::DeltaE) => {
                let map_rect = egui::Rect::from_min_size(rect.min, pane_size);
                let r = ui.interact(
                    map_rect,
                    ui.scope_id().with("pane-map"),
                    egui::Sense::click_and_drag(),
                );
                named(&r, "ΔE00 map");
                let shown = self.map_ui(ui, map_rect, &r, &labels);
                self.click_to_paint(&r, shown);
                covered.extend(shown);
                self.camera_input(ui, &r);
                let legend =
                    egui::Rect::from_min_max(egui::pos2(map_rect.right(), rect.top()), rect.max);
                legend_ui(ui, legend.shrink2(egui::vec2(4.0, 20.0)), self.map_scale);
            }
        }
        covered
    }

    /// Draws view `i`'s image letterboxed in `rect`, with a label; returns where the
    /// (opaque) image went.
    fn image_ui(
        &self,
        ui: &Ui,
        i: usize,
        rect: egui::Rect,
        label: Option<&str>,
    ) -> Option<egui::Rect> {
        let mut drawn = None;
        match &self.textures[i] {
            Some(t) => {
                let shown = letterbox(rect, t.size_vec2());
                ui.painter().image(t.id(), shown, full_uv(), Color32::WHITE);
                drawn = Some(shown);
            }
            None => {
                waiting_note(ui, rect, "Preparing the car…");
            }
        }
        if let Some(label) = label {
            pane_label(
                ui,
                rect.left_top() + egui::vec2(6.0, 6.0),
                egui::Align2::LEFT_TOP,
                label,
            );
        }
        drawn
    }

    /// The split view; returns the part of `rect` its two images cover.
    fn split_ui(
        &mut self,
        ui: &mut Ui,
        rect: egui::Rect,
        labels: &[String; 2],
    ) -> Option<egui::Rect> {
        let r = ui.interact(
            rect,
            ui.scope_id().with("pane-split"),
            egui::Sense::click_and_drag(),
        );
        named(&r, "Preview pane: split");
        let size = self.textures[0]
            .as_ref()
            .map(|t| t.size_vec2())
            .unwrap_or(egui::vec2(16.0, 10.0));
        let shown = letterbox(rect, size);
        let x = shown.left() + self.divider * shown.width();
        let drawn = self.textures.iter().all(Option::is_some).then_some(shown);
        for (i, t) in self.textures.iter().enumerate() {
            let Some(t) = t else { continue };
            let (part, uv) = if i == 0 {
                (
                    egui::Rect::from_min_max(shown.min, egui::pos2(x, shown.bottom())),
                    egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(self.divider, 1.0)),
                )
            } else {
                (
                    egui::Rect::from_min_max(egui::pos2(x, shown.top()), shown.max),
                    egui::Rect::from_min_max(egui::pos2(self.divider, 0.0), egui::pos2(1.0, 1.0)),
                )
            };
            ui.painter().image(t.id(), part, uv, Color32::WHITE);
        }
        if self.textures[0].is_none() {
            self.image_ui(ui, 0, rect, None);
        }
        // The divider: a handle over the line, on top of the picture's own drag area.
        let handle = egui::Rect::from_center_size(
            egui::pos2(x, shown.center().y),
            egui::vec2(12.0, shown.height()),
        );
        let d = ui
            .interact(
                handle,
                ui.scope_id().with("split-divider"),
                egui::Sense::drag(),
            )
            .on_hover_cursor(egui::CursorIcon::ResizeHorizontal);
        named(&d, "Split divider");
        if d.dragged() {
            self.divider =
                (self.divider + d.drag_delta().x / shown.width().max(1.0)).clamp(0.0, 1.0);
        }
        let stroke = if d.hovered() || d.dragged() { 3.0 } else { 1.5 };
        ui.painter().line_segment(
            [egui::pos2(x, shown.top()), egui::pos2(x, shown.bottom())],
            egui::Stroke::new(stroke, Color32::WHITE),
        );
        ui.painter()
            .circle_filled(egui::pos2(x, shown.center().y), 6.0, Color32::WHITE);
        pane_label(
            ui,
            shown.left_top() + egui::vec2(6.0, 6.0),
            egui::Align2::LEFT_TOP,
            &labels[0],
        );
        pane_label(
            ui,
            shown.right_top() + egui::vec2(-6.0, 6.0),
            egui::Align2::RIGHT_TOP,
            &labels[1],
        );
        if !d.dragged() {
            self.click_to_paint(&r, drawn);
            self.camera_input(ui, &r);
        }
        drawn
    }

    /// A click (not a drag) in `response`'s area on the picture `shown` toggles
    /// the paint of the material under it (the engine picks it through the
    /// camera of the views, which every layout shares).
    fn click_to_paint(&mut self, response: &egui::Response, shown: Option<egui::Rect>) {
        if let (true, Some(pos), Some(shown)) =
            (response.clicked(), response.interact_pointer_pos(), shown)
            && shown.contains(pos)
        {
            let at = (pos - shown.min) / shown.size();
            self.send(Command::TogglePaintAt(at.x, at.y));
        }
    }

    /// The ΔE00 map; returns where its (opaque) image went.
    fn map_ui(
        &self,
        ui: &Ui,
        rect: egui::Rect,
        response: &egui::Response,
        labels: &[String; 2],
    ) -> Option<egui::Rect> {
        let (Some(t), Some(map)) = (&self.map_texture, &self.delta_e) else {
            waiting_note(ui, rect, "Computing the ΔE00 map…");
            return None;
        };
        let shown = letterbox(rect, t.size_vec2());
        ui.painter().image(t.id(), shown, full_uv(), Color32::WHITE);
        pane_label(
            ui,
            shown.left_top() + egui::vec2(6.0, 6.0),
            egui::Align2::LEFT_TOP,
            &format!(
                "ΔE00 {} vs {}: mean {:.2}, 95th percentile {:.2}, max {:.1} ({} spp)",
                labels[0], labels[1], map.mean, map.p95, map.max, map.samples_per_pixel
            ),
        );
        if let Some(pos) = response.hover_pos()
            && shown.contains(pos)
        {
            let u = (pos - shown.min) / shown.size();
            let x = ((u.x * map.width as f32) as u32).min(map.width - 1);
            let y = ((u.y * map.height as f32) as u32).min(map.height - 1);
            if let Some(v) = map.values.get((y * map.width + x) as usize)
                && v.is_finite()
            {
                pane_label(
                    ui,
                    pos + egui::vec2(14.0, 0.0),
                    egui::Align2::LEFT_CENTER,
                    &format!("ΔE00 {v:.2}"),
                );
            }
        }
        Some(shown)
    }

    fn camera_input(&mut self, ui: &Ui, response: &egui::Response) {
        let delta = response.drag_delta();
        if delta != egui::Vec2::ZERO {
            if response.dragged_by(egui::PointerButton::Primary) {
                self.send(Command::Orbit(-delta.x * 0.4, delta.y * 0.4));
            } else {
                let scale = self.size.0 as f32 / response.rect.width().max(1.0);
                self.send(Command::Pan(delta.x * scale, delta.y * scale));
            }
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.send(Command::Zoom((scroll * 0.004).exp()));
            }
        }
    }
}

pub(super) fn upload(
    ctx: &egui::Context,
    slot: &mut Option<egui::TextureHandle>,
    name: &str,
    image: egui::ColorImage,
) {
    match slot {
        Some(t) => t.set(image, egui::TextureOptions::LINEAR),
        None => *slot = Some(ctx.load_texture(name, image, egui::TextureOptions::LINEAR)),
    }
}

/// Gives an area a name assistive technology (and the tests) can find it by.
fn named(response: &egui::Response, name: &str) {
    let role = if name == "Split divider" {
        egui::Role::Splitter
    } else {
        egui::Role::Image
    };
    response.widget_info(|| egui::WidgetInfo::labeled(role, true, name));
}

fn full_uv() -> egui::Rect {
    egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0))
}

/// The parts of `rect` outside every rectangle of `covered`, as disjoint rectangles
/// (horizontal bands between the covered rectangles' edges, split at their sides).
pub(in crate::gui) fn uncovered(rect: egui::Rect, covered: &[egui::Rect]) -> Vec<egui::Rect> {
    let covered: Vec<egui::Rect> = covered
        .iter()
        .map(|c| c.intersect(rect))
        .filter(|c| c.is_positive())
        .collect();
    let mut ys: Vec<f32> = vec![rect.top(), rect.bottom()];
    ys.extend(covered.iter().flat_map(|c| [c.top(), c.bottom()]));
    ys.sort_by(f32::total_cmp);
    ys.dedup();
    let mut out = Vec::new();
    for band in ys.windows(2) {
        let (top, bottom) = (band[0], band[1]);
        if bottom <= top {
            continue;
        }
        // The covered x-intervals of this band, left to right.
        let mut spans: Vec<(f32, f32)> = covered
            .iter()
            .filter(|c| c.top() <= top && c.bottom() >= bottom)
            .map(|c| (c.left(), c.right()))
            .collect();
        spans.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut x = rect.left();
        for (left, right) in spans {
            if left > x {
                out.push(egui::Rect::from_min_max(
                    egui::pos2(x, top),
                    egui::pos2(left, bottom),
                ));
            }
            x = x.max(right);
        }
        if x < rect.right() {
            out.push(egui::Rect::from_min_max(
                egui::pos2(x, top),
                egui::pos2(rect.right(), bottom),
            ));
        }
    }
    out
}

/// The largest rectangle of `size`'s aspect centred in `rect`.
fn letterbox(rect: egui::Rect, size: egui::Vec2) -> egui::Rect {
    let scale = (rect.width() / size.x.max(1.0)).min(rect.height() / size.y.max(1.0));
    egui::Rect::from_center_size(rect.center(), size * scale)
}

/// A label on a dark backing, readable over any picture.
fn pane_label(ui: &Ui, pos: egui::Pos2, align: egui::Align2, text: &str) {
    let painter = ui.painter();
    let galley = painter.layout_no_wrap(
        text.to_owned(),
        egui::FontId::proportional(13.0),
        Color32::WHITE,
    );
    let rect = align.anchor_size(pos, galley.size()).expand(3.0);
    painter.rect_filled(rect, 3.0, Color32::from_black_alpha(150));
    painter.galley(rect.min + egui::vec2(3.0, 3.0), galley, Color32::WHITE);
}

pub(super) fn names_of(materials: &[MaterialInfo], indices: &[u32]) -> String {
    let names: Vec<&str> = indices
        .iter()
        .filter_map(|&i| materials.get(i as usize).map(|m| m.name.as_str()))
        .collect();
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}

/// The render size for an area of `w`×`h` physical pixels, with the area's
/// aspect, within [`MAX_PREVIEW_PIXELS`] and, for `views` views rendered side by
/// side in time, within their share of its pixels: a comparison's two views
/// together cost what one view costs, and the split and map layouts converge
/// about as fast as the side-by-side panes (278×400 in the default window), for
/// which the 30-second figures of `docs/gui.md` are measured.
pub(super) fn fit(w: f32, h: f32, views: u32) -> (u32, u32) {
    let (mw, mh) = (MAX_PREVIEW_PIXELS.0 as f32, MAX_PREVIEW_PIXELS.1 as f32);
    let (w, h) = (w.max(1.0), h.max(1.0));
    let share = mw * mh / views.max(1) as f32;
    let scale = (mw / w).min(mh / h).min((share / (w * h)).sqrt()).min(1.0);
    ((w * scale).round() as u32, (h * scale).round() as u32)
}

/// A faint note in the middle of `rect` while its image is not ready yet.
fn waiting_note(ui: &egui::Ui, rect: egui::Rect, text: &str) {
    ui.painter().text(
        rect.center(),
        egui::Align2::CENTER_CENTER,
        text,
        egui::FontId::proportional(16.0),
        ui.visuals().weak_text_color(),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(x0: f32, y0: f32, x1: f32, y1: f32) -> egui::Rect {
        egui::Rect::from_min_max(egui::pos2(x0, y0), egui::pos2(x1, y1))
    }

    fn area(rects: &[egui::Rect]) -> f32 {
        rects.iter().map(|r| r.area()).sum()
    }

    fn overlap(a: egui::Rect, b: egui::Rect) -> bool {
        let i = a.intersect(b);
        i.width() > 1e-3 && i.height() > 1e-3
    }

    /// One view renders up to 640×400; a comparison's two views each get at most
    /// half those pixels, with the area's aspect kept, so a side-by-side pane of
    /// the default window keeps its size and a split or map layout renders
    /// 453×283 instead of 640×400.
    #[test]
    fn a_comparisons_views_share_one_views_pixels() {
        assert_eq!(fit(640.0, 400.0, 1), (640, 400));
        assert_eq!(fit(1280.0, 800.0, 1), (640, 400));
        assert_eq!(fit(300.0, 200.0, 1), (300, 200));
        assert_eq!(fit(640.0, 400.0, 2), (453, 283));
        assert_eq!(fit(1280.0, 800.0, 2), (453, 283));
        // The default window's side-by-side pane area, in pixels.
        assert_eq!(fit(515.0, 740.0, 2), (278, 400));
        assert_eq!(fit(316.0, 400.0, 2), (316, 400));
        assert_eq!(fit(632.0, 800.0, 2), (316, 400));
        for (w, h) in [
            (640.0, 400.0),
            (1000.0, 300.0),
            (400.0, 1000.0),
            (576.0, 400.0),
        ] {
            let (fw, fh) = fit(w, h, 2);
            assert!(fw * fh <= 128_000 + fw + fh, "{w}×{h} → {fw}×{fh}");
            let (aspect, fitted) = (w / h, fw as f32 / fh as f32);
            assert!((fitted / aspect - 1.0).abs() < 0.01, "{w}×{h} → {fw}×{fh}");
        }
    }

    /// The background fill and the images tile the preview area exactly: every
    /// point is painted once, by the fill or by an image.
    #[test]
    fn the_background_covers_exactly_what_the_images_leave() {
        let rect = r(0.0, 0.0, 1000.0, 800.0);
        let cases: Vec<Vec<egui::Rect>> = vec![
            vec![],
            vec![letterbox(rect, egui::vec2(532.0, 400.0))],
            vec![letterbox(rect, egui::vec2(200.0, 400.0))],
            // Side by side, with a gap between the panes.
            vec![r(0.0, 200.0, 495.0, 600.0), r(505.0, 190.0, 1000.0, 610.0)],
            // Reaching outside the area (clipped) and touching its corner.
            vec![
                r(-50.0, -50.0, 100.0, 100.0),
                r(900.0, 700.0, 1100.0, 900.0),
            ],
        ];
        for covered in cases {
            let fill = uncovered(rect, &covered);
            let inside: Vec<egui::Rect> = covered.iter().map(|c| c.intersect(rect)).collect();
            let total = area(&fill) + area(&inside);
            assert!(
                (total - rect.area()).abs() < 1e-3 * rect.area(),
                "{covered:?}: fill {} + images {} != {}",
                area(&fill),
                area(&inside),
                rect.area()
            );
            for (i, a) in fill.iter().enumerate() {
                assert!(a.is_positive() && rect.contains_rect(*a), "{a:?}");
                for c in &inside {
                    assert!(!overlap(*a, *c), "{a:?} overlaps {c:?}");
                }
                for b in &fill[i + 1..] {
                    assert!(!overlap(*a, *b), "{a:?} overlaps {b:?}");
                }
            }
        }
    }
}
