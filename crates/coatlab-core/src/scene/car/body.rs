//! The body: one closed surface swept along the length, with its panels, shut lines,
//! feature line, glass and lamp lenses as regions of the same grid.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use glam::DVec3;

use super::mesh::{
    Profile, add_grid_patch, add_ring_quads, add_ring_surface, add_triangles, end_cap, lerp,
    smooth_min, smoothstep, superellipse,
};
use super::{
    ARCH_LIP_WIDTH_M, BODY, CABIN_LINING, CarParameters, GLASS, HEADLAMP_LENS, LAMP_EMITTER,
    LAMP_REFLECTOR, PANEL_GAP, TAIL_LAMP, TRIM, WELL_CLEARANCE_M,
};
use crate::scene::TriangleMesh;

/// Bands of rows around a body cross-section (upper quarter, mirrored on the left).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Band {
    /// Upper flank, waist to window line.
    Flank,
    /// Side window rows, window line to roof rail.
    Window,
    /// Roof rail and pillars.
    Rail,
    /// Bonnet, windscreen, roof, rear window, boot deck.
    Top,
    /// Below the waist.
    Lower,
}

/// The body's profiles along the length, as functions of `d`, the distance back
/// from the nose (z = length/2 − d).
pub(super) struct BodyShape {
    length: f64,
    half_width: f64,
    top: Profile,
    bottom: Profile,
    width: Profile,
    belt_start: f64,
    belt_rise: f64,
    bonnet_height: f64,
    greenhouse: f64,
    squareness: f64,
    crown: f64,
    bulge: f64,
    cowl: f64,
    roof_front: f64,
    roof_rear: f64,
    deck: f64,
    b_pillar: f64,
    wheels_z: [f64; 2],
    wheel_radius: f64,
    arch_radius: f64,
    well_scale: f64,
    /// Polar angles bounding the roof-rail band in the normalised section.
    rail: (f64, f64),
    /// Row counts per quarter: flank, window, rail, top; lower.
    rows: [usize; 5],
    /// Front overhang and wheelbase, m (the door cuts sit between the arches).
    front_overhang: f64,
    wheelbase: f64,
}

/// Height of the window line above the belt (the shoulder), m.
const SHOULDER_M: f64 = 0.07;

pub(super) struct Section {
    waist: f64,
    upper: f64,
    lower: f64,
    half_width: f64,
    belt: f64,
}

impl BodyShape {
    pub(super) fn new(p: &CarParameters) -> Self {
        let f = |v: f32| v as f64;
        let length = f(p.length_m);
        let half_width = 0.5 * f(p.width_m);
        let height = f(p.height_m);
        let fo = f(p.front_overhang_m);
        let wb = f(p.wheelbase_m);
        let ro = length - fo - wb;
        let clearance = f(p.ground_clearance_m);
        let nose = f(p.nose_height_m);
        let bonnet = f(p.bonnet_height_m);
        let boot = f(p.boot_height_m);
        let tail = f(p.tail_height_m);
        let cowl = f(p.bonnet_length_m);
        let roof_front = cowl + f(p.windscreen_length_m);
        let roof_rear = roof_front + f(p.roof_length_m);
        let deck = roof_rear + f(p.rear_window_length_m);
        let rl = roof_rear - roof_front;
        let rwl = deck - roof_rear;
        let boot_length = length - deck;

        let top = Profile::new(&[
            (0.0, nose),
            (0.45 * cowl, lerp(nose, bonnet, 0.72)),
            (cowl, bonnet),
            (cowl + 0.5 * (roof_front - cowl), lerp(bonnet, height, 0.58)),
            (roof_front, height - 0.025),
            (roof_front + 0.42 * rl, height),
            (roof_rear, height - 0.035),
            (roof_rear + 0.5 * rwl, lerp(height - 0.035, boot, 0.6)),
            (deck, boot),
            (deck + 0.6 * boot_length, boot - 0.012),
            (length, tail),
        ]);
        let bottom = Profile::new(&[
            (0.0, clearance + 0.22),
            (0.5 * fo, clearance + 0.07),
            (fo, clearance + 0.025),
            (fo + 0.5 * wb, clearance),
            (fo + wb, clearance + 0.025),
            (length - 0.5 * ro, clearance + 0.09),
            (length, clearance + 0.26),
        ]);
        let width = Profile::new(&[
            (0.0, 0.86),
            (0.5 * fo, 0.965),
            (fo, 0.99),
            (fo + 0.5 * wb, 1.0),
            (fo + wb, 0.993),
            (length - 0.5 * ro, 0.97),
            (length, 0.9),
        ]);

        let m = p.section_vertices as usize;
        let quarter_up = 5 * m / 16;
        let flank = ((quarter_up as f64) * 0.32).round() as usize;
        let window = ((quarter_up as f64) * 0.22).round() as usize;
        let rail = (((quarter_up as f64) * 0.11).round() as usize).max(2);
        let top_rows = quarter_up - flank - window - rail;
        let lower = m / 2 - quarter_up;
        let wheel_x = p.wheel_centre_x();
        let floor_x = wheel_x - 0.5 * f(p.tyre_width_m) - WELL_CLEARANCE_M;
        Self {
            length,
            half_width,
            top,
            bottom,
            width,
            belt_start: cowl,
            belt_rise: f(p.belt_rise_m) / (deck - cowl),
            bonnet_height: bonnet,
            greenhouse: f(p.greenhouse_width_fraction),
            squareness: f(p.section_squareness),
            crown: f(p.roof_crown),
            bulge: f(p.flank_bulge),
            cowl,
            roof_front,
            roof_rear,
            deck,
            b_pillar: cowl + 0.5 * (roof_rear - 0.1 - cowl),
            wheels_z: [p.front_axle_z(), p.rear_axle_z()],
            wheel_radius: f(p.wheel_radius_m),
            arch_radius: p.arch_radius_m(),
            well_scale: 1.0 - floor_x / half_width,
            rail: (0.52 * FRAC_PI_2, 0.60 * FRAC_PI_2),
            rows: [flank, window, rail, top_rows, lower],
            front_overhang: fo,
            wheelbase: wb,
        }
    }

