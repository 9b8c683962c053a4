//! End-to-end tests of `coatlab brdf` and `coatlab gloss`: the real binary, real pipes,
//! checked against the limits and conservation laws of spec 4.1 and 9 and the
//! reference readings of spec 4.3.

use std::f64::consts::PI;
use std::fmt::Write as _;

mod common;

use coatlab_core::paint::coat::body_albedo;
use coatlab_core::paint::fresnel::reflectance;
use coatlab_core::paint::parameters::{ALBEDO, GLOSS, OPTICAL_DEPTH, Parameter, REFRACTIVE_INDEX};
use common::{coatlab, exit, failure, parse_rows, stdout};

const BRDF_HEADER: &str = "n,rho,kh,theta_i_deg,theta_o_deg,dphi_deg";

/// cos θ for θ in degrees, exactly 0 at 90° (grazing), as the command computes it.
fn cos_deg(theta_deg: f64) -> f64 {
    (90.0 - theta_deg).to_radians().sin()
}

// ---------------------------------------------------------------------------------
// brdf

/// One row of `coatlab brdf` input in the canonical column order.
#[derive(Debug, Clone, Copy)]
struct BrdfRow {
    n: f64,
    rho: f64,
    kh: f64,
    theta_i_deg: f64,
    theta_o_deg: f64,
}

impl BrdfRow {
    fn new(n: f64, rho: f64, kh: f64, theta_i_deg: f64, theta_o_deg: f64) -> Self {
        Self {
            n,
            rho,
            kh,
            theta_i_deg,
            theta_o_deg,
        }
    }
}

/// Runs `coatlab brdf` on the rows (dphi 180) and returns (f_body, albedo) per row.
fn brdf(rows: &[BrdfRow]) -> Vec<(f64, f64)> {
    let mut input = format!("{BRDF_HEADER}\n");
    for r in rows {
        writeln!(
            input,
            "{},{},{},{},{},180",
            r.n, r.rho, r.kh, r.theta_i_deg, r.theta_o_deg
        )
        .unwrap();
    }
    let output = stdout(&coatlab(&["brdf"], &input));
    let (header, out_rows) = parse_rows(&output);
    assert_eq!(header.join(","), format!("{BRDF_HEADER},f_body,albedo"));
    assert_eq!(out_rows.len(), rows.len());
    out_rows
        .iter()
        .map(|row| {
            let f_body: f64 = row[6].parse().expect("f_body is a number");
            let albedo: f64 = row[7].parse().expect("albedo is a number");
            assert!(f_body.is_finite() && albedo.is_finite(), "{row:?}");
            (f_body, albedo)
        })
        .collect()
}

const INDICES: [f64; 6] = [1.0, 1.2, 1.5, 2.0, 3.0, 10.0];
const ANGLES_DEG: [f64; 9] = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0, 89.0, 90.0];

#[test]
fn brdf_accepts_any_column_order_and_passes_other_columns_through() {
    let canonical = stdout(&coatlab(
        &["brdf"],
        &format!("{BRDF_HEADER}\n1.5,0.4,0.05,30,60,180\n1.52,0.9,0,0,89,10\n"),
    ));
    let shuffled = stdout(&coatlab(
        &["brdf"],
        "id,theta_o_deg,kh,note,dphi_deg,rho,theta_i_deg,n\n\
         first,60,0.05,blue-ish,180,0.4,30,1.5\n\
         second,89,0,\"a, quoted\",10,0.9,0,1.52\n",
    ));
    let (header, rows) = parse_rows(&shuffled);
    assert_eq!(
        header.join(","),
        "id,theta_o_deg,kh,note,dphi_deg,rho,theta_i_deg,n,f_body,albedo"
    );
    assert!(
        shuffled.contains("second,89,0,\"a, quoted\",10,0.9,0,1.52,"),
        "{shuffled}"
    );
    assert_eq!(
        rows[0][..8].join(","),
        "first,60,0.05,blue-ish,180,0.4,30,1.5"
    );
    let (_, canonical_rows) = parse_rows(&canonical);
    // Same parameters, same numbers, to the last digit.
    assert_eq!(rows[0][8..], canonical_rows[0][6..]);
    let last_two = |row: &str| -> String {
        let fields: Vec<&str> = row.rsplitn(3, ',').collect();
        format!("{},{}", fields[1], fields[0])
    };
    assert_eq!(
        last_two(shuffled.lines().nth(2).unwrap()),
        last_two(canonical.lines().nth(2).unwrap())
    );
}

