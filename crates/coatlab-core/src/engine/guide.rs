//! Map-guided sampling: a comparison spends more of both views' samples on the
//! pixels where its ΔE00 map is still undecided.
//!
//! The map is there to show where the two views differ, not the noise of two
//! renders. Rendered apart, its error at a pixel after n samples in each view is
//! about σ = s / √n, with s = √(e_A² + e_B²) and e the per-sample perceptual
//! noise of either film ([`Film::sample_delta_e`]). Shared, the map is between
//! the two panes, whose difference is mostly the shared difference of the first
//! view's recorded paths; its error is what one standard error of that
//! difference's X, Y and Z moves the colour by
//! ([`crate::render::reshade::ShadingDifference::panes_difference_variance_xyz`]),
//! and s = σ √n with n the first view's samples (its recordings take every
//! sample of its passes, so a pixel's recorded samples grow with its weight,
//! [`crate::render::reshade::PathCache::recorded_per_pixel`]). A pixel whose
//! map reads d is decided once σ ≤ [`NOISE_TO_SIGNAL`] · max(d − σ, [`VISIBLE`]):
//! against the reading less one error, since a reading the noise has pushed up
//! must not lower its own bar. That holds from n* samples (`samples_to_decide`).
//! Per pixel:
//!
//! 1. its shortfall x = n* / n − 1, at least 0, where s is the largest of its
//!    3 × 3 neighbourhood: at a highlight's edge a few percent of the samples
//!    find the highlight, and a pixel that has not drawn one yet reads nearly
//!    noise-free beside neighbours that have; 0 unless the views differ there
//!    beyond their noise (below);
//! 2. the largest x of its 3 × 3 neighbourhood, as adaptive sampling does
//!    ([`crate::render::adaptive`]): a pixel's share then depends mostly on its
//!    neighbours' samples, which keeps its plain mean nearly unbiased, and the
//!    edge of a highlight gets the samples its middle asks for (with step 1,
//!    an undecided pixel's samples spread over its 5 × 5 neighbourhood);
//! 3. its extra, x clamped to [0, [`MOST_EXTRA`]] and to the largest level λ at
//!    which the extra averages no more than 1 / [`LEAST_SHARE`] − 1 over the
//!    image: the pixels nearest to being decided are served whole, the rest
//!    share what is left, and every pixel keeps at least [`LEAST_SHARE`] of an
//!    even share;
//! 4. weight 1 + extra, normalised to a mean of 1.
//!
//! A pixel asks only where the map of the views' 3 × 3 mean colours reads at
//! least [`UNDECIDED_FROM`] somewhere in its 3 × 3 neighbourhood, or where its own
//! reading less its error is at least [`VISIBLE`]. Averaging nine pixels divides
//! their noise by about three, while a difference that spans pixels (a highlight
//! moved, widened or dimmed) stays; a lone pixel that plainly differs asks by its
//! own reading. Without the first test, pixels that differ only by their noise
//! (floor, glass, most of a gloss variant's image) read above [`UNDECIDED_FROM`]
//! often enough to take over half of the samples, since `s` over-states the
//! noise of the sampler's stratified means most where a pixel is well behaved
//! ([`Film::variance_of_mean_xyz`]), and the few hundred pixels that do differ
//! were held to half their extra.
//!
//! Where the two views differ by colour the map is decided early everywhere
//! (its signal is large against its noise) and the weights soon stay even;
//! where they differ only in the highlights (a design against a glossier or
//! less glossy variant of itself), those pixels are sampled many times more
//! than the rest. What it buys and costs: docs/benchmarks.md, "Comparison".

use rayon::prelude::*;

use crate::render::adaptive::{neighbourhood_fold, neighbourhood_max};
use crate::render::film::{DisplaySettings, DisplayTransform, Film};

use super::delta_e::DeltaEMap;

