//! The comparison views of the preview: what the second pane shows, how the two
//! panes are laid out, and the ΔE00 map between them as a false-colour image with
//! its scale (the map itself, per-pixel CIEDE2000 of the displayed colours, is
//! made by the core's live engine).

pub use coatlab_core::engine::DeltaEMap;
use egui::{Color32, Ui};

/// What the preview compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CompareMode {
    /// One view.
    #[default]
    Off,
    /// The paint model (left) against Phong (right) on the same design.
    Models,
    /// The current design (left) against a second design (right), same model.
    Designs,
}

impl CompareMode {
    pub const ALL: [CompareMode; 3] = [CompareMode::Off, CompareMode::Models, CompareMode::Designs];

    pub fn label(self) -> &'static str {
        match self {
            CompareMode::Off => "No comparison",
            CompareMode::Models => "Paint vs Phong",
            CompareMode::Designs => "Two designs",
        }
    }
}

/// How two views are shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CompareLayout {
    #[default]
    SideBySide,
    /// One picture, left of a draggable divider from the first view, right of it
    /// from the second.
    Split,
    /// The ΔE00 map between the two.
    DeltaE,
}

impl CompareLayout {
    pub const ALL: [CompareLayout; 3] = [
        CompareLayout::SideBySide,
        CompareLayout::Split,
        CompareLayout::DeltaE,
    ];

    pub fn label(self) -> &'static str {
        match self {
            CompareLayout::SideBySide => "Side by side",
            CompareLayout::Split => "Split",
            CompareLayout::DeltaE => "ΔE00 map",
        }
    }
}

/// The ΔE00 map in false colour, `scale_max` at the top of the scale (larger
/// values clamp to it); pixels without a value are dark grey.
pub fn map_colours(map: &DeltaEMap, scale_max: f32) -> Vec<Color32> {
    let inv = 1.0 / scale_max.max(1e-6);
    map.values
        .iter()
        .map(|&v| {
            if v.is_finite() {
                false_colour(v * inv)
            } else {
                Color32::from_gray(40)
            }
        })
        .collect()
}

/// The scales the legend offers, ΔE00 at the top.
pub const SCALES: [f32; 4] = [2.0, 5.0, 10.0, 20.0];

/// Viridis at nine stops (perceptually ordered, readable by most colour-deficient
/// viewers, and unlike any paint colour the map could be confused with).
const VIRIDIS: [[u8; 3]; 9] = [
    [68, 1, 84],
    [71, 44, 122],
    [59, 81, 139],
    [44, 113, 142],
    [33, 144, 141],
    [39, 173, 129],
    [92, 200, 99],
    [170, 220, 50],
    [253, 231, 37],
];

/// The false colour of `t` in [0, 1] (clamped).
pub fn false_colour(t: f32) -> Color32 {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let position = t * (VIRIDIS.len() - 1) as f32;
    let i = (position as usize).min(VIRIDIS.len() - 2);
    let f = position - i as f32;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let mix = |k: usize| (f32::from(a[k]) + (f32::from(b[k]) - f32::from(a[k])) * f).round() as u8;
    Color32::from_rgb(mix(0), mix(1), mix(2))
}

/// The legend: a vertical colour bar from 0 (bottom) to `scale_max` (top) with
/// ticks, in `rect`.
pub fn legend_ui(ui: &Ui, rect: egui::Rect, scale_max: f32) {
    let painter = ui.painter_at(rect);
    let bar = egui::Rect::from_min_size(
        rect.min + egui::vec2(4.0, 24.0),
        egui::vec2(16.0, (rect.height() - 34.0).max(10.0)),
    );
    let steps = 64;
    for s in 0..steps {
        let t0 = s as f32 / steps as f32;
        let t1 = (s + 1) as f32 / steps as f32;
        let band = egui::Rect::from_x_y_ranges(
            bar.x_range(),
            egui::Rangef::new(
                bar.bottom() - t1 * bar.height(),
                bar.bottom() - t0 * bar.height(),
            ),
        );
        painter.rect_filled(band, 0.0, false_colour(0.5 * (t0 + t1)));
    }
    let text = ui.visuals().text_color();
    // Round ticks: 0.5 for the 0–2 scale, 1, 2 and 5 for 0–5, 0–10, 0–20.
    let step = match scale_max {
        s if s <= 2.0 => 0.5,
        s if s <= 5.0 => 1.0,
        s if s <= 10.0 => 2.0,
        _ => 5.0,
    };
    let ticks = (scale_max / step).round().max(1.0) as usize;
    for k in 0..=ticks {
        let value = k as f32 * step;
        let y = bar.bottom() - value / scale_max * bar.height();
        painter.line_segment(
            [egui::pos2(bar.right(), y), egui::pos2(bar.right() + 4.0, y)],
            egui::Stroke::new(1.0, text),
        );
        let label = if step < 1.0 {
            format!("{value:.1}")
        } else {
            format!("{value:.0}")
        };
        // The top colour also stands for everything above the scale.
        let label = if k == ticks {
            format!("{label}+")
        } else {
            label
        };
        painter.text(
            egui::pos2(bar.right() + 6.0, y),
            egui::Align2::LEFT_CENTER,
            label,
            egui::FontId::proportional(12.0),
            text,
        );
    }
    painter.text(
        egui::pos2(bar.left(), rect.top()),
        egui::Align2::LEFT_TOP,
        "ΔE00",
        egui::FontId::proportional(11.0),
        text,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn false_colour_runs_from_dark_violet_to_yellow_and_clamps() {
        assert_eq!(false_colour(0.0), Color32::from_rgb(68, 1, 84));
        assert_eq!(false_colour(1.0), Color32::from_rgb(253, 231, 37));
        assert_eq!(false_colour(7.0), false_colour(1.0));
        assert_eq!(false_colour(f32::NAN), false_colour(0.0));
        // Luminance rises monotonically, so the scale reads as an order.
        let lum =
            |c: Color32| 0.2126 * c.r() as f32 + 0.7152 * c.g() as f32 + 0.0722 * c.b() as f32;
        let mut last = -1.0;
        for i in 0..=100 {
            let l = lum(false_colour(i as f32 / 100.0));
            assert!(l >= last - 0.5, "{i}: {l} after {last}");
            last = l;
        }
    }
}
