//! `coatlab brdf`: the body BRDF and the directional albedo of grey parameters, CSV
//! in, CSV out.
//!
//! | column | unit, range | meaning |
//! | --- | --- | --- |
//! | `n` | [`REFRACTIVE_INDEX`] | refractive index of the clear coat |
//! | `rho` | [`ALBEDO`] | diffuse albedo ρ of the pigment layer |
//! | `kh` | [`OPTICAL_DEPTH`] | optical depth τ = k·h of the coat |
//! | `theta_i_deg` | degrees, [`POLAR_ANGLE_DEG`] | polar angle of incidence (90 = grazing) |
//! | `theta_o_deg` | degrees, [`POLAR_ANGLE_DEG`] | polar angle of the outgoing direction |
//! | `dphi_deg` | degrees, finite | φo − φi (180 = plane of incidence, mirror side) |
//!
//! The first three are the paint model's parameters: their ranges, and the
//! messages refusing a value outside them, come from its parameter table.
//!
//! The columns may come in any order; other columns pass through unchanged, in their
//! input position. Two columns are appended to each row:
//!
//! - `f_body`, 1/sr: the body term of spec 4.1 (without the cosine factor). It does
//!   not depend on `dphi_deg`, which is only validated.
//! - `albedo`: the directional albedo at θi of the whole model with the ideal mirror
//!   as its specular part, R(μi) + ∫ f_body cos θo dωo. It is 1 for ρ = 1, τ = 0
//!   (white furnace) and at grazing incidence for n > 1.
//!
//! The coat integrals C(n, τ) and E(n, τ) cost microseconds each, so they are
//! computed once per distinct (n, kh) pair; a sweep over angles costs almost nothing
//! per row.

use std::collections::HashMap;
use std::io::{Read, Write};

use coatlab_core::paint::coat::{CoatIntegrals, body_brdf};
use coatlab_core::paint::fresnel::reflectance;
use coatlab_core::paint::parameters::{ALBEDO, Bounds, OPTICAL_DEPTH, REFRACTIVE_INDEX};

use super::table::map_numeric_rows;

const INPUT_COLUMNS: [&str; 6] = ["n", "rho", "kh", "theta_i_deg", "theta_o_deg", "dphi_deg"];
const OUTPUT_COLUMNS: [&str; 2] = ["f_body", "albedo"];
/// Polar angles of directions above the surface, degrees.
pub const POLAR_ANGLE_DEG: Bounds = Bounds::new(0.0, 90.0);

/// C and E per distinct (n, kh): a sweep over angles reuses them (each costs
/// microseconds), keyed on the bit patterns of the two numbers.
#[derive(Debug, Default)]
struct CoatCache(HashMap<(u64, u64), CoatIntegrals>);

impl CoatCache {
    fn get(&mut self, n: f64, tau: f64) -> CoatIntegrals {
        // `+ 0.0` folds −0 into +0 so they share an entry.
        let key = ((n + 0.0).to_bits(), (tau + 0.0).to_bits());
        *self
            .0
            .entry(key)
            .or_insert_with(|| CoatIntegrals::new(n, tau))
    }
}

/// cos θ for θ in degrees, exactly 0 at 90° (grazing) and 1 at 0°.
fn cos_deg(theta_deg: f64) -> f64 {
    (90.0 - theta_deg).to_radians().sin()
}

pub fn run(input: impl Read, out: &mut impl Write) -> anyhow::Result<()> {
    let mut cache = CoatCache::default();
    map_numeric_rows(
        input,
        out,
        INPUT_COLUMNS,
        &OUTPUT_COLUMNS,
        check,
        |values| {
            let [n, rho, tau, theta_i_deg, theta_o_deg, _dphi_deg] = values;
            let coat = cache.get(n, tau);
            let (cos_i, cos_o) = (cos_deg(theta_i_deg), cos_deg(theta_o_deg));
            let f_body = body_brdf::<f64>(rho, n, tau, coat.c, cos_i, cos_o);
            let albedo = reflectance(cos_i, n) + coat.body_albedo(rho, n, tau, cos_i);
            vec![f_body, albedo]
        },
    )
}

/// The range each input column must lie in; `value` is already finite.
fn check(column: &str, value: f64) -> Result<(), String> {
    let parameter = match column {
        "n" => &REFRACTIVE_INDEX,
        "rho" => &ALBEDO,
        "kh" => &OPTICAL_DEPTH,
        "theta_i_deg" | "theta_o_deg" => {
            return match POLAR_ANGLE_DEG.violation(value) {
                None => Ok(()),
                Some(violation) => Err(format!("{value} {violation} degrees")),
            };
        }
        _ => return Ok(()),
    };
    parameter.check(value).map_err(|error| error.to_string())
}
