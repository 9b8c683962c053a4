//! A spectrum drawn as a curve with control points the designer drags.
//!
//! The control points sit every `control_step_nm` across the table's span; dragging
//! one adds its change to the table through the point's linear ("hat") basis
//! function, ±one step wide. So the value at the control wavelength moves exactly
//! as dragged, its neighbours follow smoothly, and detail between control points
//! (an imported measurement at 5 nm) is kept instead of being resampled away.
//! Values are clamped to the scale's range, so an invalid spectrum cannot be drawn.
//!
//! Each control point is an accessible slider named "`label` at `λ` nm", so it can
//! be set from the keyboard (arrow keys when focused), by a screen reader, or by a
//! test.

use coatlab_core::colour::spectrum::{TabulatedSpectrum, VISIBLE};
use egui::{Color32, Pos2, Rect, Sense, Stroke, Ui, Vec2, pos2, vec2};

/// The vertical scale of an editor, which is also the range values are clamped to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CurveScale {
    /// Linear between `min` and `max`.
    Linear { min: f64, max: f64 },
    /// Logarithmic (for k(λ), which spans 1e-4 to 0.2 1/µm): `min` > 0.
    Log10 { min: f64, max: f64 },
}

impl CurveScale {
    fn to_unit(self, v: f64) -> f64 {
        match self {
            CurveScale::Linear { min, max } => (v - min) / (max - min),
            CurveScale::Log10 { min, max } => {
                (v.max(min).log10() - min.log10()) / (max.log10() - min.log10())
            }
        }
    }

    fn value_at_unit(self, u: f64) -> f64 {
        match self {
            CurveScale::Linear { min, max } => min + u * (max - min),
            CurveScale::Log10 { min, max } => {
                10f64.powf(min.log10() + u * (max.log10() - min.log10()))
            }
        }
    }

    fn clamp(self, v: f64) -> f64 {
        match self {
            CurveScale::Linear { min, max } => v.clamp(min, max),
            // Zero is a valid k but has no place on a log axis: the floor of the scale
            // stands for it.
            CurveScale::Log10 { min, max } => v.clamp(min, max),
        }
    }

    /// The range values are kept in.
    pub fn range(self) -> (f64, f64) {
        match self {
            CurveScale::Linear { min, max } | CurveScale::Log10 { min, max } => (min, max),
        }
    }
}

/// The control wavelengths of a table: every `step_nm` from the first multiple of
/// the step at or after the table's start, to its end, within the visible range.
pub fn control_wavelengths(table: &TabulatedSpectrum, step_nm: f64) -> Vec<f64> {
    let w = table.wavelengths_nm();
    let (Some(&first), Some(&last)) = (w.first(), w.last()) else {
        return Vec::new();
    };
    let (first, last) = (first.max(VISIBLE.start_nm), last.min(VISIBLE.end_nm));
    let mut out = Vec::new();
    let mut l = (first / step_nm).ceil() * step_nm;
    while l <= last + 1e-9 {
        out.push(l);
        l += step_nm;
    }
    out
}

/// Moves the curve at `control_nm` to `new_value`, its neighbourhood following
/// through the hat of half-width `step_nm` (see the module documentation).
/// Returns the new table; the value at `control_nm` is `new_value` after clamping
/// (up to interpolation, exactly when `control_nm` is one of the table's wavelengths).
pub fn move_control_point(
    table: &TabulatedSpectrum,
    control_nm: f64,
    step_nm: f64,
    new_value: f64,
    scale: CurveScale,
) -> TabulatedSpectrum {
    let new_value = scale.clamp(new_value);
    let old = table.value_at_nm(control_nm);
    let hat = |l: f64| (1.0 - (l - control_nm).abs() / step_nm).max(0.0);
    let values: Vec<f64> = table
        .wavelengths_nm()
        .iter()
        .zip(table.values())
        .map(|(&l, &v)| {
            let w = hat(l);
            if w == 0.0 {
                return v;
            }
            let moved = match scale {
                CurveScale::Linear { .. } => v + (new_value - old) * w,
                // Multiplicative on a log axis: the shape of a UV edge is kept.
                CurveScale::Log10 { min, .. } => {
                    let ratio = new_value.max(min) / old.max(min);
                    v.max(min) * ratio.powf(w)
                }
            };
            scale.clamp(moved)
        })
        .collect();
    // Same wavelengths, finite clamped values: the table stays valid.
    TabulatedSpectrum::new(table.wavelengths_nm().to_vec(), values)
        .unwrap_or_else(|_| table.clone())
}

