//! Quality presets of the preview, taken from the measured speed/accuracy trade
//! (docs/tradeoff.md): each preset is a point on the Pareto front that
//! `cargo xtask bench tradeoff` measured, stored with its error and cost in
//! `assets/quality-presets.toml` (written by the bench, embedded here, validated at
//! start-up). Choosing one sets the preview's wavelength count, sample target and
//! resolution; the status line then shows the error left: the noise estimate of the
//! image so far plus the preset's measured bias floor.

use std::sync::OnceLock;

use coatlab_core::colour::spectrum::{MAX_VISIBLE_SAMPLES, WavelengthGrid};
use egui::Ui;
use serde::Deserialize;

/// The presets file, as the bench wrote it.
pub const PRESETS_TOML: &str = include_str!("../../../../assets/quality-presets.toml");

/// Knobs of the preview that a preset sets (the live engine's).
pub use coatlab_core::engine::QualityKnobs;

/// One preset with what the bench measured for it.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct QualityPreset {
    pub name: String,
    pub wavelengths: usize,
    pub samples_per_pixel: u32,
    pub resolution_divisor: u32,
    /// CPU time (both cores) of one protocol-sized image, s.
    pub cpu_seconds: f64,
    /// Wall time of one protocol-sized image on the shared 2-core machine, s.
    pub wall_seconds: f64,
    /// Mean per-pixel ΔE00 against the reference.
    pub mean_delta_e: f64,
    /// 95th percentile of the per-pixel ΔE00.
    pub p95_delta_e: f64,
    /// Largest region-mean ΔE00: the error that more samples do not remove.
    pub bias_delta_e: f64,
}

impl QualityPreset {
    /// The preview knobs of this preset.
    pub fn knobs(&self) -> QualityKnobs {
        QualityKnobs {
            wavelengths: self.wavelengths,
            max_spp: self.samples_per_pixel,
            resolution_divisor: self.resolution_divisor,
        }
    }

    /// The measured figures, in words.
    pub fn figures(&self, presets: &QualityPresets) -> String {
        format!(
            "{}: {} λ, {} spp{} · measured ΔE00 mean {:.2}, p95 {:.2}, bias {:.2} · {:.2} s CPU per {}×{} image",
            self.name,
            self.wavelengths,
            self.samples_per_pixel,
            if self.resolution_divisor > 1 {
                format!(", 1/{} resolution", self.resolution_divisor)
            } else {
                String::new()
            },
            self.mean_delta_e,
            self.p95_delta_e,
            self.bias_delta_e,
            self.cpu_seconds,
            presets.protocol_width,
            presets.protocol_height
        )
    }
}

/// The presets file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct QualityPresets {
    /// The protocol case the figures were measured on.
    pub case: String,
    pub protocol_width: u32,
    pub protocol_height: u32,
    #[serde(rename = "preset")]
    pub presets: Vec<QualityPreset>,
}

impl QualityPresets {
    /// Parses and validates a presets file; errors name the preset and field.
    pub fn parse(text: &str) -> Result<Self, String> {
        let presets: QualityPresets =
            toml::from_str(text).map_err(|e| format!("quality presets: {e}"))?;
        if presets.presets.is_empty() {
            return Err("quality presets: the file has no [[preset]]".into());
        }
        for (i, p) in presets.presets.iter().enumerate() {
            let bad = |field: &str, why: &str| {
                Err(format!(
                    "quality preset {} ('{}'): {field} {why}",
                    i + 1,
                    p.name
                ))
            };
            if p.name.trim().is_empty() {
                return bad("name", "is empty");
            }
            if presets.presets[..i].iter().any(|q| q.name == p.name) {
                return bad("name", "is used twice");
            }
            if WavelengthGrid::visible(p.wavelengths).is_err() {
                return bad(
                    "wavelengths",
                    &format!("must be 1 to {MAX_VISIBLE_SAMPLES}"),
                );
            }
            if p.samples_per_pixel == 0 {
                return bad("samples_per_pixel", "must be at least 1");
            }
            if !(1..=16).contains(&p.resolution_divisor) {
                return bad("resolution_divisor", "must be 1 to 16");
            }
            for (field, v) in [
                ("cpu_seconds", p.cpu_seconds),
                ("wall_seconds", p.wall_seconds),
                ("mean_delta_e", p.mean_delta_e),
                ("p95_delta_e", p.p95_delta_e),
                ("bias_delta_e", p.bias_delta_e),
            ] {
                if !(v.is_finite() && v >= 0.0) {
                    return bad(field, "must be a finite number ≥ 0");
                }
            }
        }
        Ok(presets)
    }