#[test]
fn brdf_of_header_only_is_header_only() {
    let output = stdout(&coatlab(&["brdf"], &format!("extra,{BRDF_HEADER}\n")));
    assert_eq!(output, format!("extra,{BRDF_HEADER},f_body,albedo\n"));
}

#[test]
fn brdf_at_index_one_is_the_attenuated_lambertian() {
    let mut rows = Vec::new();
    for rho in [0.0, 0.3, 1.0] {
        for kh in [0.0, 0.01, 0.5, 3.0] {
            for theta_i in ANGLES_DEG {
                for theta_o in [0.0, 20.0, 50.0, 80.0, 89.9] {
                    rows.push(BrdfRow::new(1.0, rho, kh, theta_i, theta_o));
                }
            }
        }
    }
    for (row, (f_body, _)) in rows.iter().zip(brdf(&rows)) {
        let mu_i = cos_deg(row.theta_i_deg);
        let mu_o = cos_deg(row.theta_o_deg);
        // τ/μ with μ = 0 is +∞ (exp → 0) for τ > 0; for τ = 0 the coat is absent.
        let path = |mu: f64| if row.kh == 0.0 { 0.0 } else { row.kh / mu };
        let expected = row.rho / PI * (-(path(mu_i) + path(mu_o))).exp();
        assert!(
            (f_body - expected).abs() <= 1e-12,
            "{row:?}: f_body {f_body}, expected {expected}"
        );
    }
}

/// The rows `rows_at(n)` for every n of [`INDICES`].
fn for_every_index<I: IntoIterator<Item = BrdfRow>>(rows_at: impl Fn(f64) -> I) -> Vec<BrdfRow> {
    INDICES.into_iter().flat_map(rows_at).collect()
}

#[test]
fn brdf_white_furnace_albedo_is_one() {
    let rows =
        for_every_index(|n| ANGLES_DEG.map(|theta_i| BrdfRow::new(n, 1.0, 0.0, theta_i, 0.0)));
    for (row, (_, albedo)) in rows.iter().zip(brdf(&rows)) {
        assert!((albedo - 1.0).abs() <= 1e-9, "{row:?}: albedo {albedo}");
    }
}

#[test]
fn brdf_albedo_is_at_most_one_and_matches_the_core() {
    let mut rows = Vec::new();
    for n in INDICES {
        for rho in [0.0, 0.2, 0.7, 0.95, 1.0] {
            for kh in [0.0, 0.02, 0.3, 2.0, 50.0] {
                for theta_i in ANGLES_DEG {
                    rows.push(BrdfRow::new(n, rho, kh, theta_i, 45.0));
                }
            }
        }
    }
    for (row, (f_body, albedo)) in rows.iter().zip(brdf(&rows)) {
        assert!(f_body >= 0.0, "{row:?}: f_body {f_body}");
        assert!(
            (0.0..=1.0 + 1e-12).contains(&albedo),
            "{row:?}: albedo {albedo}"
        );
        // The command caches the coat integrals per (n, kh); the core recomputes them.
        let mu_i = cos_deg(row.theta_i_deg);
        let expected = reflectance(mu_i, row.n) + body_albedo(row.rho, row.n, row.kh, mu_i);
        assert!(
            (albedo - expected).abs() <= 1e-12,
            "{row:?}: albedo {albedo}, core {expected}"
        );
    }
}

#[test]
fn brdf_is_reciprocal() {
    let mut rows = Vec::new();
    for n in [1.0, 1.5, 2.4] {
        for kh in [0.0, 0.1] {
            for (a, b) in [(0.0, 30.0), (10.0, 80.0), (45.0, 60.0), (5.0, 90.0)] {
                rows.push(BrdfRow::new(n, 0.8, kh, a, b));
                rows.push(BrdfRow::new(n, 0.8, kh, b, a));
            }
        }
    }
    let results = brdf(&rows);
    for (pair, rows) in results.chunks(2).zip(rows.chunks(2)) {
        let (forward, backward) = (pair[0].0, pair[1].0);
        assert!(
            (forward - backward).abs() <= 1e-14 * forward.abs(),
            "{rows:?}: {forward} vs {backward}"
        );
    }
}