/// The editor widget; returns the edited table when the user changed it this frame.
pub struct CurveEditor<'a> {
    /// Accessible name prefix of the control points ("ρ").
    pub label: &'a str,
    /// Unit shown after values ("" for ρ, "1/µm" for k).
    pub unit: &'a str,
    pub scale: CurveScale,
    pub control_step_nm: f64,
    pub height: f32,
    /// Colour of the curve.
    pub colour: Color32,
}

impl CurveEditor<'_> {
    /// Draws the curve and handles dragging; `Some(new table)` on a change.
    pub fn show(&self, ui: &mut Ui, table: &TabulatedSpectrum) -> Option<TabulatedSpectrum> {
        let width = ui.available_width().max(200.0);
        let (rect, _) = ui.allocate_exact_size(vec2(width, self.height), Sense::hover());
        let plot = Rect::from_min_max(rect.min + vec2(40.0, 6.0), rect.max - vec2(8.0, 18.0));
        let x_of = |l: f64| {
            let u = (l - VISIBLE.start_nm) / VISIBLE.width_nm();
            plot.left() + u as f32 * plot.width()
        };
        let y_of = |v: f64| plot.bottom() - self.scale.to_unit(v) as f32 * plot.height();
        let value_of_y = |y: f32| {
            self.scale
                .value_at_unit(f64::from((plot.bottom() - y) / plot.height()))
        };

        let painter = ui.painter_at(rect);
        let visuals = ui.visuals();
        painter.rect_filled(plot, 2.0, visuals.extreme_bg_color);
        let grid = Stroke::new(1.0, visuals.weak_text_color().gamma_multiply(0.3));
        let text = visuals.weak_text_color();
        let font = egui::FontId::proportional(10.0);
        for l in (400..=750).step_by(50) {
            let x = x_of(f64::from(l));
            painter.line_segment([pos2(x, plot.top()), pos2(x, plot.bottom())], grid);
            painter.text(
                pos2(x, plot.bottom() + 2.0),
                egui::Align2::CENTER_TOP,
                l.to_string(),
                font.clone(),
                text,
            );
        }
        for (v, label) in self.y_ticks() {
            let y = y_of(v);
            painter.line_segment([pos2(plot.left(), y), pos2(plot.right(), y)], grid);
            painter.text(
                pos2(plot.left() - 3.0, y),
                egui::Align2::RIGHT_CENTER,
                label,
                font.clone(),
                text,
            );
        }
        painter.text(
            pos2(plot.right(), plot.bottom() + 2.0),
            egui::Align2::RIGHT_TOP,
            "nm",
            font.clone(),
            text,
        );

        let points: Vec<Pos2> = table
            .wavelengths_nm()
            .iter()
            .zip(table.values())
            .filter(|(l, _)| VISIBLE.contains(**l))
            .map(|(&l, &v)| pos2(x_of(l), y_of(v)))
            .collect();
        painter.add(egui::Shape::line(points, Stroke::new(2.0, self.colour)));

        let mut edited: Option<TabulatedSpectrum> = None;
        let id = ui.scope_id().with(("curve", self.label));
        for (k, &control_nm) in control_wavelengths(table, self.control_step_nm)
            .iter()
            .enumerate()
        {
            let current = edited.as_ref().unwrap_or(table);
            let value = current.value_at_nm(control_nm);
            let centre = pos2(x_of(control_nm), y_of(value));
            let point_id = id.with(k);
            let hit = Rect::from_center_size(centre, Vec2::splat(14.0));
            let response = ui.interact(hit, point_id, Sense::click_and_drag());
            let name = format!("{} at {control_nm:.0} nm", self.label);
            let (lo, hi) = self.scale.range();
            response.widget_info(|| {
                let mut info = egui::WidgetInfo::labeled(egui::Role::Slider, true, &name);
                info.value = Some(value);
                info
            });
            ui.ctx().accesskit_node_builder(point_id, |node| {
                node.set_min_numeric_value(lo);
                node.set_max_numeric_value(hi);
                node.add_action(egui::accesskit::Action::SetValue);
            });
            let mut target = None;
            if response.dragged()
                && let Some(pointer) = response.interact_pointer_pos()
            {
                target = Some(value_of_y(pointer.y.clamp(plot.top(), plot.bottom())));
            }
            if response.has_focus() {
                let step = ui.input(|i| {
                    f64::from(
                        i.num_presses(egui::Key::ArrowUp) as i32
                            - i.num_presses(egui::Key::ArrowDown) as i32,
                    )
                });
                if step != 0.0 {
                    let u = self.scale.to_unit(value) + 0.01 * step;
                    target = Some(self.scale.value_at_unit(u.clamp(0.0, 1.0)));
                }
            }
            if let Some(v) = accesskit_set_value(ui, point_id) {
                target = Some(v);
            }
            if let Some(v) = target {
                edited = Some(move_control_point(
                    current,
                    control_nm,
                    self.control_step_nm,
                    v,
                    self.scale,
                ));
            }
            let active = response.hovered() || response.dragged() || response.has_focus();
            let radius = if active { 5.5 } else { 4.0 };
            draw_marker(
                ui,
                &painter,
                centre,
                radius,
                visuals.extreme_bg_color,
                Stroke::new(2.0, self.colour),
            );
            let response = response.on_hover_text(format!(
                "{name}: {value:.4} {}\nDrag up or down; arrow keys when focused.",
                self.unit
            ));
            let _ = response;
        }
        edited
    }

    fn y_ticks(&self) -> Vec<(f64, String)> {
        match self.scale {
            CurveScale::Linear { min, max } => {
                let step = nice_step((max - min) / 4.0);
                let mut v = (min / step).ceil() * step;
                let mut out = Vec::new();
                while v <= max + 1e-12 {
                    out.push((v, format!("{v:.2}")));
                    v += step;
                }
                out
            }
            CurveScale::Log10 { min, max } => {
                let mut e = min.log10().ceil() as i32;
                let mut out = Vec::new();
                while f64::from(e) <= max.log10() + 1e-9 {
                    out.push((10f64.powi(e), format!("1e{e}")));
                    e += 1;
                }
                out
            }
        }
    }
}