    /// The embedded presets (parsed once); the error says what is wrong with the
    /// committed file.
    pub fn embedded() -> Result<&'static QualityPresets, &'static str> {
        static PARSED: OnceLock<Result<QualityPresets, String>> = OnceLock::new();
        PARSED
            .get_or_init(|| QualityPresets::parse(PRESETS_TOML))
            .as_ref()
            .map_err(String::as_str)
    }
}

/// The preview's quality choice: a preset, or the built-in defaults.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct QualitySelector {
    /// Index into the embedded presets; `None`: the defaults.
    pub selected: Option<usize>,
    pub knobs: QualityKnobs,
}

impl QualitySelector {
    /// The chosen preset, if any.
    pub fn preset(&self) -> Option<&'static QualityPreset> {
        let presets = QualityPresets::embedded().ok()?;
        presets.presets.get(self.selected?)
    }

    /// The error left, in words, for the status line: the noise estimate plus the
    /// preset's measured bias floor (ΔE00 add up at most linearly).
    pub fn error_left(&self, noise_delta_e: Option<f64>) -> Option<String> {
        let preset = self.preset()?;
        Some(match noise_delta_e {
            Some(noise) => format!(
                "error left ≈ ΔE00 {:.2} (noise {noise:.2} + {} bias floor {:.2})",
                noise + preset.bias_delta_e,
                preset.name,
                preset.bias_delta_e
            ),
            None => format!("{} bias floor ΔE00 {:.2}", preset.name, preset.bias_delta_e),
        })
    }
}

