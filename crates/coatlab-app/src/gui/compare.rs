//! The comparison views of the preview: what the second pane shows, how the two
//! panes are laid out, and the ΔE00 map between them (per-pixel CIEDE2000 of the
//! displayed colours, as a false-colour image with its scale).

use coatlab_core::colour::{Xyz, ciede2000};
use coatlab_core::render::film::{DisplaySettings, Film, display_lab_of_xyz};
use egui::{Color32, Ui};
use rayon::prelude::*;

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

/// Per-pixel ΔE00 between two renders of the same view.
#[derive(Debug, Clone)]
pub struct DeltaEMap {
    pub width: u32,
    pub height: u32,
    /// Row-major from the top-left; NaN where either pixel has no sample.
    pub values: Vec<f32>,
    pub mean: f64,
    pub p95: f64,
    pub max: f64,
    /// Samples per pixel of both renders when the map was made.
    pub samples_per_pixel: u32,
}

impl DeltaEMap {
    /// CIEDE2000 between the colours `a` and `b` are shown in with `display` (the same
    /// settings for both, so exposure cannot hide or invent a difference). `None` when
    /// the films differ in size or hold no samples.
    pub fn between(a: &Film, b: &Film, display: &DisplaySettings) -> Option<DeltaEMap> {
        let (width, height) = (a.width(), a.height());
        if (b.width(), b.height()) != (width, height) || width == 0 || height == 0 {
            return None;
        }
        // Rows in parallel: a 640×400 map is ~0.25 M CIEDE2000 evaluations.
        let values: Vec<f32> = (0..height)
            .into_par_iter()
            .flat_map_iter(|y| {
                (0..width).map(move |x| {
                    if a.sample_count(x, y) == 0 || b.sample_count(x, y) == 0 {
                        return f32::NAN;
                    }
                    ciede2000(a.display_lab(x, y, display), b.display_lab(x, y, display)) as f32
                })
            })
            .collect();
        Self::of_values(width, height, values)
    }

    /// [`Self::between`] for two images given as mean XYZ per pixel (row-major,
    /// `width` × `height`): the comparison's panes re-shaded from one set of paths.
    pub fn between_xyz(
        width: u32,
        height: u32,
        a: &[[f32; 3]],
        b: &[[f32; 3]],
        display: &DisplaySettings,
    ) -> Option<DeltaEMap> {
        let n = (width as usize) * (height as usize);
        if a.len() != n || b.len() != n || n == 0 {
            return None;
        }
        let lab = |v: [f32; 3]| {
            display_lab_of_xyz(
                Xyz::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2])),
                display,
            )
        };
        let values: Vec<f32> = a
            .par_iter()
            .zip(b.par_iter())
            .map(|(&va, &vb)| {
                if va == vb {
                    // The same paths with the same value (the backdrop, or a design
                    // against itself): 0 without two colour conversions.
                    0.0
                } else {
                    ciede2000(lab(va), lab(vb)) as f32
                }
            })
            .collect();
        Self::of_values(width, height, values)
    }

    /// The map of per-pixel `values` with its statistics.
    fn of_values(width: u32, height: u32, values: Vec<f32>) -> Option<DeltaEMap> {
        let mut sorted: Vec<f32> = values.iter().copied().filter(|v| v.is_finite()).collect();
        if sorted.is_empty() {
            return None;
        }
        sorted.sort_by(f32::total_cmp);
        let mean = sorted.iter().map(|&v| f64::from(v)).sum::<f64>() / sorted.len() as f64;
        let p95 = f64::from(sorted[((sorted.len() - 1) as f64 * 0.95).round() as usize]);
        let max = f64::from(sorted[sorted.len() - 1]);
        Some(DeltaEMap {
            width,
            height,
            values,
            mean,
            p95,
            max,
            samples_per_pixel: 0,
        })
    }

    /// The map in false colour, `scale_max` at the top of the scale (larger values
    /// clamp to it); pixels without a value are dark grey.
    pub fn to_colours(&self, scale_max: f32) -> Vec<Color32> {
        let inv = 1.0 / scale_max.max(1e-6);
        self.values
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
