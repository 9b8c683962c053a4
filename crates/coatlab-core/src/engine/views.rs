//! The one or two views the engine renders: the first view's render, and the
//! second view of a comparison, a render of its own, shown either combined with
//! the first view's paths re-shaded into it (shared) or alone (rendered apart).

use std::sync::Arc;
use std::thread::JoinHandle;

use crate::colour::spectrum::WavelengthGrid;
use crate::design::PaintDesign;
use crate::render::film::DisplaySettings;
use crate::render::material::{Shading, ShadingModel};
use crate::render::progressive::PassStats;
use crate::render::reshade::{LOBE_WIDENING_ALLOWED, ReshadeError, Reshaded, ShadingDifference};
use crate::scene::SceneMaterial;

use super::backend::BackendView;
use super::{SHARED_LOBE_NARROWING, ThreadHook};

/// The views' renders and what the second view is made of.
pub(super) struct ViewSet<V> {
    /// The first view's render.
    pub first: V,
    /// The second view's own render.
    pub second: Option<V>,
    /// The second view's shading, when the first view's paths re-shade into it:
    /// its pane then combines its own render with them.
    pub shared: Option<Arc<Shading>>,
    /// The difference the second shading makes, from the first view's recorded
    /// paths, and which recordings it is made of.
    pub difference: Option<(ShadingDifference, Recordings)>,
    /// The second view's shading being built; `None` inside: the design is invalid.
    pub job: Option<JoinHandle<Option<Arc<Shading>>>>,
    /// Why the second view is rendered apart, as the user reads it.
    pub reason: String,
    /// Samples per pixel whose paths the first view records.
    pub cache_samples: u32,
    /// The display settings of the last published images (what an export writes).
    pub display: DisplaySettings,
    /// The last passes of the first and the second view (their speed is shown
    /// again with the images).
    pub last_stats: [PassStats; 2],
    /// Whether views rendered apart spend more samples where the map is
    /// undecided ([`super::guide`]).
    pub map_guidance: bool,
    /// The first view's samples per pixel when both views were last given the
    /// map's weights; `None`: not given since the last restart.
    pub guided_at: Option<u32>,
    /// How much sharper the second view's lobe may be and still be shared
    /// ([`SHARED_LOBE_NARROWING`] unless measuring).
    pub lobe_narrowing: f32,
}

/// Which of the first view's recordings a shared difference is made of.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Recordings {
    /// The first recording while it grows: it holds every sample of the film.
    Growing,
    /// Complete recordings; the one in progress is merged in when complete.
    Merged,
    /// Complete recordings, and the back-end records no more: final.
    Final,
}

impl<V: BackendView> ViewSet<V> {
    /// One view, recording `cache_samples` samples per pixel.
    pub fn new(mut first: V, cache_samples: u32) -> Self {
        first.set_path_cache_samples(cache_samples);
        Self {
            first,
            second: None,
            shared: None,
            difference: None,
            job: None,
            reason: String::new(),
            cache_samples,
            display: DisplaySettings::default(),
            last_stats: [PassStats::default(); 2],
            map_guidance: true,
            guided_at: None,
            lobe_narrowing: SHARED_LOBE_NARROWING,
        }
    }

    /// Records `samples` samples per pixel of the first view's paths, if that is
    /// not what it records (restarts the first view).
    pub fn record(&mut self, samples: u32) {
        if samples != self.cache_samples {
            self.cache_samples = samples;
            self.first.set_path_cache_samples(samples);
        }
    }

    /// No second view.
    pub fn drop_second(&mut self) {
        self.second = None;
        self.shared = None;
        self.difference = None;
        self.job = None;
    }

    /// Both panes of a shared comparison: each view's own film combined with
    /// the other's and the difference, with its own film's weight.
    pub fn shared_panes(&self) -> Option<Result<[(Reshaded, f64); 2], ReshadeError>> {
        let (second, (difference, _)) = (self.second.as_ref()?, self.difference.as_ref()?);
        self.shared.as_ref()?;
        let (a, b) = (self.first.film(), second.film());
        // The two panes side by side: each pass publishes them while the
        // tracer's threads wait.
        let (first, second) = rayon::join(
            || difference.combine_first(a, b),
            || difference.combine(a, b),
        );
        Some(first.and_then(|first| Ok([first, second?])))
    }

    /// The second view's image for an export.
    pub fn second_image(&self) -> SecondImage<'_> {
        if let Some(panes) = self.shared_panes() {
            return SecondImage::Reshaded(panes.map(|[_, (image, _)]| image));
        }
        match &self.second {
            Some(render) => SecondImage::Film(render.film()),
            None => SecondImage::None,
        }
    }
}

/// The second view's image, for an export.
#[derive(Debug)]
pub enum SecondImage<'a> {
    /// There is no second view.
    None,
    /// Rendered apart: its film.
    Film(&'a crate::render::film::Film),
    /// Its own film combined with the first view's paths re-shaded into it:
    /// that image (it has no film).
    Reshaded(Result<Reshaded, ReshadeError>),
}

/// What the second view's shading is built from.
pub(super) struct SecondSpec {
    pub design: PaintDesign,
    pub model: ShadingModel,
    pub grid: WavelengthGrid,
    pub materials: Vec<SceneMaterial>,
    pub paint_materials: Vec<u32>,
}

/// Starts building the second view's shading on a thread of its own: a best-fit
/// Phong takes tens of milliseconds to fit, which then overlaps the first view's
/// coarse pass instead of delaying the first new image.
pub(super) fn spawn_second_shading(
    spec: SecondSpec,
    on_start: ThreadHook,
) -> Option<JoinHandle<Option<Arc<Shading>>>> {
    std::thread::Builder::new()
        .name("coatlab-preview-shading".into())
        .spawn(move || {
            on_start();
            let paint = spec.design.model(spec.grid).ok()?;
            Some(Arc::new(Shading::new(
                &paint,
                spec.model,
                &spec.materials,
                &spec.paint_materials,
            )))
        })
        .ok()
}

/// Why two views whose gloss lobes have the exponents `first` and `second` are
/// rendered apart rather than shared, as the user reads it; `None` where the
/// second lobe is at most `narrowing` sharper ([`SHARED_LOBE_NARROWING`] as the
/// app runs) and no wider than the re-shade allows ([`LOBE_WIDENING_ALLOWED`]), or either
/// is a mirror (which the re-shade refuses with its own reason). Shared paths
/// sampled by one lobe and re-weighted into a much sharper one are noisy in the
/// highlights, which is all such designs differ in; rendered apart, both views
/// spend their samples there ([`super::guide`]): docs/benchmarks.md,
/// "Comparison".
pub(super) fn lobes_differ(
    first: Option<f32>,
    second: Option<f32>,
    narrowing: f32,
) -> Option<String> {
    let (Some(a), Some(b)) = (first, second) else {
        return None;
    };
    let excess = b / a - 1.0;
    (excess > narrowing || excess < -LOBE_WIDENING_ALLOWED).then(|| {
        format!(
            "the gloss lobes differ (exponent {a:.0} against {b:.0}): each view is traced \
             with its own, more samples where the map is undecided"
        )
    })
}

/// Why the second view cannot be re-shaded from the first view's paths, as the
/// user reads it.
pub(super) fn independent_reason(e: &ReshadeError) -> String {
    match e {
        ReshadeError::DeltaChanged => "an ideal-mirror paint cannot be re-shaded into the other \
             view (a mirror bounce has no lobe to re-weight)"
            .to_owned(),
        other => format!("the first view's paths cannot be re-shaded ({other})"),
    }
}