/// The quality selector: a combo box of the presets with each one's measured
/// figures; returns the knobs to apply when the choice changed.
pub fn quality_ui(ui: &mut Ui, selector: &mut QualitySelector) -> Option<QualityKnobs> {
    let presets = match QualityPresets::embedded() {
        Ok(p) => p,
        Err(e) => {
            ui.label(egui::RichText::new(e).color(ui.visuals().error_fg_color));
            return None;
        }
    };
    let mut selected = selector.selected;
    let shown = selector
        .preset()
        .map(|p| p.name.clone())
        .unwrap_or_else(|| "Default".to_owned());
    egui::ComboBox::from_label("Quality")
        .selected_text(shown)
        .show_ui(ui, |ui| {
            ui.selectable_value(&mut selected, None, "Default")
                .on_hover_text(
                    "32 wavelengths, refined to 1024 spp, full resolution (not measured)",
                );
            for (i, p) in presets.presets.iter().enumerate() {
                ui.selectable_value(&mut selected, Some(i), &p.name)
                    .on_hover_text(p.figures(presets));
            }
        });
    if let Some(p) = selector.preset() {
        ui.label(egui::RichText::new(p.figures(presets)).weak());
    }
    if selected == selector.selected {
        return None;
    }
    selector.selected = selected;
    selector.knobs = selector
        .preset()
        .map(QualityPreset::knobs)
        .unwrap_or_default();
    Some(selector.knobs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_presets_parse_and_are_ordered_by_cost_and_error() {
        let presets = QualityPresets::embedded().expect("the committed presets are valid");
        assert!(presets.presets.len() >= 2);
        let first = &presets.presets[0];
        let last = presets.presets.last().unwrap();
        assert!(first.cpu_seconds <= last.cpu_seconds);
        assert!(first.mean_delta_e >= last.mean_delta_e);
    }

    #[test]
    fn bad_preset_files_are_refused_naming_the_field() {
        let good = "case = \"c\"\nprotocol_width = 320\nprotocol_height = 180\n[[preset]]\nname = \"A\"\nwavelengths = 8\nsamples_per_pixel = 4\nresolution_divisor = 1\ncpu_seconds = 0.1\nwall_seconds = 0.05\nmean_delta_e = 3.0\np95_delta_e = 6.0\nbias_delta_e = 0.5\n";
        assert!(QualityPresets::parse(good).is_ok());
        let e =
            QualityPresets::parse(&good.replace("wavelengths = 8", "wavelengths = 0")).unwrap_err();
        assert!(e.contains("'A'") && e.contains("wavelengths"), "{e}");
        let e = QualityPresets::parse(&good.replace("cpu_seconds = 0.1", "cpu_seconds = -1.0"))
            .unwrap_err();
        assert!(e.contains("cpu_seconds"), "{e}");
        assert!(QualityPresets::parse("case = 1").is_err());
    }

    /// The cheapest preset's measured mean ΔE00, measured again here rather than read
    /// back from the bench's output: the protocol of `cargo xtask bench tradeoff`
    /// (xtask/src/bench.rs) on its primary case, the built-in car in the studio painted with
    /// the first built-in design, 320×180, rendered at the preset's wavelengths,
    /// samples and resolution with several seeds and compared with an 81-wavelength
    /// reference of fewer samples than the bench's.
    ///
    /// The bound. Per pixel, ΔE00 obeys the triangle inequality (closely enough: it
    /// is a distance in a locally Euclidean colour space), so against a reference R
    /// whose own noise is n_R = mean ΔE00(R, truth), a render's mean error is its
    /// error against the truth ± n_R. The committed figure was measured with seed 7
    /// against the bench's reference, so it is that render's error against the truth
    /// ± n_bench; seed to seed the error varies with a standard deviation s,
    /// estimated from the k seeds here. So the figure must lie within the seeds'
    /// mean ± (n_R + n_bench + 4 s √(1 + 1/k)). n_R is half the mean ΔE00 between
    /// this reference's two halves (they differ by √2 × a half's noise = 2 × the
    /// whole's; the bench's own estimate). n_bench is the noise the bench recorded
    /// for its reference beside the table (docs/tradeoff.md); it is not scaled down
    /// from n_R by √(spp ratio): the renders' rare bright paths make the noise fall
    /// more slowly than that (the recorded value for 1024 spp exceeds n_R here).
    /// The negative controls: the figure doubled and halved must fall outside.
    #[test]
    fn the_cheapest_presets_error_is_what_a_new_measurement_gives() {
        use std::sync::Arc;

        use coatlab_core::design::{PaintDesign, presets};
        use coatlab_core::render::camera::Camera;
        use coatlab_core::render::environment::Environment;
        use coatlab_core::render::film::DisplaySettings;
        use coatlab_core::render::image_error::{RegionMasks, XyzImage, image_error};
        use coatlab_core::render::material::ShadingModel;
        use coatlab_core::render::progressive::{ProgressiveRender, RenderScene, RenderSettings};
        use coatlab_core::scene::car::{CarParameters, generate};

        /// The reference's samples per pixel (two halves of half as many).
        const REFERENCE_SPP: u32 = 128;
        const HALF_SEEDS: [u64; 2] = [0x5eed_0001, 0x5eed_0002];
        const SEEDS: std::ops::Range<u64> = 7..15;

        let presets = QualityPresets::embedded().expect("the committed presets are valid");
        assert_eq!(
            presets.case, "default car, studio",
            "the protocol case changed"
        );
        let size = (presets.protocol_width, presets.protocol_height);
        let preset = presets
            .presets
            .iter()
            .min_by(|a, b| a.cpu_seconds.total_cmp(&b.cpu_seconds))
            .expect("a preset");
        let scene = Arc::new(
            RenderScene::new(generate(&CarParameters::default())).expect("the built-in car"),
        );
        let design: PaintDesign = presets::all().swap_remove(0).design;
        let render = |wavelengths: usize, spp: u32, divisor: u32, seed: u64| {
            let grid = WavelengthGrid::visible(wavelengths).expect("wavelengths");
            let model = design.model(grid).expect("the design is valid");
            let shading = scene.shading(&model, ShadingModel::Paint);
            let (width, height) = ((size.0 / divisor).max(1), (size.1 / divisor).max(1));
            let mut render = ProgressiveRender::new(
                Arc::clone(&scene),
                Arc::new(Environment::studio(&grid)),
                Arc::new(shading),
                Camera::framing(scene.bounds(), width, height),
                RenderSettings::seeded(seed),
            )
            .expect("a render");
            render.render_to(spp, 4);
            XyzImage::from_film(render.film()).resized(size.0, size.1)
        };
        // The protocol's camera: the scene-box framing the presets were measured
        // with (see `PreparedCase::camera` in xtask/src/bench.rs).
        let masks =
            RegionMasks::from_scene(&scene, &Camera::framing(scene.bounds(), size.0, size.1));
        let error = |a: &XyzImage, b: &XyzImage| {
            image_error(a, b, &masks, &DisplaySettings::MEASURED)
                .expect("same sizes")
                .mean_delta_e
        };

        let halves = HALF_SEEDS.map(|seed| render(81, REFERENCE_SPP / 2, 1, seed));
        let reference = halves[0].average(&halves[1]).expect("same sizes");
        let noise = error(&halves[0], &halves[1]) / 2.0;
        // | case | cache key | render time | noise mean | noise p95 | regions |
        let noise_bench: f64 = include_str!("../../../../docs/tradeoff.md")
            .lines()
            .filter(|l| l.starts_with(&format!("| {} | `", presets.case)))
            .find_map(|l| l.split('|').nth(4)?.trim().parse().ok())
            .expect("the bench's reference noise for the case, in docs/tradeoff.md");

        let errors: Vec<f64> = SEEDS
            .map(|seed| {
                let image = render(
                    preset.wavelengths,
                    preset.samples_per_pixel,
                    preset.resolution_divisor,
                    seed,
                );
                error(&image, &reference)
            })
            .collect();
        let k = errors.len() as f64;
        let mean = errors.iter().sum::<f64>() / k;
        let sd = (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (k - 1.0)).sqrt();
        let half_width = noise + noise_bench + 4.0 * sd * (1.0 + 1.0 / k).sqrt();
        let within = |figure: f64| (figure - mean).abs() <= half_width;
        println!(
            "{}: measured mean ΔE00 {mean:.3} (seed sd {sd:.4}), reference noise {noise:.3}, \
             the bench's {noise_bench:.3}: the figure may lie in {:.3}..{:.3}; it is {:.3}",
            preset.name,
            mean - half_width,
            mean + half_width,
            preset.mean_delta_e
        );
        assert!(
            within(preset.mean_delta_e),
            "{}: the committed mean ΔE00 {} is not what the protocol measures ({mean:.3} ± {half_width:.3})",
            preset.name,
            preset.mean_delta_e
        );
        for control in [2.0 * preset.mean_delta_e, 0.5 * preset.mean_delta_e] {
            assert!(
                !within(control),
                "the bound ({mean:.3} ± {half_width:.3}) cannot tell {control:.3} from the figure"
            );
        }
    }

    /// The presets sit on the Pareto front of the committed table (docs/tradeoff.md):
    /// no row of the presets' case is both faster and more accurate.
    #[test]
    fn each_preset_is_on_the_front_of_the_committed_table() {
        let presets = QualityPresets::embedded().unwrap();
        let doc = include_str!("../../../../docs/tradeoff.md");
        // | case | knobs | λ | spp | CPU s | wall s | mean | p95 | body | top | floor | bias | front |
        let rows: Vec<(String, usize, u32, f64, f64, bool)> = doc
            .lines()
            .filter(|l| l.starts_with(&format!("| {} |", presets.case)))
            .filter_map(|l| {
                let c: Vec<&str> = l.split('|').map(str::trim).collect();
                Some((
                    c.get(2)?.to_string(),
                    c.get(3)?.parse().ok()?,
                    c.get(4)?.parse().ok()?,
                    c.get(5)?.parse().ok()?,
                    c.get(7)?.parse().ok()?,
                    c.get(13)? == &"★",
                ))
            })
            .collect();
        assert!(
            rows.len() > 5,
            "the table of '{}' is in docs/tradeoff.md",
            presets.case
        );
        for p in &presets.presets {
            let knobs = if p.resolution_divisor > 1 {
                format!("1/{} res", p.resolution_divisor)
            } else {
                "spectral".to_owned()
            };
            let row = rows
                .iter()
                .find(|r| r.0 == knobs && r.1 == p.wavelengths && r.2 == p.samples_per_pixel)
                .unwrap_or_else(|| panic!("preset {} is a row of the table", p.name));
            assert!(row.5, "preset {} is marked on the front", p.name);
            let dominated = rows
                .iter()
                .any(|r| r.3 <= row.3 && r.4 <= row.4 && (r.3 < row.3 || r.4 < row.4));
            assert!(!dominated, "preset {} is dominated", p.name);
            assert!(
                (row.4 - p.mean_delta_e).abs() < 0.01,
                "preset {} error",
                p.name
            );
        }
    }
}