/// A control point: a disc of `fill` with a ring of `stroke` just outside it, as
/// `painter.circle` draws it, but from two small pre-rendered textures (4
/// triangles) instead of a tessellated, feathered circle (≈ 100 triangles, most
/// thinner than a pixel). A software rasteriser pays per triangle: the editors'
/// 37 points were ~5 k of the window's 12 k triangles a frame
/// (docs/benchmarks.md, "GUI responsiveness").
fn draw_marker(
    ui: &Ui,
    painter: &egui::Painter,
    centre: Pos2,
    radius: f32,
    fill: Color32,
    stroke: Stroke,
) {
    let ppp = ui.ctx().pixels_per_point();
    let key = egui::Id::unique((
        "curve-marker",
        radius.to_bits(),
        stroke.width.to_bits(),
        ppp.to_bits(),
    ));
    // Not created inside `memory_mut`: loading a texture locks the context too.
    let cached: Option<[egui::TextureHandle; 2]> = ui.ctx().data(|d| d.get_temp(key));
    let [disc, ring] = match cached {
        Some(textures) => textures,
        None => {
            let textures = marker_images(radius, stroke.width, ppp).map(|image| {
                ui.ctx()
                    .load_texture("curve-marker", image, egui::TextureOptions::LINEAR)
            });
            ui.ctx().data_mut(|d| d.insert_temp(key, textures.clone()));
            textures
        }
    };
    // The textures' pixels are the screen's: the quad is their size in points.
    let side = disc.size()[0] as f32 / ppp;
    let rect = Rect::from_center_size(centre, Vec2::splat(side));
    let uv = Rect::from_min_max(pos2(0.0, 0.0), pos2(1.0, 1.0));
    painter.image(disc.id(), rect, uv, fill);
    painter.image(ring.id(), rect, uv, stroke.color);
}

/// The coverage masks (white, alpha = the share of each screen pixel covered) of a
/// marker's disc (radius `radius` points) and of its ring (`width` points wide,
/// outside the disc, as egui strokes a circle), `ppp` pixels per point, with a pixel's margin for the
/// edges' anti-aliasing.
fn marker_images(radius: f32, width: f32, ppp: f32) -> [egui::ColorImage; 2] {
    let outer = radius + width;
    let n = (2.0 * outer * ppp).ceil() as usize + 2;
    let half = n as f32 / 2.0;
    // Coverage of "distance < edge" for a pixel at `d` pixels from the centre.
    let inside = |edge: f32, d: f32| (edge * ppp - d + 0.5).clamp(0.0, 1.0);
    let mut disc = Vec::with_capacity(n * n);
    let mut ring = Vec::with_capacity(n * n);
    for y in 0..n {
        for x in 0..n {
            let d = (x as f32 + 0.5 - half).hypot(y as f32 + 0.5 - half);
            let a_disc = inside(radius, d);
            let a_ring = inside(outer, d) - inside(radius, d);
            disc.push(Color32::from_white_alpha((a_disc * 255.0).round() as u8));
            ring.push(Color32::from_white_alpha((a_ring * 255.0).round() as u8));
        }
    }
    [
        egui::ColorImage::new([n, n], disc),
        egui::ColorImage::new([n, n], ring),
    ]
}