/// Noise to signal at which a pixel of the map counts as decided: below it, a
/// reading of d is d ± 0.4 d at one standard error, so the noise stays below the
/// signal in all but about 1 % of such pixels (2.5 standard errors).
pub const NOISE_TO_SIGNAL: f64 = 0.4;
/// ΔE00 a designer reads as a visible difference: a pixel's map is decided once
/// its noise is below [`NOISE_TO_SIGNAL`] times its reading or times this,
/// whichever is larger (a reading below it needs no finer noise than this).
pub const VISIBLE: f64 = 1.0;
/// ΔE00 from which the map of the views' 3 × 3 means asks to be decided: half
/// the difference of 1 that a designer reads as visible, so that pixels whose
/// true difference is just above 1 but read lower are still sampled.
pub const UNDECIDED_FROM: f64 = 0.5;
/// The most samples a pixel asks for beyond an even share, as a multiple of it:
/// a few hundred undecided pixels then reach the samples of a render many times
/// longer without slowing the rest of the image much. At a gloss variant's
/// highlight fringe, where a percent of the samples find the highlight, the map
/// needs some 20–30 times the image's mean samples. With the budget spent (a
/// mean weight of 1 / [`LEAST_SHARE`] before normalising) a pixel takes at most
/// (1 + this) · [`LEAST_SHARE`] = 16 times the mean; measured against 15 and 31
/// with half an even share kept, and against 31 with a quarter
/// (docs/benchmarks.md, "Comparison").
pub const MOST_EXTRA: f64 = 63.0;
/// The weights are made again when the first view's samples per pixel have grown
/// by this factor: a pixel at a highlight's edge that has just drawn the
/// highlight is served soon after. Measured against adaptive sampling's ×1.5
/// (docs/benchmarks.md, "Comparison"): the map's noise on gloss variants' signal
/// pixels 0.62–0.70 against 0.67–0.78; ×1.1 left 10–20 % fewer samples (the
/// weights cost about a third of a sample per pixel each time) and decided no
/// more.
pub const REWEIGH_GROWTH: f64 = 1.2;
/// The least share of an even pass any pixel keeps, however many pixels are
/// undecided, so each pane still converges to its own image everywhere. A
/// quarter rather than a half: where two designs differ across the car (two
/// presets), tens of thousands of pixels are undecided at first, and the few
/// whose noise is rare long paths (the cabin through the glass) were left at
/// about an even share; measured against a half and 0.7 (docs/benchmarks.md,
/// "Comparison": a run's misses halved, the panes' mean error 0.31 → 0.37).
pub const LEAST_SHARE: f64 = 0.25;

/// The weights (one per pixel, row major, mean 1) for the next passes of both
/// views rendered apart, `a` and `b`, their map seen with `display` (see the
/// module documentation). `None` while the films differ in size or a pixel has
/// fewer than two samples in either (no noise estimate yet). Pixels in
/// parallel where it costs (the map, the noise); the result does not depend on
/// the thread count.
pub fn map_guided_weights(a: &Film, b: &Film, display: &DisplaySettings) -> Option<Vec<f32>> {
    let map = DeltaEMap::between(a, b, display)?;
    let (noise_a, noise_b) = (a.sample_delta_e(display), b.sample_delta_e(display));
    // A pixel of fewer than two samples in either film has no noise estimate yet
    // (`sample_delta_e` reads infinite there), so past this every n is at least 2.
    if map
        .values
        .iter()
        .chain(&noise_a)
        .chain(&noise_b)
        .any(|v| !v.is_finite())
    {
        return None;
    }
    let noise: Vec<f32> = noise_a
        .iter()
        .zip(&noise_b)
        .map(|(&e_a, &e_b)| e_a.hypot(e_b))
        .collect();
    let width = a.width();
    let samples: Vec<f64> = (0..map.values.len())
        .map(|i| {
            let (x, y) = (i as u32 % width, i as u32 / width);
            a.sample_count(x, y).min(b.sample_count(x, y)) as f64
        })
        .collect();
    let coarse = DeltaEMap::between_xyz(
        a.width(),
        a.height(),
        &neighbourhood_means(&film_means(a), a.width(), a.height()),
        &neighbourhood_means(&film_means(b), b.width(), b.height()),
        display,
    )?;
    Some(weights_from(
        &map.values,
        &noise,
        &samples,
        &coarse.values,
        (a.width(), a.height()),
    ))
}

