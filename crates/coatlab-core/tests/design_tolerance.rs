//! The optional, versioned `[tolerance]` table of a design file: written and read
//! back to an equal design, absent when unset, refused with the field named when
//! bad or newer.

use coatlab_core::colour::tolerance::{Formula, Tolerance};
use coatlab_core::design::{PaintDesign, TOLERANCE_VERSION, presets, tolerance_spec};

fn red() -> PaintDesign {
    presets::by_slug("signal-red").expect("preset").design
}

#[test]
fn a_tolerance_round_trips_through_the_file_and_an_absent_one_stays_absent() {
    let plain = red();
    assert_eq!(plain.tolerance, None);
    let text = plain.to_toml_string();
    assert!(!text.contains("[tolerance]"));
    assert_eq!(
        PaintDesign::from_toml_str(&text, "plain").expect("read"),
        plain
    );

    for spec in [
        "de00:1",
        "cmc:1.5",
        "de00:0.8,15=1.5,110=2.25",
        "deab:2,-15=3",
    ] {
        let mut design = red();
        design.tolerance = Some(spec.parse().expect("a tolerance"));
        let text = design.to_toml_string();
        assert!(text.contains(&format!("[tolerance]\nversion = {TOLERANCE_VERSION}\n")));
        let back = PaintDesign::from_toml_str(&text, "t").expect("read back");
        assert_eq!(back, design, "{spec}");
        // And through a file, saved atomically.
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("t.toml");
        design.save(&path).expect("save");
        assert_eq!(PaintDesign::load(&path).expect("load"), design);
    }
    let t: Tolerance = "cmc:1.5,25=2".parse().expect("tolerance");
    assert_eq!(t.formula, Formula::Cmc);
    assert_eq!(tolerance_spec(&t), "cmc:1.5,25=2");
}

#[test]
fn a_bad_or_newer_tolerance_table_is_refused_by_field() {
    let text = red().to_toml_string();
    // The message refusing the preset with `table` appended.
    let refused = |table: &str| {
        PaintDesign::from_toml_str(&format!("{text}\n[tolerance]\n{table}"), "f.toml")
            .expect_err(table)
            .to_string()
    };
    let cases = [
        (
            "version = 2\nspec = \"1\"\n",
            "f.toml: tolerance.version = 2",
        ),
        ("version = 2\nspec = \"1\"\n", "newer Coatlab"),
        (
            "version = 1\nspec = \"de99:1\"\n",
            "tolerance.spec = \"de99:1\"",
        ),
        ("version = 1\nspec = \"de00:-1\"\n", "not a positive number"),
        ("version = 1\n", "spec"),
        ("version = 1\nspec = \"1\"\nlimit = 2\n", "limit"),
    ];
    for (table, said) in cases {
        let e = refused(table);
        assert!(e.contains(said), "{table}: {e}");
    }
    // A limit set in code that no file could hold is refused on save.
    let mut design = red();
    design.tolerance = Some(Tolerance {
        default_limit: f64::NAN,
        ..Tolerance::default()
    });
    let dir = tempfile::tempdir().expect("temp dir");
    let e = design
        .save(dir.path().join("x.toml"))
        .expect_err("NaN limit");
    assert!(e.to_string().contains("tolerance.spec"), "{e}");
}
