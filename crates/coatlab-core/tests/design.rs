//! Paint design files: the presets against their generator, round trips, every
//! refusal (with the field and value named), refusal exactly outside the parameter
//! table's ranges, grid sampling, atomic saves, and the physics behind the paint
//! panel's controls (Cauchy fit, gloss at another geometry, the gloss span).

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};

use coatlab_core::colour::spectrum::{TabulatedSpectrum, VISIBLE, WavelengthGrid};
use coatlab_core::design::{
    Absorption, DesignError, FORMAT_VERSION, Gloss, PaintDesign, RefractiveIndex, presets,
};
use coatlab_core::paint::gloss::{
    GLOSS_WAVELENGTH_NM, GlossExponent, GlossGeometry, reading_from_exponent, reading_range,
};
use coatlab_core::paint::lobe::LobeKind;
use coatlab_core::paint::parameters::{
    ABSORPTION, ALBEDO, Bounds, CAUCHY_B, GLOSS, Parameter, REFRACTIVE_INDEX, THICKNESS,
};

fn presets_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/presets")
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/designs")
        .join(name)
}

/// A fresh, empty directory for one test (no tempfile dependency; cargo provides a
/// scratch directory for integration tests).
fn scratch_dir(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("design-tests")
        .join(format!("{test}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn files_in(dir: &Path) -> BTreeSet<String> {
    fs::read_dir(dir)
        .unwrap()
        .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
        .collect()
}

/// A valid design to mutate: the red preset.
fn base() -> PaintDesign {
    presets::by_slug("signal-red").unwrap().design
}

fn base_text() -> String {
    base().to_toml_string()
}

/// Parses `text` as "test.toml", expecting a refusal; returns the message after
/// checking it names the file.
fn refusal(text: &str) -> String {
    let message = match PaintDesign::from_toml_str(text, "test.toml") {
        Ok(_) => panic!("accepted an invalid design:\n{text}"),
        Err(error) => error.to_string(),
    };
    assert!(
        message.starts_with("test.toml: "),
        "message does not name the file: {message}"
    );
    message
}

/// Serialises `design` (whatever its values) and expects the reader to refuse it.
fn refusal_of(design: &PaintDesign) -> String {
    assert!(design.validate().is_err(), "validate() accepted it");
    refusal(&design.to_toml_string())
}

fn assert_names(message: &str, parts: &[&str]) {
    for part in parts {
        assert!(message.contains(part), "message lacks {part:?}:\n{message}");
    }
}

/// `text` with `from` (found once) replaced by `to` must be refused with a message
/// naming every one of `parts`.
fn assert_edit_refused(text: &str, from: &str, to: &str, parts: &[&str]) {
    assert_names(&refusal(&replace_once(text, from, to)), parts);
}

fn replace_once(text: &str, from: &str, to: &str) -> String {
    assert_eq!(text.matches(from).count(), 1, "{from:?} is not unique");
    text.replacen(from, to, 1)
}

fn with_albedo_value(design: &PaintDesign, index: usize, value: f64) -> PaintDesign {
    let mut values = design.albedo.values().to_vec();
    values[index] = value;
    let mut design = design.clone();
    design.albedo =
        TabulatedSpectrum::new(design.albedo.wavelengths_nm().to_vec(), values).unwrap();
    design
}

// ---------------------------------------------------------------------------------
// Presets

#[test]
fn committed_presets_equal_the_generator_output() {
    for preset in presets::all() {
        let path = presets_dir().join(format!("{}.toml", preset.slug));
        let loaded = PaintDesign::load(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            loaded,
            preset.design,
            "{} differs from the generator",
            path.display()
        );
        let text = fs::read_to_string(&path).unwrap();
        assert_eq!(
            text,
            preset.design.to_toml_string(),
            "{} is not the generator's text; rerun `cargo run -p coatlab-core --example make_presets`",
            path.display()
        );
    }
}

#[test]
fn preset_directory_holds_exactly_the_presets() {
    let expected: BTreeSet<String> = presets::all()
        .iter()
        .map(|p| format!("{}.toml", p.slug))
        .collect();
    let found: BTreeSet<String> = files_in(&presets_dir())
        .into_iter()
        .filter(|name| name.ends_with(".toml"))
        .collect();
    assert_eq!(found, expected);
}

#[test]
fn presets_are_valid_plausible_and_cover_both_lobes() {
    let all = presets::all();
    assert!(all.len() >= 6);
    let reference = WavelengthGrid::reference();
    for preset in &all {
        let design = &preset.design;
        design.validate().unwrap();
        let name = preset.slug;
        assert!(
            design
                .description
                .as_deref()
                .unwrap()
                .contains("not measured data")
        );
        // ρ on the 5 nm reference grid, exactly.
        assert_eq!(design.albedo.wavelengths_nm().len(), 81, "{name}");
        assert_eq!(
            design.albedo_on(&reference).values(),
            design.albedo.values()
        );
        // The clear coat of the brief: h 35–55 µm, τ = k·h small in the visible, a UV
        // absorber below 400 nm.
        assert!((35.0..=55.0).contains(&design.thickness_um), "{name}");
        let tau = |nm: f64| design.absorption_per_um.at_nm(nm) * design.thickness_um;
        assert!(tau(550.0) < 0.02 && tau(420.0) < 0.05, "{name}");
        assert!(tau(380.0) > 1.0, "{name}: no UV absorber");
        let n = design.refractive_index_at_nm(GLOSS_WAVELENGTH_NM);
        assert!((1.48..=1.55).contains(&n), "{name}: n = {n}");
        match design.exponent().unwrap() {
            GlossExponent::Finite(m) => assert!(m.is_finite() && m > 0.0, "{name}: m = {m}"),
            GlossExponent::Mirror => panic!("{name}: gloss at or above the mirror reading"),
        }
    }
    assert!(all.iter().any(|p| p.design.lobe == LobeKind::Paper));
    assert!(all.iter().any(|p| p.design.lobe == LobeKind::Normalised));
    assert!(
        all.iter()
            .any(|p| p.design.gloss.geometry != GlossGeometry::Deg20)
    );
    for slug in [
        "signal-red",
        "pure-white",
        "jet-black",
        "deep-blue",
        "sunflower-yellow",
        "mid-grey",
    ] {
        assert!(all.iter().any(|p| p.slug == slug), "no {slug}");
    }
}

#[test]
fn preset_spectra_have_their_pigment_shapes() {
    let all = presets::all();
    let rho = |slug: &str, nm: f64| {
        all.iter()
            .find(|p| p.slug == slug)
            .unwrap()
            .design
            .albedo
            .value_at_nm(nm)
    };
    // TiO2: dark below its edge near 400 nm, high and flat beyond.
    assert!(rho("pure-white", 380.0) < 0.2 && rho("pure-white", 450.0) > 0.85);
    // Carbon black: flat 0.03–0.05.
    for nm in [380.0, 550.0, 780.0] {
        assert!((0.03..=0.05).contains(&rho("jet-black", nm)));
    }
    // Phthalocyanine blue: peak near 450, low in the red, rising beyond 700.
    assert!(rho("deep-blue", 450.0) > 3.0 * rho("deep-blue", 600.0));
    assert!(rho("deep-blue", 780.0) > 3.0 * rho("deep-blue", 680.0));
    // Organic red: steep rise near 600 nm.
    assert!(rho("signal-red", 560.0) < 0.1 && rho("signal-red", 640.0) > 0.7);
    // Yellow: edge near 500 nm.
    assert!(rho("sunflower-yellow", 460.0) < 0.15 && rho("sunflower-yellow", 550.0) > 0.8);
    // Greys: ρ(550) as mixed, and nearly neutral across 450–700 nm.
    assert!((rho("mid-grey", 550.0) - 0.20).abs() < 1e-3);
    assert!((rho("silver-grey", 550.0) - 0.45).abs() < 1e-3);
    for nm in [450.0, 500.0, 600.0, 700.0] {
        assert!((rho("mid-grey", nm) / rho("mid-grey", 550.0) - 1.0).abs() < 0.1);
    }
}

// ---------------------------------------------------------------------------------
// Round trips and reading

#[test]
fn save_then_load_gives_an_equal_design() {
    let dir = scratch_dir("round-trip");
    for preset in presets::all() {
        let path = dir.join(format!("{}.toml", preset.slug));
        preset.design.save(&path).unwrap();
        assert_eq!(PaintDesign::load(&path).unwrap(), preset.design);
    }
    // The other variants, awkward numbers and a name that needs escaping.
    let mut design = base();
    design.name = "Quote \" backslash \\ tab\t newline\n ünïcode".to_owned();
    design.description = None;
    design.refractive_index = RefractiveIndex::Table(
        TabulatedSpectrum::new(vec![380.0, 587.6, 780.0], vec![1.53, 1.1 / 3.0 + 1.15, 1.5])
            .unwrap(),
    );
    design.absorption_per_um = Absorption::Constant(1.0 / 3.0 * 1e-3);
    design.thickness_um = 0.0;
    design.gloss = Gloss {
        gu: 100.0 / 3.0,
        geometry: GlossGeometry::Deg85,
    };
    let path = dir.join("variants.toml");
    design.save(&path).unwrap();
    assert_eq!(PaintDesign::load(&path).unwrap(), design);
    assert_eq!(
        files_in(&dir).len(),
        presets::all().len() + 1,
        "temporary files left behind"
    );
}

#[test]
fn hand_written_file_reads_with_inline_tables_and_integers() {
    let design = PaintDesign::load(fixture("hand-written.toml")).unwrap();
    assert_eq!(design.name, "Hand-written \"test\" orange");
    assert_eq!(design.description, None);
    assert_eq!(design.thickness_um, 38.0);
    assert_eq!(design.gloss.gu, 80.0);
    assert_eq!(design.absorption_per_um, Absorption::Constant(0.0005));
    assert_eq!(design.refractive_index_at_nm(GLOSS_WAVELENGTH_NM), 1.512);
    assert!((design.albedo.value_at_nm(570.0) - 0.325).abs() < 1e-12);
    assert!(matches!(
        design.exponent().unwrap(),
        GlossExponent::Finite(_)
    ));
    // Written back in the house layout, it still reads the same.
    let again = PaintDesign::from_toml_str(&design.to_toml_string(), "again").unwrap();
    assert_eq!(again, design);
}

#[test]
fn grid_values_follow_the_resampling_rule() {
    let design = base();
    let reference = WavelengthGrid::reference();
    let n = design.refractive_index_on(&reference);
    for (i, nm) in reference.wavelengths_nm().enumerate() {
        // Bin means of a smooth n differ from point values by ~1e-6 on 5 nm bins.
        assert!((n.values()[i] - design.refractive_index_at_nm(nm)).abs() < 1e-5);
        assert_eq!(
            design.absorption_on(&reference).values()[i],
            design.absorption_per_um.at_nm(nm)
        );
    }
    // One 400 nm bin: the exact mean of a + b/λ² over 380–780 nm is a + b/(0.38·0.78).
    let one = WavelengthGrid::visible(1).unwrap();
    let RefractiveIndex::Cauchy { a, b_um2 } = design.refractive_index else {
        panic!("the red preset has a Cauchy index");
    };
    assert!(
        (design.refractive_index_on(&one).values()[0] - (a + b_um2 / (0.38 * 0.78))).abs() < 1e-12
    );
    // The UV edge is averaged into the first coarse bin, not missed.
    let coarse = WavelengthGrid::visible(8).unwrap();
    let k = design.absorption_on(&coarse);
    assert!(k.values()[0] > design.absorption_per_um.at_nm(405.0));
    assert_eq!(design.albedo_on(&coarse).grid(), &coarse);
}

// ---------------------------------------------------------------------------------
// Refusals: each message names the file, the field and the value.

#[test]
fn refuses_other_formats_and_versions() {
    let text = base_text();
    assert_edit_refused(
        &text,
        "format = \"coatlab-paint-design\"",
        "format = \"paint\"",
        &["format = \"paint\"", "coatlab-paint-design"],
    );
    assert_edit_refused(
        &text,
        "format = \"coatlab-paint-design\"\n",
        "",
        &["format"],
    );

    let newer = replace_once(&text, "version = 1\n", "version = 2\nnew_key = true\n");
    let message = refusal(&newer);
    assert_names(&message, &["version = 2", "newer Coatlab"]);
    let error = PaintDesign::from_toml_str(&newer, "x").unwrap_err();
    assert!(matches!(
        error.without_file(),
        DesignError::NewerVersion { found: 2 }
    ));
    assert_eq!(error.field(), Some("version"));

    for bad in ["version = 0", "version = \"1\"", "version = 1.0"] {
        assert_edit_refused(
            &text,
            "version = 1",
            bad,
            &[bad, &format!("version {FORMAT_VERSION}")],
        );
    }
    assert_edit_refused(&text, "version = 1\n", "", &["no `version` key"]);
}

#[test]
fn refuses_missing_fields_with_toml_context() {
    let text = base_text();
    for (line, field) in [
        ("thickness_um = 45.0\n", "thickness_um"),
        ("name = \"Signal red\"\n", "name"),
        ("lobe = \"normalised\"\n", "lobe"),
        ("geometry_deg = 20\n", "geometry_deg"),
    ] {
        assert_edit_refused(&text, line, "", &["missing field", field, "line"]);
    }
}

#[test]
fn refuses_unknown_fields() {
    let text = base_text();
    let cases = [
        ("thickness_um = 45.0", "thicknes_um = 45.0", "thicknes_um"),
        ("[gloss]\n", "[gloss]\nhaze = 3.0\n", "haze"),
        ("b_um2 = 0.0045 }", "b_um2 = 0.0045, c_um4 = 0.0 }", "c_um4"),
        (
            "lobe = \"normalised\"\n",
            "lobe = \"normalised\"\n[extra]\n",
            "extra",
        ),
    ];
    for (from, to, field) in cases {
        assert_edit_refused(&text, from, to, &["unknown", field, "line"]);
    }
    // Inside a table too (TabulatedSpectrum's own form would ignore it).
    let hand = fs::read_to_string(fixture("hand-written.toml")).unwrap();
    assert_edit_refused(
        &hand,
        "value = [0.06,",
        "values = [0.0, 1.0], value = [0.06,",
        &["unknown", "values"],
    );
    assert_edit_refused(
        &hand,
        "{ constant = 0.0005 }",
        "{ constnat = 0.0005 }",
        &["constnat"],
    );
}

#[test]
fn refuses_refractive_index_below_one() {
    let mut design = base();
    design.refractive_index = RefractiveIndex::Cauchy {
        a: 0.9,
        b_um2: 0.0045,
    };
    let message = refusal_of(&design);
    assert_names(
        &message,
        &["test.toml: clear_coat.refractive_index: Cauchy n(780 nm) = 0.9074 is below 1"],
    );
    // Anomalous dispersion: the minimum is at the blue end.
    design.refractive_index = RefractiveIndex::Cauchy {
        a: 1.05,
        b_um2: -0.01,
    };
    assert_names(
        &refusal_of(&design),
        &["Cauchy n(380 nm) = 0.9807 is below 1"],
    );
    design.refractive_index = RefractiveIndex::Table(
        TabulatedSpectrum::new(vec![380.0, 395.0, 780.0], vec![1.5, 0.98, 1.5]).unwrap(),
    );
    assert_names(
        &refusal_of(&design),
        &["clear_coat.refractive_index.table.value[1] = 0.98 at 395 nm is below 1"],
    );
}

#[test]
fn refuses_albedo_outside_unit_interval() {
    let design = with_albedo_value(&base(), 12, 1.2);
    assert_names(
        &refusal_of(&design),
        &["test.toml: pigment.albedo.value[12] = 1.2 at 440 nm is outside [0, 1]"],
    );
    let design = with_albedo_value(&base(), 0, -0.01);
    assert_names(
        &refusal_of(&design),
        &["pigment.albedo.value[0] = -0.01 at 380 nm is outside [0, 1]"],
    );
    let error = with_albedo_value(&base(), 0, -0.01).validate().unwrap_err();
    assert_eq!(error.field(), Some("pigment.albedo.value[0]"));
}

#[test]
fn refuses_negative_absorption_and_thickness() {
    let mut design = base();
    design.absorption_per_um = Absorption::Constant(-0.001);
    assert_names(
        &refusal_of(&design),
        &["clear_coat.absorption_per_um.constant = -0.001 is negative"],
    );
    design.absorption_per_um = Absorption::Table(
        TabulatedSpectrum::new(vec![380.0, 500.0, 780.0], vec![0.01, -1e-4, 0.0]).unwrap(),
    );
    assert_names(
        &refusal_of(&design),
        &["clear_coat.absorption_per_um.table.value[1] = -0.0001 at 500 nm is negative"],
    );
    let mut design = base();
    design.thickness_um = -5.0;
    assert_names(
        &refusal_of(&design),
        &["clear_coat.thickness_um = -5 is negative"],
    );
}

#[test]
fn refuses_non_finite_numbers() {
    let text = base_text();
    let cases = [
        (
            "thickness_um = 45.0",
            "thickness_um = nan",
            "clear_coat.thickness_um = NaN",
        ),
        ("gu = 88.0", "gu = inf", "gloss.gu = inf"),
        (
            "a = 1.515",
            "a = -inf",
            "clear_coat.refractive_index.cauchy.a = -inf",
        ),
        (
            "380, 385, 390,",
            "380, 385, nan,",
            "pigment.albedo.wavelength_nm[2] = NaN",
        ),
        (
            "0.0571, 0.0601,",
            "nan, 0.0601,",
            "pigment.albedo.value[0] = NaN at 380 nm",
        ),
        (
            "0.151, 0.151, 0.151, 0.151,",
            "0.151, inf, 0.151, 0.151,",
            "absorption_per_um.table.value[1] = inf",
        ),
    ];
    for (from, to, expected) in cases {
        assert_edit_refused(&text, from, to, &[expected, "not a finite number"]);
    }
    let hand = fs::read_to_string(fixture("hand-written.toml")).unwrap();
    assert_edit_refused(
        &hand,
        "constant = 0.0005",
        "constant = nan",
        &["clear_coat.absorption_per_um.constant = NaN is not a finite number"],
    );
}

#[test]
fn refuses_blank_names() {
    for name in ["", "   \t"] {
        let mut design = base();
        design.name = name.to_owned();
        let message = refusal_of(&design);
        assert_names(&message, &["name = ", "is empty"]);
    }
}

#[test]
fn refuses_gloss_out_of_range() {
    let mut design = base();
    design.gloss.gu = -3.0;
    assert_names(&refusal_of(&design), &["gloss.gu = -3 is negative"]);
    // Below what the broadest lobe reads at 20°: m(g) has no answer.
    design.gloss.gu = 0.0;
    let message = refusal_of(&design);
    assert_names(
        &message,
        &["gloss.gu = 0", "below the lowest reading", "20°"],
    );
    assert_eq!(design.validate().unwrap_err().field(), Some("gloss.gu"));
    // At or above the mirror reading is allowed: the ideal mirror.
    design.gloss.gu = 99.0;
    assert_eq!(design.exponent().unwrap(), GlossExponent::Mirror);
    design.validate().unwrap();

    let text = base_text();
    assert_edit_refused(
        &text,
        "geometry_deg = 20",
        "geometry_deg = 45",
        &["45", "20°, 60°, 85°", "line"],
    );
    assert_edit_refused(
        &text,
        "lobe = \"normalised\"\n",
        "lobe = \"phong\"\n",
        &["phong", "line"],
    );
}

#[test]
fn refuses_badly_shaped_spectra() {
    let hand = fs::read_to_string(fixture("hand-written.toml")).unwrap();
    assert_edit_refused(
        &hand,
        "[380, 450, 520, 560,",
        "[380, 450, 450, 560,",
        &[
            "pigment.albedo.wavelength_nm[2] = 450 nm is not greater than the one before it (450 nm)",
        ],
    );
    assert_edit_refused(
        &hand,
        "[380, 450, 520, 560,",
        "[380, 520, 450, 560,",
        &["pigment.albedo.wavelength_nm[2] = 450 nm"],
    );
    // Coverage: must reach down to 400 and up to 700 nm.
    assert_edit_refused(
        &hand,
        "[380, 450, 520, 560,",
        "[420, 450, 520, 560,",
        &[
            "pigment.albedo.wavelength_nm covers 420–780 nm",
            "400–700 nm",
        ],
    );
    assert_edit_refused(
        &hand,
        "656.3, 780]",
        "656.3, 690]",
        &["clear_coat.refractive_index.table.wavelength_nm covers 380–690 nm"],
    );
    // Values and wavelengths must pair up.
    assert_edit_refused(
        &hand,
        "0.7, 0.72]",
        "0.7]",
        &["pigment.albedo has 7 values for 8 wavelengths"],
    );
    assert_edit_refused(
        &hand,
        "[380, 450, 520, 560, 580, 600, 650, 780], value = [0.06, 0.05, 0.06, 0.2, 0.45, 0.62, 0.7, 0.72]",
        "[380], value = [0.06]",
        &["pigment.albedo has 1 sample(s)"],
    );
}

#[test]
fn refuses_bad_toml_with_position() {
    let message = refusal("format = \"coatlab-paint-design\"\nversion = 1\nname = \n");
    assert_names(&message, &["line 3"]);
}

#[test]
fn load_names_the_file_and_reports_missing_files() {
    let dir = scratch_dir("load-errors");
    let path = dir.join("broken.toml");
    fs::write(
        &path,
        base_text().replace("thickness_um = 45.0", "thickness_um = -1.0"),
    )
    .unwrap();
    let message = PaintDesign::load(&path).unwrap_err().to_string();
    assert_names(
        &message,
        &["broken.toml: clear_coat.thickness_um = -1 is negative"],
    );
    let error = PaintDesign::load(dir.join("absent.toml")).unwrap_err();
    assert!(matches!(error, DesignError::Read { .. }));
    assert_names(&error.to_string(), &["absent.toml"]);
}

// ---------------------------------------------------------------------------------
// Atomic saves

#[test]
fn save_replaces_an_existing_file_and_leaves_no_temporary_files() {
    let dir = scratch_dir("save-replace");
    let path = dir.join("design.toml");
    fs::write(&path, "old contents").unwrap();
    base().save(&path).unwrap();
    assert_eq!(fs::read_to_string(&path).unwrap(), base_text());
    assert_eq!(files_in(&dir), BTreeSet::from(["design.toml".to_owned()]));
}

#[test]
fn failed_saves_leave_the_old_file_untouched() {
    let dir = scratch_dir("save-failures");
    let path = dir.join("design.toml");
    fs::write(&path, "old contents").unwrap();

    // An invalid design is never written.
    let mut invalid = base();
    invalid.thickness_um = f64::NAN;
    assert!(invalid.save(&path).is_err());
    assert_eq!(fs::read_to_string(&path).unwrap(), "old contents");

    // The final rename fails (the target is a non-empty directory): the error names
    // the path, the directory is intact and the temporary file is cleaned up.
    let blocker = dir.join("blocker.toml");
    fs::create_dir(&blocker).unwrap();
    fs::write(blocker.join("keep"), "kept").unwrap();
    let error = base().save(&blocker).unwrap_err();
    assert!(matches!(error, DesignError::Write { .. }));
    assert_names(&error.to_string(), &["cannot save", "blocker.toml"]);
    assert_eq!(fs::read_to_string(blocker.join("keep")).unwrap(), "kept");

    // Writing the temporary file fails (its directory does not exist).
    let missing = dir.join("no-such-dir").join("design.toml");
    assert!(matches!(
        base().save(&missing),
        Err(DesignError::Write { .. })
    ));
    assert!(!missing.exists());

    assert_eq!(fs::read_to_string(&path).unwrap(), "old contents");
    assert_eq!(
        files_in(&dir),
        BTreeSet::from(["blocker.toml".to_owned(), "design.toml".to_owned()])
    );
}

#[cfg(unix)]
#[test]
fn save_into_a_read_only_directory_fails_cleanly() {
    use std::os::unix::fs::PermissionsExt;
    let dir = scratch_dir("save-read-only");
    let path = dir.join("design.toml");
    fs::write(&path, "old contents").unwrap();
    fs::set_permissions(&dir, fs::Permissions::from_mode(0o555)).unwrap();
    // Root (as in some CI containers) ignores directory permissions; there the
    // scenario cannot be staged, and the other save tests cover the failure paths.
    let probe = dir.join("probe");
    let staged = fs::write(&probe, "").is_err();
    let result = base().save(&path);
    let _ = fs::remove_file(&probe);
    fs::set_permissions(&dir, fs::Permissions::from_mode(0o755)).unwrap();
    if staged {
        assert!(matches!(result, Err(DesignError::Write { .. })));
        assert_eq!(fs::read_to_string(&path).unwrap(), "old contents");
        assert_eq!(files_in(&dir), BTreeSet::from(["design.toml".to_owned()]));
    }
}

// ---------------------------------------------------------------------------------
// The parameter table: validation refuses exactly what lies outside its ranges

/// The values at and just beyond each finite end of `bounds`, each with whether it
/// lies inside, plus the non-finite values (never accepted).
fn boundary_values(bounds: Bounds) -> Vec<(f64, bool)> {
    let mut values = vec![(f64::NAN, false), (f64::INFINITY, false)];
    if bounds.min.is_finite() {
        values.extend([(bounds.min, true), (bounds.min.next_down(), false)]);
    }
    if bounds.max.is_finite() {
        values.extend([(bounds.max, true), (bounds.max.next_up(), false)]);
    }
    values
}

/// `design` with albedo value 0 (at 380 nm) set to `value`.
fn with_first_albedo(design: &PaintDesign, value: f64) -> PaintDesign {
    with_albedo_value(design, 0, value)
}

#[test]
fn validation_refuses_exactly_outside_the_table_s_ranges() {
    type Setter = fn(&mut PaintDesign, f64);
    // (parameter, field, setter, whether the field is a table: a table cannot hold
    // a non-finite value at all, and its reading is tested with the TOML above).
    let cases: [(&Parameter, &str, Setter, bool); 5] = [
        (
            &ALBEDO,
            "pigment.albedo.value[0]",
            |d, v| *d = with_first_albedo(d, v),
            true,
        ),
        (
            &ABSORPTION,
            "clear_coat.absorption_per_um.constant",
            |d, v| d.absorption_per_um = Absorption::Constant(v),
            false,
        ),
        (
            &THICKNESS,
            "clear_coat.thickness_um",
            |d, v| d.thickness_um = v,
            false,
        ),
        (
            &REFRACTIVE_INDEX,
            "clear_coat.refractive_index.table.value[1]",
            |d, v| {
                d.refractive_index = RefractiveIndex::Table(
                    TabulatedSpectrum::new(vec![380.0, 587.6, 780.0], vec![1.5, v, 1.5]).unwrap(),
                );
            },
            true,
        ),
        (
            &CAUCHY_B,
            "clear_coat.refractive_index.cauchy.b_um2",
            |d, v| d.refractive_index = RefractiveIndex::Cauchy { a: 1.5, b_um2: v },
            false,
        ),
    ];
    for (parameter, field, set, table) in cases {
        for (value, inside) in boundary_values(parameter.range) {
            if table && !value.is_finite() {
                continue;
            }
            let mut design = base();
            // A gloss every index here can give, so only the parameter decides.
            design.gloss = Gloss {
                gu: 50.0,
                geometry: GlossGeometry::Deg60,
            };
            set(&mut design, value);
            let result = design.validate();
            assert_eq!(
                result.is_ok(),
                inside,
                "{} = {value}: {result:?}",
                parameter.label()
            );
            if let Err(error) = result {
                assert_names(
                    &error.to_string(),
                    &[field, &parameter.label(), &parameter.range_text()],
                );
            }
        }
    }
}

#[test]
fn a_cauchy_index_is_refused_exactly_where_n_leaves_its_range_in_the_visible() {
    let mut design = base();
    design.gloss = Gloss {
        gu: 10.0,
        geometry: GlossGeometry::Deg60,
    };
    // b = 0: n is a everywhere.
    for (a, inside) in [(1.0, true), (1.0f64.next_down(), false)] {
        design.refractive_index = RefractiveIndex::Cauchy { a, b_um2: 0.0 };
        assert_eq!(design.validate().is_ok(), inside, "a = {a}");
    }
    // b < 0: the minimum is at the short end of the visible range.
    let b_um2 = -0.01;
    let at_start = 1.0 - b_um2 / (VISIBLE.start_nm * 1e-3).powi(2);
    design.refractive_index = RefractiveIndex::Cauchy {
        a: at_start + 1e-12,
        b_um2,
    };
    assert!(design.validate().is_ok());
    design.refractive_index = RefractiveIndex::Cauchy {
        a: at_start - 1e-12,
        b_um2,
    };
    let message = design.validate().unwrap_err().to_string();
    assert_names(
        &message,
        &[
            &format!("Cauchy n({} nm)", VISIBLE.start_nm),
            &REFRACTIVE_INDEX.range_text(),
            &VISIBLE.to_string(),
        ],
    );
}

#[test]
fn a_gloss_reading_is_refused_exactly_below_the_broadest_lobe_s() {
    let mut design = base();
    let n = design.refractive_index_at_nm(GLOSS_WAVELENGTH_NM);
    for geometry in GlossGeometry::ALL {
        let range = reading_range(geometry, n).unwrap();
        for (gu, inside) in [
            (range.min, true),
            (range.min.next_down(), false),
            (range.max, true),
            (range.max * 2.0, true),
        ] {
            design.gloss = Gloss { gu, geometry };
            assert_eq!(design.validate().is_ok(), inside, "{gu} GU at {geometry}");
        }
    }
    for (gu, inside) in boundary_values(GLOSS.range) {
        if inside {
            continue; // 0 GU is in range but below every lobe's reading (above).
        }
        design.gloss.gu = gu;
        assert_names(
            &design.validate().unwrap_err().to_string(),
            &["gloss.gu", &GLOSS.label(), &GLOSS.range_text()],
        );
    }
}

// ---------------------------------------------------------------------------------
// The physics behind the paint panel's controls

#[test]
fn the_cauchy_fit_recovers_a_cauchy_table() {
    let w: Vec<f64> = (0..=40).map(|i| 380.0 + 10.0 * f64::from(i)).collect();
    let v = w
        .iter()
        .map(|l| 1.5 + 0.0042 / (l * 1e-3f64).powi(2))
        .collect();
    let fit = RefractiveIndex::cauchy_fit(&TabulatedSpectrum::new(w, v).expect("valid"));
    let RefractiveIndex::Cauchy { a, b_um2 } = fit else {
        panic!("a fit is a Cauchy index: {fit:?}");
    };
    assert!(
        (a - 1.5).abs() < 1e-9 && (b_um2 - 0.0042).abs() < 1e-9,
        "{a} {b_um2}"
    );
}

#[test]
fn the_cauchy_fit_ignores_samples_outside_the_visible_range() {
    // Far off the curve outside 380–780 nm, on it inside.
    let w = vec![300.0, 380.0, 500.0, 780.0, 830.0];
    let cauchy = |l: f64| 1.52 + 0.004 / (l * 1e-3).powi(2);
    let v = w
        .iter()
        .map(|&l| if VISIBLE.contains(l) { cauchy(l) } else { 3.0 })
        .collect();
    let fit = RefractiveIndex::cauchy_fit(&TabulatedSpectrum::new(w, v).unwrap());
    for l in [400.0, 600.0] {
        assert!((fit.at_nm(l) - cauchy(l)).abs() < 1e-12, "{fit:?}");
    }
    // One sample inside: a constant, n(587.6 nm) of the table, at least 1.
    let table = TabulatedSpectrum::new(vec![300.0, 550.0, 900.0], vec![0.9, 0.95, 0.9]).unwrap();
    assert_eq!(
        RefractiveIndex::cauchy_fit(&table),
        RefractiveIndex::Cauchy { a: 1.0, b_um2: 0.0 }
    );
}

#[test]
fn changing_the_geometry_keeps_the_lobe() {
    let g = Gloss {
        gu: 50.0,
        geometry: GlossGeometry::Deg20,
    };
    let g60 = g.at_geometry(GlossGeometry::Deg60, 1.5);
    assert_eq!(g60.geometry, GlossGeometry::Deg60);
    let back = g60.at_geometry(GlossGeometry::Deg20, 1.5);
    assert!((back.gu - 50.0).abs() < 1e-6, "{back:?}");
    // A reading no lobe gives is kept, at the new geometry.
    let low = Gloss {
        gu: 0.001,
        geometry: GlossGeometry::Deg20,
    };
    assert_eq!(
        low.at_geometry(GlossGeometry::Deg85, 1.5),
        Gloss {
            gu: 0.001,
            geometry: GlossGeometry::Deg85
        }
    );
}

#[test]
fn the_gloss_reading_range_runs_from_the_broadest_lobe_to_the_mirror() {
    for geometry in GlossGeometry::ALL {
        let range = reading_range(geometry, 1.5).unwrap();
        let broadest = reading_from_exponent(geometry, 1.5, GlossExponent::Finite(0.0)).unwrap();
        let mirror = reading_from_exponent(geometry, 1.5, GlossExponent::Mirror).unwrap();
        assert_eq!((range.min, range.max), (broadest, mirror));
        assert!(range.min < range.max && GLOSS.accepts(range.min));
    }
    assert!(reading_range(GlossGeometry::Deg20, 0.9).is_err());
}