/// [`map_guided_weights`] for a shared comparison: its panes `first` and
/// `second` (each a mean XYZ per pixel), the variances of the second's X, Y
/// and Z less the first's per pixel (`difference_variance`, what
/// [`crate::render::reshade::ShadingDifference::panes_difference_variance_xyz`]
/// gives) and the first view's film, whose samples per pixel the panes' noise
/// falls with (its recordings take the same share of the weights as its
/// passes). The map's error at a pixel is the ΔE00 that one standard error of
/// each of X, Y and Z moves the second pane's colour by, as a film's
/// per-sample noise is taken ([`Film::sample_delta_e`]): in a dark pixel of a
/// saturated colour the map's noise is mostly one of chroma, which an error of
/// Y alone along the colour's own chromaticity would not show. `None` while a
/// pixel has fewer than two samples or the sizes differ.
pub fn shared_map_guided_weights(
    first: &[[f32; 3]],
    second: &[[f32; 3]],
    difference_variance: &[[f32; 3]],
    film: &Film,
    display: &DisplaySettings,
) -> Option<Vec<f32>> {
    let (width, height) = (film.width(), film.height());
    let pixels = width as usize * height as usize;
    if difference_variance.len() != pixels {
        return None;
    }
    let map = DeltaEMap::between_xyz(width, height, first, second, display)?;
    let transform = DisplayTransform::of(display);
    let samples: Vec<f64> = (0..pixels)
        .map(|i| film.sample_count(i as u32 % width, i as u32 / width) as f64)
        .collect();
    if samples.iter().any(|&n| n < 2.0) {
        return None;
    }
    let noise: Vec<f32> = second
        .par_iter()
        .zip(difference_variance.par_iter())
        .zip(samples.par_iter())
        .map(|((&colour, &variance), &n)| {
            transform.sample_noise(colour.map(f64::from), variance.map(f64::from), n)
        })
        .collect();
    let widen = |v: &[[f32; 3]]| {
        let means: Vec<[f64; 3]> = v.iter().map(|c| c.map(f64::from)).collect();
        neighbourhood_means(&means, width, height)
    };
    let coarse = DeltaEMap::between_xyz(width, height, &widen(first), &widen(second), display)?;
    Some(weights_from(
        &map.values,
        &noise,
        &samples,
        &coarse.values,
        (width, height),
    ))
}

/// The weights from a map's readings `map`, its per-sample noise `noise` (s)
/// and samples `samples` (n), and the map of 3 × 3 means `coarse`, all per
/// pixel of an image of `size` (see the module documentation).
fn weights_from(
    map: &[f32],
    noise: &[f32],
    samples: &[f64],
    coarse: &[f32],
    size: (u32, u32),
) -> Vec<f32> {
    let (width, height) = (size.0 as usize, size.1 as usize);
    let noise_near = neighbourhood_max(noise, width, height);
    let coarse_near = neighbourhood_max(coarse, width, height);
    let shortfall: Vec<f32> = map
        .iter()
        .zip(noise_near.iter().zip(&coarse_near))
        .zip(samples)
        .map(|((&d, (&s, &coarse_d)), &n)| {
            let sigma = f64::from(s) / n.sqrt();
            if f64::from(coarse_d) < UNDECIDED_FROM && f64::from(d) - sigma < VISIBLE {
                0.0
            } else {
                let decided_at = samples_to_decide(f64::from(s), f64::from(d));
                (decided_at / n - 1.0).max(0.0) as f32
            }
        })
        .collect();
    let widened: Vec<f64> = neighbourhood_max(&shortfall, width, height)
        .into_iter()
        .map(f64::from)
        .collect();
    let budget = 1.0 / LEAST_SHARE - 1.0;
    let extra = nearest_first(&widened, budget);
    let mean = 1.0 + extra.iter().sum::<f64>() / extra.len().max(1) as f64;
    extra.iter().map(|&x| ((1.0 + x) / mean) as f32).collect()
}