    pub(super) fn belt(&self, d: f64) -> f64 {
        self.bonnet_height
            + self.belt_rise * (d - self.belt_start).clamp(0.0, self.deck - self.belt_start)
    }

    pub(super) fn section(&self, d: f64) -> Section {
        let top = self.top.eval(d);
        let bottom = self.bottom.eval(d);
        let belt = self.belt(d);
        let waist = bottom + 0.55 * (smooth_min(top, belt, 0.05) - bottom);
        let from_tail = self.length - d;
        let cap_w = end_cap(d, 0.5, 2.6) * end_cap(from_tail, 0.42, 2.6);
        let cap_h = end_cap(d, 0.26, 2.0) * end_cap(from_tail, 0.3, 2.0);
        Section {
            waist,
            upper: (top - waist) * cap_h,
            lower: (waist - bottom) * cap_h,
            half_width: self.half_width * self.width.eval(d) * cap_w,
            belt,
        }
    }

    /// Point of section `s` at polar angle `psi` ∈ [0, 2π) of the normalised
    /// superellipse (0 at the right waist, π/2 at the top), before the arches.
    fn point(&self, s: &Section, psi: f64) -> (f64, f64) {
        let (xn, yn) = superellipse(psi, self.squareness);
        let bow = (1.0 + self.bulge * (1.0 - yn * yn)) / (1.0 + self.bulge);
        let crown = (1.0 + self.crown * (1.0 - xn * xn)) / (1.0 + self.crown);
        if yn >= 0.0 {
            let y = s.waist + s.upper * yn * crown;
            let narrowing = smoothstep(s.belt - 0.07, s.belt + 0.27, y);
            let x = s.half_width * xn * bow * (1.0 - (1.0 - self.greenhouse) * narrowing);
            (x, y)
        } else {
            (s.half_width * xn * bow, s.waist + s.lower * yn * crown)
        }
    }

    /// Weight of the wheel well at (y, z): 1 inside, 0 outside the arch.
    fn well(&self, y: f64, z: f64) -> f64 {
        self.wheels_z
            .iter()
            .map(|&wz| {
                let rho = (y - self.wheel_radius).hypot(z - wz);
                1.0 - smoothstep(self.arch_radius - ARCH_LIP_WIDTH_M, self.arch_radius, rho)
            })
            .fold(0.0, f64::max)
    }

