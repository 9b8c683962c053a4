//! `coatlab delta-e`: CIEDE2000 of colour pairs, CSV in, CSV out.
//!
//! Input columns `L1,a1,b1,L2,a2,b2` may come in any order; other columns pass
//! through unchanged, and `dE00` is appended to each row.

use std::io::{Read, Write};

use coatlab_core::colour::{Lab, ciede2000};

use super::table::map_numeric_rows;

const INPUT_COLUMNS: [&str; 6] = ["L1", "a1", "b1", "L2", "a2", "b2"];
const OUTPUT_COLUMN: &str = "dE00";

pub fn run(input: impl Read, out: &mut impl Write) -> anyhow::Result<()> {
    map_numeric_rows(
        input,
        out,
        INPUT_COLUMNS,
        &[OUTPUT_COLUMN],
        |_, _| Ok(()),
        |[l1, a1, b1, l2, a2, b2]| vec![ciede2000(Lab::new(l1, a1, b1), Lab::new(l2, a2, b2))],
    )
}