/// Each pixel's mean XYZ, row major.
fn film_means(film: &Film) -> Vec<[f64; 3]> {
    (0..film.height())
        .flat_map(|y| (0..film.width()).map(move |x| (x, y)))
        .map(|(x, y)| {
            let m = film.mean_xyz(x, y);
            [m.x, m.y, m.z]
        })
        .collect()
}

/// Each of `means` (row major, `width` × `height`) averaged over its 3 × 3
/// neighbourhood (the pixels of it inside the image).
fn neighbourhood_means(means: &[[f64; 3]], width: u32, height: u32) -> Vec<[f32; 3]> {
    neighbourhood_fold(
        means,
        width as usize,
        height as usize,
        ([0.0f64; 3], 0u32),
        |(sum, count), m| (std::array::from_fn(|k| sum[k] + m[k]), count + 1),
    )
    .into_iter()
    .map(|(sum, count)| sum.map(|v| (v / f64::from(count)) as f32))
    .collect()
}

/// Samples a pixel's map needs before it is decided, with per-sample noise
/// `noise` (s) and the map reading `reading` (d): the least n at which σ = s / √n
/// ≤ [`NOISE_TO_SIGNAL`] · max(d − σ, [`VISIBLE`]). That holds when σ is within
/// either bound, [`NOISE_TO_SIGNAL`] · [`VISIBLE`] or [`NOISE_TO_SIGNAL`] · d /
/// (1 + [`NOISE_TO_SIGNAL`]), so n* is the smaller of the two counts.
fn samples_to_decide(noise: f64, reading: f64) -> f64 {
    let to_visible = (noise / (NOISE_TO_SIGNAL * VISIBLE)).powi(2);
    let to_reading = ((1.0 + NOISE_TO_SIGNAL) * noise / (NOISE_TO_SIGNAL * reading)).powi(2);
    to_visible.min(to_reading)
}