#[test]
fn brdf_of_black_pigment_is_zero() {
    let rows = for_every_index(|n| {
        [(0.0, 0.0), (30.0, 70.0), (90.0, 10.0)]
            .map(|(theta_i, theta_o)| BrdfRow::new(n, 0.0, 0.01, theta_i, theta_o))
    });
    for (row, (f_body, albedo)) in rows.iter().zip(brdf(&rows)) {
        assert_eq!(f_body, 0.0, "{row:?}");
        // Only the mirror reflects.
        let mu_i = cos_deg(row.theta_i_deg);
        assert!(
            (albedo - reflectance(mu_i, row.n)).abs() <= 1e-15,
            "{row:?}"
        );
    }
}

#[test]
fn brdf_at_grazing_incidence_is_a_mirror_except_without_a_coat() {
    let mut rows = Vec::new();
    for n in INDICES {
        for rho in [0.0, 0.5, 1.0] {
            for kh in [0.0, 0.2] {
                rows.push(BrdfRow::new(n, rho, kh, 90.0, 30.0));
            }
        }
    }
    for (row, (f_body, albedo)) in rows.iter().zip(brdf(&rows)) {
        if row.n > 1.0 {
            assert_eq!(f_body, 0.0, "{row:?}");
            assert!((albedo - 1.0).abs() <= 1e-12, "{row:?}: albedo {albedo}");
        } else {
            // No interface: no mirror; the light reaches the pigment only through
            // a clear coat, along its surface.
            let expected = if row.kh == 0.0 { row.rho } else { 0.0 };
            assert!(
                (albedo - expected).abs() <= 1e-12,
                "{row:?}: albedo {albedo}"
            );
        }
    }
}

#[test]
fn brdf_reports_bad_rows_with_row_and_column() {
    let good = "1.5,0.5,0.01,30,30,180";
    let cases = [
        (
            "1.5,1.2,0.01,30,30,180",
            "stdin row 3 (line 4), column \"rho\": 1.2 is outside [0, 1]",
        ),
        ("0.9,0.5,0.01,30,30,180", "column \"n\": 0.9 is below 1"),
        ("1.5,-0.1,0.01,30,30,180", "column \"rho\": -0.1 is outside"),
        ("1.5,0.5,-1,30,30,180", "column \"kh\": -1 is negative"),
        (
            "1.5,0.5,0.01,90.5,30,180",
            "column \"theta_i_deg\": 90.5 is outside [0, 90]",
        ),
        (
            "1.5,0.5,0.01,30,-1,180",
            "column \"theta_o_deg\": -1 is outside [0, 90]",
        ),
        (
            "1.5,NaN,0.01,30,30,180",
            "column \"rho\": cannot read \"NaN\" as a finite number",
        ),
        (
            "inf,0.5,0.01,30,30,180",
            "column \"n\": cannot read \"inf\" as a finite number",
        ),
        (
            "1.5,0.5,0.01,30,30,nan",
            "column \"dphi_deg\": cannot read \"nan\" as a finite number",
        ),
        (
            "1.5,0.5,thin,30,30,180",
            "column \"kh\": cannot read \"thin\" as a finite number",
        ),
        ("1.5,0.5,0.01,30,30", "stdin row 3 (line 4): 5 fields"),
    ];
    for (bad, expected) in cases {
        let input = format!("{BRDF_HEADER}\n{good}\n{good}\n{bad}\n{good}\n");
        let message = failure(&coatlab(&["brdf"], &input), exit::DATA);
        assert!(
            message.contains("stdin row 3 (line 4)") && message.contains(expected),
            "{bad}: {message}"
        );
    }

    let message = failure(
        &coatlab(
            &["brdf"],
            "n,rho,theta_i_deg,theta_o_deg,dphi_deg\n1.5,0.5,30,30,180\n",
        ),
        exit::DATA,
    );
    assert!(
        message.contains("lacks column(s) kh"),
        "missing column: {message}"
    );
    let message = failure(
        &coatlab(&["brdf"], &format!("{BRDF_HEADER},albedo\n{good},0.3\n")),
        exit::DATA,
    );
    assert!(message.contains("\"albedo\""), "{message}");
}

