//! The images the live engine publishes: display pixels of each view with what
//! they show, and the ΔE00 map between the views.

use crate::render::film::{DisplayChoice, DisplaySettings, display_xyz};
use crate::render::progressive::PassStats;
use crate::render::reshade::Reshaded;

use super::backend::BackendView;
use super::delta_e::DeltaEMap;

/// One published image of a view.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// 8-bit sRGB, alpha 255, row-major from the top-left.
    pub pixels: Vec<[u8; 4]>,
    /// Samples per pixel the image holds.
    pub samples_per_pixel: u32,
    /// Pixel samples per second of the last pass.
    pub samples_per_second: f64,
    /// Mean ΔE00 of the noise left, when the film can estimate it.
    pub noise_delta_e: Option<f64>,
    /// The coarse first pass after a change.
    pub coarse: bool,
    /// A paint edit shown re-shaded from the previous design's samples: the share
    /// (0–1) the fresh samples of the new design already carry in the image.
    /// `None`: the image is the new design's own samples alone.
    pub reshaded: Option<f64>,
    /// The last command this image shows, as numbered by the sender
    /// ([`super::EngineThread`]); 0 from an engine driven directly.
    pub epoch: u64,
    /// The second view of a comparison: how it was made. `None` for the first.
    pub source: Option<SecondSource>,
}

/// How the second view of a comparison is made.
#[derive(Debug, Clone, PartialEq)]
pub enum SecondSource {
    /// Its own render combined with the first view's recorded paths (this many
    /// samples per pixel, over its successive recordings) re-shaded into it: the
    /// panes share those samples.
    Shared {
        /// Samples per pixel of the first view's paths the shared difference is
        /// made of.
        recorded_spp: u32,
        /// The weight (0–1) its own render carries in the pane.
        own_weight: f64,
    },
    /// Rendered on its own (same camera and seed), for the reason given.
    Independent {
        /// Why the first view's paths could not be re-shaded into it.
        reason: String,
    },
}

/// What a publication changes of the second view's image.
#[derive(Debug, Clone, PartialEq)]
pub enum SecondUpdate {
    /// Its last image stays (its new one is still being made).
    Keep,
    /// There is none.
    Clear,
    /// This one.
    Set(Frame),
}

/// One publication: the first view's image, the second's, and the ΔE00 map.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewsUpdate {
    /// The first view's image.
    pub first: Frame,
    /// The second view's.
    pub second: SecondUpdate,
    /// `Some(map)`: the map is replaced (by none for `Some(None)`); `None`: the
    /// last map stays.
    pub map: Option<Option<DeltaEMap>>,
}

impl ViewsUpdate {
    /// The frames of the update, to stamp or inspect.
    pub fn frames_mut(&mut self) -> impl Iterator<Item = &mut Frame> {
        let second = match &mut self.second {
            SecondUpdate::Set(frame) => Some(frame),
            _ => None,
        };
        std::iter::once(&mut self.first).chain(second)
    }
}

/// One display setting for both views, so neither hides nor invents a
/// difference: the viewer's choice, an automatic exposure taken from the first
/// view's film.
pub(super) fn display_of(first: &impl BackendView, choice: &DisplayChoice) -> DisplaySettings {
    choice.settings_for(first.film())
}

/// Whether the ΔE00 map is made after a pass: it costs about as much as a pass
/// at 640×400, so only at 1, 2, 4, 8, … samples per pixel (and the coarse pass
/// and the last), which keeps its share of the time small.
pub(super) fn map_due(coarse: bool, spp: u32, max_spp: u32) -> bool {
    coarse || spp.is_power_of_two() || spp >= max_spp
}

/// A view's film as shown with `display`.
pub(super) fn film_frame(
    view: &impl BackendView,
    stats: PassStats,
    display: &DisplaySettings,
    coarse: bool,
) -> Frame {
    frame_showing(
        view.film().to_display(display),
        view,
        stats,
        display,
        coarse,
    )
}