/// Each pixel's extra: its shortfall, at most [`MOST_EXTRA`] and at most a
/// level λ, the largest at which the extras average no more than `budget`
/// (none where the budget covers every shortfall). The pixels nearest to being
/// decided get all they ask; the rest share what is left, each as much. Not the
/// most undecided first: where the views differ across the car in a wide
/// picture, tens of thousands of pixels are short and the most short are the
/// floor's, which light the car throws onto the floor leaves undecided however
/// many samples they get; served first, they take the samples that would
/// decide the rest (docs/benchmarks.md, "Comparison"). By bisection (the mean
/// rises with λ), in a fixed order.
fn nearest_first(shortfall: &[f64], budget: f64) -> Vec<f64> {
    let mut capped: Vec<f64> = shortfall
        .iter()
        .map(|&x| x.clamp(0.0, MOST_EXTRA))
        .collect();
    let mean_below =
        |level: f64| capped.iter().map(|&x| x.min(level)).sum::<f64>() / capped.len().max(1) as f64;
    if mean_below(MOST_EXTRA) <= budget {
        return capped;
    }
    let (mut low, mut high) = (0.0, MOST_EXTRA);
    for _ in 0..64 {
        let mid = 0.5 * (low + high);
        if mean_below(mid) > budget {
            high = mid;
        } else {
            low = mid;
        }
    }
    for x in &mut capped {
        *x = x.min(low);
    }
    capped
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::spectrum::Channels;

    const SIZE: u32 = 9;

    /// A 9 × 9 linear-sRGB film of `samples` samples per pixel, each pixel's
    /// samples from `value(x, y, k)`.
    fn film(samples: u32, value: impl Fn(u32, u32, u32) -> [f32; 3]) -> Film {
        let mut film = Film::new(SIZE, SIZE, Channels::LinearSrgb);
        for y in 0..SIZE {
            for x in 0..SIZE {
                for k in 0..samples {
                    film.add_sample(x, y, &value(x, y, k));
                }
            }
        }
        film
    }

    fn grey(_: u32, _: u32, _: u32) -> [f32; 3] {
        [0.2; 3]
    }

    /// A noisy highlight at (`cx`, `cy`): samples alternate around `level`.
    fn highlight(cx: u32, cy: u32, level: f32) -> impl Fn(u32, u32, u32) -> [f32; 3] {
        move |x, y, k| {
            if (x, y) == (cx, cy) {
                [level * if k.is_multiple_of(2) { 0.2 } else { 1.8 }; 3]
            } else {
                grey(x, y, k)
            }
        }
    }

    fn display() -> DisplaySettings {
        DisplaySettings::MEASURED
    }

    fn assert_mean_one(weights: &[f32]) {
        let mean = weights.iter().map(|&w| f64::from(w)).sum::<f64>() / weights.len() as f64;
        assert!((mean - 1.0).abs() < 1e-6, "mean weight {mean}");
    }

    #[test]
    fn views_that_agree_or_differ_plainly_are_sampled_evenly() {
        let a = film(8, grey);
        let same = map_guided_weights(&a, &film(8, grey), &display()).expect("weights");
        assert!(same.iter().all(|&w| w == 1.0), "{same:?}");
        // A clearly different colour, noise-free: decided everywhere.
        let red = film(8, |_, _, _| [0.4, 0.05, 0.05]);
        let plain = map_guided_weights(&a, &red, &display()).expect("weights");
        assert!(plain.iter().all(|&w| w == 1.0), "{plain:?}");
    }

    #[test]
    fn an_undecided_highlight_and_its_neighbours_get_the_extra_samples() {
        // Both views see a noisy highlight at the centre, the second brighter.
        let a = film(8, highlight(4, 4, 1.0));
        let b = film(8, highlight(4, 4, 1.5));
        let weights = map_guided_weights(&a, &b, &display()).expect("weights");
        assert_mean_one(&weights);
        let at = |x: u32, y: u32| weights[(y * SIZE + x) as usize];
        let centre = at(4, 4);
        let even = at(0, 0);
        assert!(centre > 2.0 * even, "centre {centre}, elsewhere {even}");
        // Its neighbours, whose own samples are noise-free, take the centre's
        // noise as theirs and ask as it does; their neighbours share in that.
        for y in 0..SIZE {
            for x in 0..SIZE {
                let near = x.abs_diff(4) <= 2 && y.abs_diff(4) <= 2;
                let expected = if near { centre } else { even };
                assert_eq!(at(x, y), expected, "pixel ({x}, {y})");
            }
        }
        // The same highlight with many more samples is decided: even again.
        let a = film(4096, highlight(4, 4, 1.0));
        let b = film(4096, highlight(4, 4, 1.5));
        let weights = map_guided_weights(&a, &b, &display()).expect("weights");
        assert!(weights.iter().all(|&w| w == 1.0), "{weights:?}");
    }

    #[test]
    fn a_pixel_that_differs_only_by_its_noise_does_not_ask() {
        // Both views the same noisy grey (each sample half or one and a half
        // times the mean); in the second, the pixels within `reach` of the
        // centre read a tenth brighter.
        let noisy = |drift: f32, reach: u32| {
            move |x: u32, y: u32, k: u32| {
                let near = x.abs_diff(4) <= reach && y.abs_diff(4) <= reach;
                let level = if near { 0.2 * drift } else { 0.2 };
                [level
                    * if (k + x + y).is_multiple_of(2) {
                        0.5
                    } else {
                        1.5
                    }; 3]
            }
        };
        // At the centre alone: about what eight such samples' noise moves a
        // mean by, so the map reads a visible difference there, but the views'
        // 3 × 3 means barely differ and its own reading is within its error.
        let (a, b) = (film(8, noisy(1.0, 0)), film(8, noisy(1.1, 0)));
        let map = DeltaEMap::between(&a, &b, &display()).expect("map");
        let centre = map.values[(4 * SIZE + 4) as usize];
        assert!(f64::from(centre) > VISIBLE, "the centre reads {centre}");
        let weights = map_guided_weights(&a, &b, &display()).expect("weights");
        assert!(weights.iter().all(|&w| w == 1.0), "{weights:?}");
        // The same over the centre's 3 × 3 is a difference of the views: its
        // pixels read it plainly enough, and the pixels around them, which read
        // none, ask until their noise could not hide one.
        let (a, b) = (film(8, noisy(1.0, 1)), film(8, noisy(1.1, 1)));
        let weights = map_guided_weights(&a, &b, &display()).expect("weights");
        let (beside, corner) = (weights[(4 * SIZE + 2) as usize], weights[0]);
        assert!(beside > 2.0 * corner, "beside {beside}, corner {corner}");
    }

    #[test]
    fn every_pixel_keeps_its_least_share_however_many_are_undecided() {
        // Every pixel a noisy highlight that differs between the views, except
        // the first three rows.
        let noisy = |level: f32| {
            move |x: u32, y: u32, k: u32| {
                if y <= 2 {
                    grey(x, y, k)
                } else {
                    [level
                        * if (k + x + y).is_multiple_of(2) {
                            0.05
                        } else {
                            1.95
                        }; 3]
                }
            }
        };
        let weights = map_guided_weights(&film(4, noisy(0.3)), &film(4, noisy(0.33)), &display())
            .expect("weights");
        assert_mean_one(&weights);
        // Six rows are undecided and two more ask through their neighbours
        // (the third row takes the fourth's noise, the second shares the
        // third's shortfall): more than the budget serves, so they share it
        // and the first row, asking nothing, keeps exactly its least share.
        let asking = weights.iter().filter(|&&w| w > weights[0]).count();
        assert!(asking >= 2 * SIZE as usize, "{asking} pixels ask");
        assert!(
            (f64::from(weights[0]) - LEAST_SHARE).abs() < 1e-6,
            "the first row's weight {}",
            weights[0]
        );
        let least = weights.iter().copied().fold(f32::INFINITY, f32::min);
        assert!(
            f64::from(least) >= LEAST_SHARE - 1e-6,
            "least weight {least}"
        );
        let most = weights.iter().copied().fold(0.0f32, f32::max);
        assert!(f64::from(most) <= 1.0 + MOST_EXTRA, "most weight {most}");
    }

    #[test]
    fn a_reading_is_decided_against_itself_less_its_error() {
        let s = 2.0;
        // Readings up to 1 + NOISE_TO_SIGNAL are held to the visible difference.
        let to_visible = (s / (NOISE_TO_SIGNAL * VISIBLE)).powi(2);
        for d in [0.0, 0.5, 1.0, 1.4] {
            assert!(
                (samples_to_decide(s, d) - to_visible).abs() < 1e-9,
                "reading {d}"
            );
        }
        // Above, at the count it gives, the error is NOISE_TO_SIGNAL times the
        // reading less that error, exactly.
        for d in [1.5, 2.0, 5.0, 30.0] {
            let sigma = s / samples_to_decide(s, d).sqrt();
            let bound = NOISE_TO_SIGNAL * (d - sigma).max(VISIBLE);
            assert!(
                (sigma - bound).abs() < 1e-9,
                "reading {d}: error {sigma}, bound {bound}"
            );
            // More samples than the reading alone would ask for: it may be
            // high only because of the noise.
            let by_reading = (s / (NOISE_TO_SIGNAL * d)).powi(2);
            assert!(samples_to_decide(s, d) > 1.9 * by_reading, "reading {d}");
        }
    }

    #[test]
    fn the_pixels_nearest_to_being_decided_are_served_first() {
        // Ten pixels and a budget of 35 extra samples in all: the one 5 short
        // gets its 5, the two more short share the other 30 (15 each: the one
        // MOST_EXTRA + 25 short no more than the one 20 short).
        let mut shortfall = [0.0; 10];
        shortfall[..3].copy_from_slice(&[MOST_EXTRA + 25.0, 20.0, 5.0]);
        let extra = nearest_first(&shortfall, 35.0 / 10.0);
        for (got, want) in extra[..3].iter().zip([15.0, 15.0, 5.0]) {
            assert!((got - want).abs() < 1e-9, "{extra:?}");
        }
        assert!(extra[3..].iter().all(|&x| x == 0.0));
        // A budget that covers every shortfall: each its own, at most MOST_EXTRA.
        let extra = nearest_first(&shortfall, 10.0 * MOST_EXTRA);
        assert_eq!(extra[..3], [MOST_EXTRA, 20.0, 5.0]);
    }

    /// Shared panes that differ by a little over 2 ΔE00 on the 3 × 3 pixels
    /// around the centre, and agree precisely elsewhere: where the variance of
    /// their difference makes that reading uncertain, those pixels and their
    /// neighbours ask for more samples, also where only X and Z are uncertain
    /// (a difference whose noise is one of chroma); where it is precise, the
    /// weights stay even.
    #[test]
    fn shared_panes_ask_where_their_difference_is_uncertain() {
        let pixels = (SIZE * SIZE) as usize;
        let centre = |i: usize| {
            let (x, y) = (i as u32 % SIZE, i as u32 / SIZE);
            x.abs_diff(SIZE / 2) <= 1 && y.abs_diff(SIZE / 2) <= 1
        };
        let first = vec![[0.19f32, 0.2, 0.22]; pixels];
        let second: Vec<[f32; 3]> = (0..pixels)
            .map(|i| {
                if centre(i) {
                    [0.217, 0.228, 0.251]
                } else {
                    first[i]
                }
            })
            .collect();
        let map = DeltaEMap::between_xyz(SIZE, SIZE, &first, &second, &display()).expect("map");
        println!("the centre reads {:.2}", map.values[pixels / 2]);
        assert!((2.0..3.0).contains(&map.values[pixels / 2]));
        let films = film(8, grey);
        let weights_with = |standard_error: [f32; 3]| {
            let variance: Vec<[f32; 3]> = (0..pixels)
                .map(|i| {
                    if centre(i) {
                        standard_error.map(|e| e * e)
                    } else {
                        [0.0; 3]
                    }
                })
                .collect();
            shared_map_guided_weights(&first, &second, &variance, &films, &display())
                .expect("weights")
        };
        for (what, standard_error) in [
            ("X, Y and Z", [0.03; 3]),
            ("X and Z only", [0.03, 0.0, 0.03]),
        ] {
            let uncertain = weights_with(standard_error);
            assert_mean_one(&uncertain);
            // The block's noise spreads to its neighbours (the largest noise of
            // a 3 × 3 neighbourhood) and their shortfall twice more: everything
            // within three pixels of the centre may ask, the corners do not.
            let most = uncertain.iter().copied().fold(0.0f32, f32::max);
            let least = uncertain.iter().copied().fold(f32::INFINITY, f32::min);
            let corner = uncertain[0];
            println!("{what} uncertain: {least:.2} to {most:.2}, corner {corner:.2}");
            assert_eq!(corner, least, "{what}");
            assert!(most > 2.0 * corner, "{what}: most {most}, corner {corner}");
        }
        let precise = weights_with([1e-5; 3]);
        assert!(
            precise.iter().all(|&w| (w - 1.0).abs() < 1e-6),
            "{precise:?}"
        );
        // A variance of another size: no weights.
        assert!(
            shared_map_guided_weights(&first, &second, &[[0.0; 3]], &films, &display()).is_none()
        );
    }

    #[test]
    fn no_weights_without_a_noise_estimate_or_for_films_of_two_sizes() {
        assert_eq!(
            map_guided_weights(&film(1, grey), &film(1, grey), &display()),
            None
        );
        let other = Film::new(SIZE + 1, SIZE, Channels::LinearSrgb);
        assert_eq!(map_guided_weights(&film(8, grey), &other, &display()), None);
    }
}