/// The model's columns are checked against the paint parameter table: accepted
/// exactly at the ends of each range, refused just beyond, with the table's name
/// for the parameter and its range in the message.
#[test]
fn brdf_refuses_exactly_outside_the_parameter_table_and_names_it() {
    type Row = fn(f64) -> [f64; 3];
    let cases: [(&Parameter, &str, Row); 3] = [
        (&REFRACTIVE_INDEX, "n", |v| [v, 0.5, 0.01]),
        (&ALBEDO, "rho", |v| [1.5, v, 0.01]),
        (&OPTICAL_DEPTH, "kh", |v| [1.5, 0.5, v]),
    ];
    for (parameter, column, row) in cases {
        let range = parameter.range;
        let mut values = vec![(range.min, true), (range.min.next_down(), false)];
        if range.max.is_finite() {
            values.extend([(range.max, true), (range.max.next_up(), false)]);
        }
        for (value, inside) in values {
            let [n, rho, kh] = row(value);
            let input = format!("{BRDF_HEADER}\n{n},{rho},{kh},30,30,180\n");
            let output = coatlab(&["brdf"], &input);
            if inside {
                stdout(&output);
                continue;
            }
            let message = failure(&output, exit::DATA);
            for part in [
                format!("column \"{column}\": {value} "),
                parameter.label(),
                parameter.range_text(),
            ] {
                assert!(message.contains(&part), "{column} = {value}: {message}");
            }
        }
    }
}

#[test]
fn brdf_sweeps_ten_thousand_rows() {
    let mut input = format!("{BRDF_HEADER},id\n");
    let mut count = 0;
    for n in [1.5, 1.55] {
        for kh in [0.0, 0.05] {
            for i in 0..50 {
                for o in 0..50 {
                    let theta_i = 90.0 * f64::from(i) / 49.0;
                    let theta_o = 90.0 * f64::from(o) / 49.0;
                    writeln!(input, "{n},0.6,{kh},{theta_i},{theta_o},180,{count}").unwrap();
                    count += 1;
                }
            }
        }
    }
    assert_eq!(count, 10_000);
    let output = stdout(&coatlab(&["brdf"], &input));
    let (_, rows) = parse_rows(&output);
    assert_eq!(rows.len(), 10_000);
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row[6], i.to_string());
        let albedo: f64 = row[8].parse().unwrap();
        assert!((0.0..=1.0).contains(&albedo), "{row:?}");
    }
}

// ---------------------------------------------------------------------------------
// gloss

fn gloss(args: &[&str]) -> String {
    let mut all_args = vec!["gloss"];
    all_args.extend_from_slice(args);
    let text = stdout(&coatlab(&all_args, ""));
    assert!(
        text.ends_with('\n') && text.lines().count() == 1,
        "{text:?}"
    );
    text.trim_end().to_owned()
}

fn gloss_number(args: &[&str]) -> f64 {
    let text = gloss(args);
    text.parse()
        .unwrap_or_else(|_| panic!("{args:?} printed {text:?}"))
}

/// Every refusal of `gloss` is of its command line: exit status 2.
fn gloss_failure(args: &[&str]) -> String {
    let mut all_args = vec!["gloss"];
    all_args.extend_from_slice(args);
    failure(&coatlab(&all_args, ""), exit::USAGE)
}

#[test]
fn gloss_of_black_glass_mirror_is_100_at_every_geometry() {
    for geometry in ["20", "60", "85"] {
        let gu = gloss_number(&["--n", "1.567", "--geometry", geometry, "--m", "inf"]);
        assert!((gu - 100.0).abs() <= 1e-9, "{geometry}°: {gu}");
    }
}

#[test]
fn gloss_of_index_1_5_mirror_matches_the_spec() {
    for (geometry, expected) in [("20", 82.0), ("60", 89.1), ("85", 99.0)] {
        let gu = gloss_number(&["--n", "1.5", "--geometry", geometry, "--m", "inf"]);
        assert!((gu - expected).abs() <= 0.1, "{geometry}°: {gu}");
    }
    // The default geometry is 20°.
    let default = gloss_number(&["--n", "1.5", "--m", "inf"]);
    let at_20 = gloss_number(&["--n", "1.5", "--geometry", "20", "--m", "inf"]);
    assert_eq!(default, at_20);
}