    /// Polar angle where the section meets the window line, and whether the section
    /// reaches it (the cabin).
    pub(super) fn window_line_angle(&self, s: &Section) -> (f64, bool) {
        let limit = 0.85 * self.rail.0;
        let target = s.belt + SHOULDER_M;
        if self.point(s, limit).1 <= target {
            return (limit, false);
        }
        let (mut lo, mut hi) = (0.0, limit);
        for _ in 0..48 {
            let mid = 0.5 * (lo + hi);
            if self.point(s, mid).1 < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        (0.5 * (lo + hi), true)
    }

    /// Point of the body surface (after the arches) at distance `d` back from the
    /// nose and polar angle `psi` of its section.
    pub(super) fn surface(&self, d: f64, psi: f64) -> DVec3 {
        let s = self.section(d);
        let (x, y) = self.point(&s, psi);
        let z = 0.5 * self.length - d;
        DVec3::new(x * (1.0 - self.well_scale * self.well(y, z)), y, z)
    }

    /// Point and outward unit normal of the surface at (`d`, `psi`), the normal by
    /// central differences (∂/∂d × ∂/∂ψ points outward: +x at the right waist).
    pub(super) fn surface_frame(&self, d: f64, psi: f64) -> (DVec3, DVec3) {
        let h = 1e-4;
        let along = self.surface(d + h, psi) - self.surface(d - h, psi);
        let around = self.surface(d, psi + h) - self.surface(d, psi - h);
        (self.surface(d, psi), along.cross(around).normalize())
    }

    /// Polar angle (right side) at fraction `f` of the flank band at `d`.
    pub(super) fn flank_angle(&self, d: f64, f: f64) -> f64 {
        f * self.window_line_angle(&self.section(d)).0
    }

    /// Where the cuts, the lamps and the cabin lie along the length.
    pub(super) fn layout(&self) -> Layout {
        let arch_front = self.front_overhang + self.arch_radius;
        let arch_rear = self.front_overhang + self.wheelbase - self.arch_radius;
        // The first section behind the cowl that reaches the window line: the front
        // doors start behind it, so that their top edge is glass all along.
        let cabin_start = (0..400)
            .map(|k| self.cowl + 0.005 * k as f64)
            .find(|&d| self.window_line_angle(&self.section(d)).1)
            .unwrap_or(self.roof_front);
        Layout {
            bonnet_front: 0.25 * self.front_overhang,
            cowl: self.cowl,
            front_door: (cabin_start + 0.04).max(arch_front + 0.08),
            b_pillar: self.b_pillar,
            rear_door: (self.roof_rear - 0.1).min(arch_rear - 0.06),
            deck: self.deck,
            boot_rear: self.length - 0.07,
            roof_rear: self.roof_rear,
            length: self.length,
        }
    }

    /// The rows of every section: the bands, each with its base rows and the
    /// narrow rows of the feature crease and the longitudinal shut lines.
    fn row_plan(&self) -> Vec<Row> {
        let [flank, window, rail, top, lower] = self.rows;
        let (r0, r1) = self.rail;
        // (from, to) as psi = a + b·window_line.
        let quarter: [BandSpec; 4] = [
            (
                (0.0, 0.0),
                (0.0, 1.0),
                flank,
                Band::Flank,
                vec![Knot::crease(FEATURE_FRACTION)],
            ),
            ((0.0, 1.0), (r0, 0.0), window, Band::Window, vec![]),
            ((r0, 0.0), (r1, 0.0), rail, Band::Rail, vec![]),
            (
                (r1, 0.0),
                (FRAC_PI_2, 0.0),
                top,
                Band::Top,
                vec![Knot::gap(0.0, RowCut::TopSide, 0.003)],
            ),
        ];
        let mut quarter_rows = Vec::new();
        for (from, to, count, band, knots) in &quarter {
            quarter_rows.extend(band_rows(*from, *to, *count, *band, knots));
        }
        // The upper half: the quarter from the waist (0) up to the top, the top row
        // (π/2), and the quarter mirrored back down, short of the left waist (π), the
        // first row of the lower half.
        let mut rows = quarter_rows.clone();
        rows.push(Row {
            a: FRAC_PI_2,
            b: 0.0,
            band: Band::Top,
            cut: None,
        });
        rows.extend(quarter_rows[1..].iter().rev().map(|r| Row {
            a: PI - r.a,
            b: -r.b,
            ..*r
        }));
        let bottom = DOOR_BOTTOM_ANGLE / PI;
        rows.extend(band_rows(
            (PI, 0.0),
            (TAU, 0.0),
            2 * lower,
            Band::Lower,
            &[
                Knot::gap(bottom, RowCut::DoorBottom, 0.006),
                Knot::gap(1.0 - bottom, RowCut::DoorBottom, 0.006),
            ],
        ));
        rows
    }

    /// Distances back from the nose of the body's sections: a cosine-weighted
    /// spacing (denser toward the caps) with five narrow sections at each
    /// transverse shut line.
    fn ring_plan(&self, n: usize) -> Vec<Ring> {
        let ring_d = |u: f64| self.length * (0.8 * 0.5 * (1.0 - (PI * u).cos()) + 0.2 * u);
        let l = self.layout();
        let cuts = [
            (l.bonnet_front, RingCut::TopCross),
            (l.front_door, RingCut::Door),
            (l.b_pillar, RingCut::Door),
            (l.rear_door, RingCut::Door),
            (l.deck + 0.012, RingCut::TopCross),
            (l.boot_rear, RingCut::TopCross),
        ];
        let mut rings: Vec<Ring> = (1..n)
            .filter_map(|i| {
                let d = ring_d(i as f64 / n as f64);
                let spacing =
                    ring_d((i as f64 + 0.5) / n as f64) - ring_d((i as f64 - 0.5) / n as f64);
                let clear = cuts
                    .iter()
                    .all(|&(c, _)| (d - c).abs() > GAP_SPREAD * GAP_HALF_M + 0.6 * spacing);
                clear.then_some(Ring { d, cut: None })
            })
            .collect();
        for &(centre, cut) in &cuts {
            for (k, offset) in GAP_OFFSETS.iter().enumerate() {
                rings.push(Ring {
                    d: centre + offset * GAP_HALF_M,
                    cut: Some((cut, k)),
                });
            }
        }
        rings.sort_by(|a, b| a.d.total_cmp(&b.d));
        rings
    }

    /// Whether the transverse cut `cut` runs through side angle `q` at `d`.
    fn ring_cut_spans(&self, cut: RingCut, q: f64, window_line: f64) -> bool {
        match cut {
            RingCut::TopCross => q >= self.rail.1 - 1e-9,
            RingCut::Door => q >= -DOOR_BOTTOM_ANGLE - 1e-9 && q <= window_line + 1e-9,
        }
    }

    /// Whether the longitudinal cut `cut` runs through `d`.
    fn row_cut_spans(&self, cut: RowCut, d: f64) -> bool {
        let l = self.layout();
        let within = |from: f64, to: f64| d >= from - 1e-9 && d <= to + 1e-9;
        match cut {
            RowCut::TopSide => {
                within(l.bonnet_front, l.cowl) || within(l.deck + 0.012, l.boot_rear)
            }
            RowCut::DoorBottom => within(l.front_door, l.rear_door),
        }
    }

    /// Appends the body surface and, inside it, the lamps' reflector bowls.
    pub(super) fn add_to(&self, mesh: &mut TriangleMesh, p: &CarParameters) {
        let plan = self.row_plan();
        let ring_plan = self.ring_plan(p.rings as usize);
        let half_length = 0.5 * self.length;
        let m = plan.len();

        // The undisplaced grid: per ring its window line, cabin flag and points.
        let mut base: Vec<Vec<DVec3>> = Vec::with_capacity(ring_plan.len());
        let mut lines = Vec::with_capacity(ring_plan.len());
        for ring in &ring_plan {
            let s = self.section(ring.d);
            let (window_line, cabin) = self.window_line_angle(&s);
            lines.push((window_line, cabin));
            base.push(
                plan.iter()
                    .map(|row| {
                        let (x, y) = self.point(&s, row.psi(window_line));
                        let z = half_length - ring.d;
                        DVec3::new(x * (1.0 - self.well_scale * self.well(y, z)), y, z)
                    })
                    .collect(),
            );
        }
        let nose = self.section(0.0);
        let tail = self.section(self.length);
        let poles = (
            DVec3::new(0.0, nose.waist, half_length),
            DVec3::new(0.0, tail.waist, -half_length),
        );
        let normals = grid_normals(&base, poles);

        // Displacements along the normal: the feature crease outward, the shut lines
        // inward.
        let rings: Vec<Vec<[f64; 3]>> = (0..ring_plan.len())
            .map(|i| {
                let ring = &ring_plan[i];
                let (window_line, _) = lines[i];
                (0..m)
                    .map(|j| {
                        let row = &plan[j];
                        let psi = row.psi(window_line);
                        let q = side_angle(psi);
                        let mut offset = 0.0;
                        if row.band == Band::Flank {
                            let t = (q - FEATURE_FRACTION * window_line).abs() / FEATURE_WIDTH;
                            let fade = smoothstep(0.35, 0.7, ring.d)
                                * smoothstep(0.35, 0.7, self.length - ring.d);
                            offset += FEATURE_HEIGHT_M * (1.0 - t).max(0.0).powi(2) * fade;
                        }
                        let mut depth: f64 = 0.0;
                        if let Some((cut, k)) = ring.cut
                            && self.ring_cut_spans(cut, q, window_line)
                        {
                            depth = depth.max(GAP_DEPTHS[k]);
                        }
                        if let Some((cut, k)) = row.cut
                            && self.row_cut_spans(cut, ring.d)
                        {
                            depth = depth.max(GAP_DEPTHS[k]);
                        }
                        (base[i][j] + normals[i][j] * (offset - depth)).to_array()
                    })
                    .collect()
            })
            .collect();

        // Materials of the quads (ring i to i + 1, row j to j + 1).
        let layout = self.layout();
        let materials: Vec<Vec<u32>> = (0..ring_plan.len() - 1)
            .map(|i| {
                (0..m)
                    .map(|j| {
                        self.quad_material(
                            &layout,
                            [&ring_plan[i], &ring_plan[i + 1]],
                            [&plan[j], &plan[(j + 1) % m]],
                            lines[i],
                            [rings[i][j], rings[i + 1][(j + 1) % m]],
                        )
                    })
                    .collect()
            })
            .collect();
        let last = ring_plan.len() - 1;
        add_ring_surface(
            mesh,
            &rings,
            Some((poles.0.to_array(), poles.1.to_array())),
            false,
            |i, j| {
                if i < 0 || i as usize >= last {
                    BODY
                } else {
                    materials[i as usize][j]
                }
            },
        );

        self.add_cabin_lining(mesh, &ring_plan, &rings, &normals, &materials);

        for (lens, depth) in [(HEADLAMP_LENS, 0.03), (TAIL_LAMP, 0.025)] {
            for right in [true, false] {
                let quads = (0..last).flat_map(|i| (0..m).map(move |j| (i, j)));
                let on_side = |&(i, j): &(usize, usize)| {
                    let psi = plan[j].psi(lines[i].0);
                    materials[i][j] == lens && (FRAC_PI_2..=1.5 * PI).contains(&psi) != right
                };
                let selected: Vec<(usize, usize)> = quads.filter(on_side).collect();
                let Some(first) = selected.first() else {
                    continue;
                };
                let (mut i0, mut i1, mut j0, mut j1) = (first.0, first.0, first.1, first.1);
                for &(i, j) in &selected {
                    (i0, i1, j0, j1) = (i0.min(i), i1.max(i), j0.min(j), j1.max(j));
                }
                let bowl = LampBowl {
                    rings: i0..=i1 + 1,
                    rows: j0..=j1 + 1,
                    depth,
                    emitter: lens == HEADLAMP_LENS,
                };
                bowl.add_to(mesh, &rings, &normals);
            }
        }
    }

    /// Appends the cabin's lining (door cards, pillar trims, headliner): seen from
    /// inside through the glass the body is trim, as in a real car, not the paint.
    /// It is the body's grid (`rings`, with its `normals` and quad `materials`)
    /// drawn in toward each section's centre over the cabin's length, less the
    /// glass's quads: toward the centre, not along the normals, which would fold
    /// where the arch lips turn tighter than the inset.
    fn add_cabin_lining(
        &self,
        mesh: &mut TriangleMesh,
        ring_plan: &[Ring],
        rings: &[Vec<[f64; 3]>],
        normals: &[Vec<DVec3>],
        materials: &[Vec<u32>],
    ) {
        let last = ring_plan.len() - 1;
        let m = rings[0].len();
        let lined = |i: usize| {
            (self.cowl - LINING_OVERHANG_M..=self.deck + LINING_OVERHANG_M)
                .contains(&ring_plan[i].d)
        };
        let (Some(first), Some(end)) = ((0..last).position(lined), (0..last + 1).rposition(lined))
        else {
            return;
        };
        let lining: Vec<Vec<DVec3>> = (first..=end)
            .map(|i| {
                let waist = self.section(ring_plan[i].d).waist;
                (0..m)
                    .map(|j| {
                        let point = DVec3::from(rings[i][j]);
                        let outward = point - DVec3::new(0.0, waist, point.z);
                        point - outward * (LINING_INSET_M / outward.length())
                    })
                    .collect()
            })
            .collect();
        let lined_quad = |i: usize, j: usize| materials[first + i][j % m] != GLASS;
        add_ring_quads(
            mesh,
            &lining,
            |i, j| lined_quad(i, j).then_some(CABIN_LINING),
            |i, j| -normals[first + i][j],
        );
        // The reveals: where the lining meets a pane, a strip from its edge out
        // to the pane's, so that no paint shows between them at a glancing look.
        let shell = |i: usize, j: usize| DVec3::from(rings[first + i][j % m]);
        let inner = |i: usize, j: usize| lining[i][j % m];
        // Each faces the pane (i, j) it borders, away from the hollow between
        // the lining and the body.
        let strip = |(i0, j0): (usize, usize), (i1, j1): (usize, usize), (i, j)| {
            let [a, b, c, d] = [inner(i0, j0), inner(i1, j1), shell(i1, j1), shell(i0, j0)];
            let pane =
                0.25 * (shell(i, j) + shell(i + 1, j) + shell(i, j + 1) + shell(i + 1, j + 1));
            if (b - a).cross(c - a).dot(pane - 0.5 * (a + b)) >= 0.0 {
                [[a, b, c], [a, c, d]]
            } else {
                [[a, c, b], [a, d, c]]
            }
        };
        let quads = lining.len() - 1;
        let mut reveals = Vec::new();
        for i in 0..quads {
            for j in (0..m).filter(|&j| lined_quad(i, j)) {
                let below = (j + m - 1) % m;
                if !lined_quad(i, below) {
                    reveals.extend(strip((i, j), (i + 1, j), (i, below)));
                }
                if !lined_quad(i, j + 1) {
                    reveals.extend(strip((i, j + 1), (i + 1, j + 1), (i, j + 1)));
                }
                if i > 0 && !lined_quad(i - 1, j) {
                    reveals.extend(strip((i, j), (i, j + 1), (i - 1, j)));
                }
                if i + 1 < quads && !lined_quad(i + 1, j) {
                    reveals.extend(strip((i + 1, j), (i + 1, j + 1), (i + 1, j)));
                }
            }
        }
        add_triangles(mesh, &reveals, CABIN_LINING);
        // The bulkheads closing the lining at its two ends (the front one behind
        // the dashboard, the rear one behind the rear seat's backrest).
        let bulkheads: Vec<[DVec3; 3]> = [0, quads]
            .into_iter()
            .flat_map(|i| {
                let centre = DVec3::new(
                    0.0,
                    self.section(ring_plan[first + i].d).waist,
                    lining[i][0].z,
                );
                (0..m).map(move |j| [centre, inner(i, j), inner(i, j + 1)])
            })
            .collect();
        add_triangles(mesh, &bulkheads, CABIN_LINING);
    }

    /// Material of one quad of the body grid.
    fn quad_material(
        &self,
        l: &Layout,
        rings: [&Ring; 2],
        rows: [&Row; 2],
        (window_line, cabin): (f64, bool),
        corners: [[f64; 3]; 2],
    ) -> u32 {
        let d = 0.5 * (rings[0].d + rings[1].d);
        let (psi0, mut psi1) = (rows[0].psi(window_line), rows[1].psi(window_line));
        if psi1 < psi0 {
            psi1 += TAU;
        }
        let psi = 0.5 * (psi0 + psi1);
        let q = side_angle(psi);
        let mid = 0.5 * (DVec3::from(corners[0]) + DVec3::from(corners[1]));
        if self.well(mid.y, mid.z) > 0.9 {
            return TRIM;
        }
        // Shut lines: the two quads either side of a cut's centre.
        let central = |k: usize| (1..=3).contains(&k);
        if let (Some((a, ka)), Some((b, kb))) = (rings[0].cut, rings[1].cut)
            && a == b
            && central(ka)
            && central(kb)
            && self.ring_cut_spans(a, q, window_line)
        {
            return PANEL_GAP;
        }
        if let (Some((a, ka)), Some((b, kb))) = (rows[0].cut, rows[1].cut)
            && a == b
            && central(ka)
            && central(kb)
            && self.row_cut_spans(a, d)
        {
            return PANEL_GAP;
        }
        let flank_fraction = q / window_line;
        if rows[0].band == Band::Flank {
            if d > HEADLAMP_D.0 && d < HEADLAMP_D.1 && (0.4..0.92).contains(&flank_fraction) {
                return HEADLAMP_LENS;
            }
            let from_tail = l.length - d;
            if from_tail > TAIL_LAMP_D.0
                && from_tail < TAIL_LAMP_D.1
                && (0.3..0.97).contains(&flank_fraction)
            {
                return TAIL_LAMP;
            }
        }
        // The front intake and the rear valance below the bumpers.
        if (d < GRILLE_DEPTH_M && q < -0.25) || (l.length - d < VALANCE_DEPTH_M && q < -0.45) {
            return TRIM;
        }
        match rows[0].band {
            Band::Window if cabin && d > self.cowl + 0.02 && d < self.roof_rear - 0.1 => {
                if (d - self.b_pillar).abs() > 0.045 {
                    GLASS
                } else {
                    TRIM
                }
            }
            Band::Top
                if (d > self.cowl && d < self.roof_front)
                    || (d > self.roof_rear && d < self.deck) =>
            {
                GLASS
            }
            _ => BODY,
        }
    }
}

/// Height of the feature crease above the flank, m, and its half-width as a polar
/// angle: the crease's two sides meet at about 2·atan(2·h/w·…) ≈ 20°.
const FEATURE_HEIGHT_M: f64 = 0.005;
const FEATURE_WIDTH: f64 = 0.16;
/// Where the feature crease runs, as a fraction of the flank (waist to window line).
const FEATURE_FRACTION: f64 = 0.62;
/// Half-width of a shut line, m (and the polar half-widths given per row cut).
const GAP_HALF_M: f64 = 0.0025;
/// Positions of the five sections or rows of a cut, in half-widths: the panel edges
/// roll over between the outer two and the inner two; the centre is the gap floor.
const GAP_OFFSETS: [f64; 5] = [-2.5, -1.0, 0.0, 1.0, 2.5];
const GAP_SPREAD: f64 = 2.5;
/// Inward displacement of the five sections or rows of a cut, m.
const GAP_DEPTHS: [f64; 5] = [0.0, 0.0008, 0.004, 0.0008, 0.0];
/// Polar angle below the waist of the doors' lower shut line.
const DOOR_BOTTOM_ANGLE: f64 = 0.42;
/// How far inside the body its cabin lining lies, m.
const LINING_INSET_M: f64 = 0.03;
/// How far the lining reaches in front of the cowl and behind the boot deck's
/// front edge, m, so that no edge of it shows through the windscreen or the rear
/// window.
const LINING_OVERHANG_M: f64 = 0.05;
/// Headlamps and tail lamps: the range of `d` from the nose and from the tail, m.
const HEADLAMP_D: (f64, f64) = (0.02, 0.32);
const TAIL_LAMP_D: (f64, f64) = (0.01, 0.3);
/// The front intake: quads this close to the nose below the waist are trim.
const GRILLE_DEPTH_M: f64 = 0.12;
/// The rear valance: quads this close to the tail, well below the waist, are trim.
const VALANCE_DEPTH_M: f64 = 0.1;

/// Where the body's cuts lie along the length (distances back from the nose), m.
pub(super) struct Layout {
    pub(super) bonnet_front: f64,
    pub(super) cowl: f64,
    pub(super) front_door: f64,
    pub(super) b_pillar: f64,
    pub(super) rear_door: f64,
    pub(super) deck: f64,
    pub(super) boot_rear: f64,
    pub(super) roof_rear: f64,
    pub(super) length: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum RingCut {
    /// Across the top: bonnet front, boot lid front and rear.
    TopCross,
    /// Down the flank, door bottom to window line.
    Door,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum RowCut {
    /// Along the top: the sides of bonnet and boot lid.
    TopSide,
    /// Along the flank below the waist: the doors' lower edge.
    DoorBottom,
}

struct Ring {
    d: f64,
    /// The cut and which of its five sections (0..5) this is.
    cut: Option<(RingCut, usize)>,
}

/// A row of the section grid at polar angle `a + b·window_line`.
#[derive(Debug, Clone, Copy)]
struct Row {
    a: f64,
    b: f64,
    band: Band,
    cut: Option<(RowCut, usize)>,
}

impl Row {
    fn psi(&self, window_line: f64) -> f64 {
        self.a + self.b * window_line
    }
}

/// A band of rows: from and to (as psi = a + b·window_line), its row count, its
/// kind, and the extra rows inside it.
type BandSpec = ((f64, f64), (f64, f64), usize, Band, Vec<Knot>);

/// Extra rows inside a band: a cut or the feature crease, at a fraction of the band.
struct Knot {
    fraction: f64,
    /// Offsets of its rows, polar angle.
    offsets: Vec<f64>,
    cut: Option<RowCut>,
}

impl Knot {
    fn crease(fraction: f64) -> Self {
        Self {
            fraction,
            offsets: vec![-0.004, 0.0, 0.004],
            cut: None,
        }
    }

    fn gap(fraction: f64, cut: RowCut, half_angle: f64) -> Self {
        Self {
            fraction,
            offsets: GAP_OFFSETS.iter().map(|o| o * half_angle).collect(),
            cut: Some(cut),
        }
    }
}

/// The rows of one band from `from` (inclusive) toward `to`: `count` evenly spaced
/// ones, less those a knot's rows replace.
fn band_rows(
    from: (f64, f64),
    to: (f64, f64),
    count: usize,
    band: Band,
    knots: &[Knot],
) -> Vec<Row> {
    let at = |fraction: f64, offset: f64| Row {
        a: lerp(from.0, to.0, fraction) + offset,
        b: lerp(from.1, to.1, fraction),
        band,
        cut: None,
    };
    let mut rows: Vec<(f64, Row)> = (0..count)
        .map(|k| k as f64 / count as f64)
        .filter(|f| {
            knots
                .iter()
                .all(|knot| (f - knot.fraction).abs() >= 0.6 / count as f64)
        })
        .map(|f| (f, at(f, 0.0)))
        .collect();
    for knot in knots {
        for (k, &offset) in knot.offsets.iter().enumerate() {
            let row = Row {
                cut: knot.cut.map(|c| (c, k)),
                ..at(knot.fraction, offset)
            };
            rows.push((knot.fraction + offset * 1e-3, row));
        }
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    rows.into_iter().map(|(_, r)| r).collect()
}

/// Polar angle folded onto the right side: in (−π/2, π/2], equal on mirrored points.
fn side_angle(psi: f64) -> f64 {
    if psi <= FRAC_PI_2 {
        psi
    } else if psi <= 1.5 * PI {
        PI - psi
    } else {
        psi - TAU
    }
}

/// Outward unit normals of a ring grid (rings along the length, closed around),
/// by central differences; the poles stand before the first ring and after the last.
fn grid_normals(grid: &[Vec<DVec3>], poles: (DVec3, DVec3)) -> Vec<Vec<DVec3>> {
    let n = grid.len();
    (0..n)
        .map(|i| {
            let m = grid[i].len();
            (0..m)
                .map(|j| {
                    let before = if i == 0 { poles.0 } else { grid[i - 1][j] };
                    let after = if i + 1 == n { poles.1 } else { grid[i + 1][j] };
                    let around = grid[i][(j + 1) % m] - grid[i][(j + m - 1) % m];
                    (after - before).cross(around).normalize_or(DVec3::Y)
                })
                .collect()
        })
        .collect()
}

/// The pocket behind a lamp's lens: the lens's block of the grid pushed inward,
/// meeting the lens at its edge; metallic, with an emitter strip in headlamps.
struct LampBowl {
    rings: std::ops::RangeInclusive<usize>,
    rows: std::ops::RangeInclusive<usize>,
    depth: f64,
    emitter: bool,
}

impl LampBowl {
    fn add_to(&self, mesh: &mut TriangleMesh, grid: &[Vec<[f64; 3]>], normals: &[Vec<DVec3>]) {
        let (i0, i1) = (*self.rings.start(), *self.rings.end());
        let (j0, j1) = (*self.rows.start(), *self.rows.end());
        // The pocket's walls rise over the outer third of the lens on each side, so
        // that the pushed-in grid does not fold where the body curves tightly.
        let edge = |k: usize, lo: usize, hi: usize| {
            smoothstep(
                0.0,
                0.34,
                (k - lo).min(hi - k) as f64 / (hi - lo).max(1) as f64,
            )
        };
        // Pushed in along the lens's mean normal, not each vertex's: an inward offset
        // along the normals would fold where the lens wraps a corner tighter than the
        // depth.
        let outward = (i0..=i1)
            .flat_map(|i| (j0..=j1).map(move |j| normals[i][j]))
            .sum::<DVec3>()
            .normalize_or(DVec3::Z);
        let patch: Vec<Vec<DVec3>> = (i0..=i1)
            .map(|i| {
                (j0..=j1)
                    .map(|j| {
                        let w = edge(i, i0, i1) * edge(j, j0, j1);
                        DVec3::from(grid[i][j]) - outward * self.depth * w
                    })
                    .collect()
            })
            .collect();
        let strip = |j: usize| {
            let f = (j - j0) as f64 / (j1 - j0).max(1) as f64;
            self.emitter && (0.62..0.8).contains(&f)
        };
        add_grid_patch(mesh, &patch, outward, |_, j| {
            if strip(j0 + j) {
                LAMP_EMITTER
            } else {
                LAMP_REFLECTOR
            }
        });
    }
}