fn nice_step(raw: f64) -> f64 {
    let p = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * p)
}

fn accesskit_set_value(ui: &Ui, id: egui::Id) -> Option<f64> {
    use egui::accesskit::{Action, ActionData};
    ui.input(|input| {
        input
            .accesskit_action_requests(id, Action::SetValue)
            .filter_map(|r| match r.data {
                Some(ActionData::NumericValue(v)) => Some(v),
                _ => None,
            })
            .last()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> TabulatedSpectrum {
        let w: Vec<f64> = (0..=80).map(|i| 380.0 + 5.0 * f64::from(i)).collect();
        let v = w.iter().map(|l| 0.2 + 0.0001 * (l - 380.0)).collect();
        TabulatedSpectrum::new(w, v).expect("valid")
    }

    #[test]
    fn a_moved_control_point_lands_where_dragged_and_leaves_far_points_alone() {
        let t = table();
        let scale = CurveScale::Linear { min: 0.0, max: 1.0 };
        let moved = move_control_point(&t, 550.0, 25.0, 0.7, scale);
        assert!((moved.value_at_nm(550.0) - 0.7).abs() < 1e-12);
        assert_eq!(moved.value_at_nm(500.0), t.value_at_nm(500.0));
        assert_eq!(moved.value_at_nm(600.0), t.value_at_nm(600.0));
        let mid = moved.value_at_nm(540.0) - t.value_at_nm(540.0);
        assert!((mid - 0.6 * (0.7 - t.value_at_nm(550.0))).abs() < 1e-12);
    }

    #[test]
    fn values_are_clamped_to_the_scale() {
        let t = table();
        let scale = CurveScale::Linear { min: 0.0, max: 1.0 };
        let moved = move_control_point(&t, 550.0, 25.0, 3.0, scale);
        assert!(moved.values().iter().all(|v| (0.0..=1.0).contains(v)));
        let log = CurveScale::Log10 {
            min: 1e-5,
            max: 1.0,
        };
        let moved = move_control_point(&t, 550.0, 25.0, 1e-3, log);
        assert!((moved.value_at_nm(550.0) - 1e-3).abs() < 1e-12);
        assert!(moved.values().iter().all(|v| *v >= 1e-5 && *v <= 1.0));
    }

    /// The marker's masks cover what a circle of that radius and a ring of that
    /// width cover: areas within half a pixel's rim, and the ring hollow.
    #[test]
    fn a_marker_covers_its_disc_and_ring() {
        for (radius, width, ppp) in [(4.0f32, 2.0f32, 1.0f32), (5.5, 2.0, 1.0), (4.0, 2.0, 2.0)] {
            let [disc, ring] = marker_images(radius, width, ppp);
            let area = |img: &egui::ColorImage| {
                img.pixels
                    .iter()
                    .map(|c| f32::from(c.a()) / 255.0)
                    .sum::<f32>()
            };
            let r = radius * ppp;
            let w = width * ppp;
            let want_disc = std::f32::consts::PI * r * r;
            let want_ring = std::f32::consts::PI * ((r + w).powi(2) - r * r);
            // The rim's anti-aliasing is exact to about a tenth of the perimeter in pixels.
            let tol = |rr: f32| 0.1 * 2.0 * std::f32::consts::PI * rr;
            assert!(
                (area(&disc) - want_disc).abs() < tol(r),
                "disc {} vs {want_disc}",
                area(&disc)
            );
            assert!(
                (area(&ring) - want_ring).abs() < tol(r + w) + tol(r),
                "ring {} vs {want_ring}",
                area(&ring)
            );
            // The centre of the ring's mask is empty, the disc's full.
            let n = disc.size[0];
            let centre = n / 2 * n + n / 2;
            assert_eq!(disc.pixels[centre].a(), 255);
            assert_eq!(ring.pixels[centre].a(), 0);
            // The whole ring fits, with a transparent border for the edge.
            assert!(ring.pixels[..n].iter().all(|c| c.a() == 0));
        }
    }

    #[test]
    fn control_points_cover_the_table() {
        let c = control_wavelengths(&table(), 25.0);
        assert_eq!(c.first(), Some(&400.0));
        assert_eq!(c.last(), Some(&775.0));
    }
}