#[test]
fn gloss_round_trips_through_the_exponent() {
    for (geometry, readings) in [
        ("20", [0.5, 5.0, 40.0, 80.0]),
        ("60", [1.0, 20.0, 60.0, 88.0]),
        ("85", [1.0, 30.0, 90.0, 98.5]),
    ] {
        let mut previous_m = 0.0;
        for gu in readings {
            let gu_text = gu.to_string();
            let m = gloss(&["--n", "1.5", "--geometry", geometry, "--gu", &gu_text]);
            let m_value: f64 = m.parse().unwrap();
            assert!(
                m_value.is_finite() && m_value > previous_m,
                "{geometry}° {gu} GU: m = {m}"
            );
            previous_m = m_value;
            let back = gloss_number(&["--n", "1.5", "--geometry", geometry, "--m", &m]);
            assert!(
                (back - gu).abs() <= 1e-6,
                "{geometry}° {gu} GU → m = {m} → {back} GU"
            );
        }
    }
}

#[test]
fn gloss_at_or_above_the_mirror_reading_is_inf() {
    let mirror = gloss(&["--n", "1.5", "--geometry", "60", "--m", "inf"]);
    for gu in [mirror.as_str(), "95", "150"] {
        assert_eq!(
            gloss(&["--n", "1.5", "--geometry", "60", "--gu", gu]),
            "inf",
            "{gu} GU"
        );
    }
    // m = 0 is the broadest lobe; its reading round-trips to m ≈ 0.
    let broadest = gloss(&["--n", "1.5", "--m", "0"]);
    let m = gloss_number(&["--n", "1.5", "--gu", &broadest]);
    assert!(m.abs() <= 1e-6, "m = {m}");
}

#[test]
fn gloss_reports_invalid_arguments() {
    let message = gloss_failure(&["--n", "1.5", "--geometry", "45", "--gu", "50"]);
    assert!(
        message.contains("45") && message.contains("20°, 60°, 85°"),
        "{message}"
    );
    for n in ["0.9", "NaN", "inf", "-1.5"] {
        let message = gloss_failure(&["--n", n, "--gu", "50"]);
        assert!(message.contains("refractive index"), "--n {n}: {message}");
    }
    for gu in ["-3", "NaN", "-inf"] {
        let message = gloss_failure(&["--n", "1.5", "--gu", gu]);
        // The parameter table's message: what is wrong, the parameter, its range.
        assert!(
            message.contains("gloss") && message.contains("must lie in [0"),
            "--gu {gu}: {message}"
        );
    }
    for m in ["-1", "NaN", "-inf"] {
        let message = gloss_failure(&["--n", "1.5", "--m", m]);
        assert!(
            message.contains("lobe exponent") && message.contains("non-negative"),
            "--m {m}: {message}"
        );
    }
    // The index and the reading are checked against the paint parameter table,
    // whose words for them the message uses.
    for (args, parameter) in [
        (["--n", "0.9", "--gu", "50"], &REFRACTIVE_INDEX),
        (["--n", "1.5", "--gu", "-3"], &GLOSS),
    ] {
        let message = gloss_failure(&args);
        assert!(
            message.contains(&parameter.label()) && message.contains(&parameter.range_text()),
            "{args:?}: {message}"
        );
    }
    // Below what the broadest lobe (m = 0) reads: the message gives that minimum.
    let minimum = gloss_number(&["--n", "1.5", "--geometry", "20", "--m", "0"]);
    let message = gloss_failure(&["--n", "1.5", "--geometry", "20", "--gu", "0.01"]);
    assert!(
        message.contains("below the lowest reading") && message.contains(&format!("{minimum:.4}")),
        "{message}"
    );
    // Exactly one of --gu and --m; not a number.
    gloss_failure(&["--n", "1.5"]);
    gloss_failure(&["--n", "1.5", "--gu", "50", "--m", "10"]);
    gloss_failure(&["--n", "1.5", "--gu", "glossy"]);
}
