//! `coatlab delta-e`: CIEDE2000 of colour pairs, CSV in, CSV out.
//!
//! Input columns `L1,a1,b1,L2,a2,b2` may come in any order; other columns pass
//! through unchanged, and `dE00` is appended to each row. Each value must lie
//! within ±[`MAX_COMPONENT`].

use std::io::{Read, Write};

use coatlab_core::colour::{Lab, ciede2000};

use super::table::map_numeric_rows;

const INPUT_COLUMNS: [&str; 6] = ["L1", "a1", "b1", "L2", "a2", "b2"];
const OUTPUT_COLUMN: &str = "dE00";
/// The largest |L*|, |a*|, |b*| taken. Colours have components of a few hundred
/// at most, so anything near this is a unit or column mistake; and CIEDE2000's
/// seventh powers of chroma overflow f64 from |C| ≈ 10⁴⁴ on, giving NaN.
pub const MAX_COMPONENT: f64 = 1e6;

pub fn run(input: impl Read, out: &mut impl Write) -> anyhow::Result<()> {
    map_numeric_rows(
        input,
        out,
        INPUT_COLUMNS,
        &[OUTPUT_COLUMN],
        |_, value| {
            if value.abs() > MAX_COMPONENT {
                Err(format!(
                    "{value} is beyond ±{MAX_COMPONENT:e}, far outside any colour"
                ))
            } else {
                Ok(())
            }
        },
        |[l1, a1, b1, l2, a2, b2]| vec![ciede2000(Lab::new(l1, a1, b1), Lab::new(l2, a2, b2))],
    )
}