/// A view's frame showing `pixels` (its film as shown, or a pane made from it):
/// the view's size, samples, rate and noise with `display`.
fn frame_showing(
    pixels: Vec<[u8; 4]>,
    view: &impl BackendView,
    stats: PassStats,
    display: &DisplaySettings,
    coarse: bool,
) -> Frame {
    let film = view.film();
    Frame {
        width: film.width(),
        height: film.height(),
        pixels,
        samples_per_pixel: view.samples_per_pixel(),
        samples_per_second: stats.samples_per_second(),
        noise_delta_e: if coarse {
            None
        } else {
            view.noise_estimate(display).map(|n| n.mean_delta_e)
        },
        coarse,
        reshaded: None,
        epoch: 0,
        source: None,
    }
}

/// The first view while a paint edit is shown re-shaded: the blend of the
/// re-shaded and the fresh image, in `display` (the last image's exposure: the
/// fresh film is too young to set one, and a steady exposure lets the edit
/// show). `None` once the film alone is better.
pub(super) fn edit_update(
    first: &impl BackendView,
    stats: PassStats,
    display: &DisplaySettings,
) -> Option<ViewsUpdate> {
    let (image, fresh_weight) = first.edit_estimate()?;
    let frame = Frame {
        width: image.width,
        height: image.height,
        pixels: display_xyz(&image.xyz, display),
        samples_per_pixel: first.samples_per_pixel(),
        samples_per_second: stats.samples_per_second(),
        noise_delta_e: None,
        coarse: false,
        reshaded: Some(fresh_weight),
        epoch: 0,
        source: None,
    };
    Some(ViewsUpdate {
        first: frame,
        second: SecondUpdate::Clear,
        map: Some(None),
    })
}

/// Both views of a shared comparison: each pane its own film combined with
/// the other view's film and the difference of the first view's recorded paths
/// re-shaded (with its own film's weight); the map between the two when due.
pub(super) fn shared_update(
    [a, b]: [&impl BackendView; 2],
    [(pane_a, _), (pane_b, own_weight)]: &[(Reshaded, f64); 2],
    shared_spp: u32,
    [stats_a, stats_b]: [PassStats; 2],
    display: &DisplaySettings,
    (coarse, map_due): (bool, bool),
) -> ViewsUpdate {
    let first = frame_showing(
        display_xyz(&pane_a.xyz, display),
        a,
        stats_a,
        display,
        coarse,
    );
    let second = Frame {
        source: Some(SecondSource::Shared {
            recorded_spp: shared_spp,
            own_weight: *own_weight,
        }),
        ..frame_showing(
            display_xyz(&pane_b.xyz, display),
            b,
            stats_b,
            display,
            coarse,
        )
    };
    let map = map_due.then(|| {
        DeltaEMap::between_xyz(
            pane_a.width,
            pane_a.height,
            &pane_a.xyz,
            &pane_b.xyz,
            display,
        )
        .map(|m| DeltaEMap {
            samples_per_pixel: a.samples_per_pixel(),
            ..m
        })
    });
    ViewsUpdate {
        first,
        second: SecondUpdate::Set(second),
        map: map.flatten().map(Some),
    }
}

/// Both views rendered apart: the second's image and, when due, the map.
pub(super) fn pair_update(
    [a, b]: [&impl BackendView; 2],
    [stats_a, stats_b]: [PassStats; 2],
    reason: &str,
    display: &DisplaySettings,
    (coarse, map_due): (bool, bool),
) -> ViewsUpdate {
    let second = Frame {
        source: Some(SecondSource::Independent {
            reason: reason.to_owned(),
        }),
        ..film_frame(b, stats_b, display, coarse)
    };
    let map = map_due.then(|| {
        DeltaEMap::between(a.film(), b.film(), display).map(|m| DeltaEMap {
            samples_per_pixel: a.samples_per_pixel(),
            ..m
        })
    });
    // A map that cannot be made (no samples yet) leaves the last one.
    ViewsUpdate {
        first: film_frame(a, stats_a, display, coarse),
        second: SecondUpdate::Set(second),
        map: map.flatten().map(Some),
    }
}
