//! Framing and views on the real test cars (`shared/testdata/gltf`, read in place)
//! and the built-in car: the default view fills the frame with the car, nose
//! toward the camera; each named view looks from its side; the file's cameras.

use coatlab_core::accel::Accel;
use coatlab_core::render::camera::Camera;
use coatlab_core::render::camera::{FRAMING_AZIMUTH_DEG, FRAMING_ELEVATION_DEG};
use coatlab_core::render::view::{
    NamedView, SceneFraming, Turntable, ViewChoice, ViewError, ViewParseError, ViewSpec,
};
use coatlab_core::scene::Scene;
use coatlab_core::scene::car::{CarParameters, generate};
use coatlab_core::scene::framing::car_triangles;
use coatlab_core::scene::gltf_loader::{LoadOptions, load};
use glam::{DVec3, Vec3};

#[path = "support/gltf_testdata.rs"]
mod gltf_testdata;
use gltf_testdata::testdata;

/// A test car, and where its nose points in its file, as seen on renders of it
/// (the Lamborghini's front splitter and the rear wing, the ToyCar's headlamps
/// and tail fins, the milk truck's cab and box): an answer the loader's heuristic
/// must reproduce, not one taken from it.
struct TestCar {
    name: &'static str,
    scene: Scene,
    nose_in_file: DVec3,
}

fn cars() -> Vec<TestCar> {
    let mut cars = vec![TestCar {
        name: "built-in car",
        scene: generate(&CarParameters::default()),
        nose_in_file: DVec3::Z,
    }];
    let Some(dir) = testdata() else {
        return cars;
    };
    // The Lamborghini is yawed about 43.6° in its file, nose toward +x +z.
    let lamborghini = DVec3::new(0.724, 0.0, 0.690).normalize();
    for (name, rel, nose_in_file) in [
        (
            "Lamborghini",
            "LamborghiniHuracanGT3/LamborghiniHuracanGT3.glb",
            lamborghini,
        ),
        ("ToyCar", "ToyCar/ToyCar.gltf", DVec3::Z),
        (
            "CesiumMilkTruck",
            "CesiumMilkTruck/CesiumMilkTruck.glb",
            DVec3::Z,
        ),
    ] {
        let scene =
            load(&dir.join(rel), &LoadOptions::default()).unwrap_or_else(|e| panic!("{rel}: {e}"));
        cars.push(TestCar {
            name,
            scene,
            nose_in_file,
        });
    }
    cars
}

/// Continuous pixel coordinates of a world point, and its depth along the view.
fn project(camera: &Camera, point: Vec3) -> (f32, f32, f32) {
    let forward = Vec3::from(camera.forward());
    let right = forward.cross(Vec3::from(camera.up())).normalize();
    let up = right.cross(forward);
    let o = point - Vec3::from(camera.position());
    let depth = o.dot(forward);
    let tan_v = (0.5 * camera.vertical_fov_deg().to_radians()).tan();
    let (w, h) = (camera.width() as f32, camera.height() as f32);
    let tan_h = tan_v * w / h;
    let x = (o.dot(right) / depth / tan_h + 1.0) * 0.5 * w;
    let y = (1.0 - o.dot(up) / depth / tan_v) * 0.5 * h;
    (x, y, depth)
}

/// The car's vertices (by `scene::framing`'s rule).
fn car_points(scene: &Scene) -> Vec<Vec3> {
    let car = car_triangles(&scene.mesh, &scene.paint_materials);
    scene
        .mesh
        .triangles
        .iter()
        .zip(car)
        .filter(|(_, car)| *car)
        .flat_map(|(t, _)| t.map(|v| Vec3::from(scene.mesh.positions[v as usize])))
        .collect()
}

/// The projected box of `points`: (min x, max x, min y, max y), pixels.
fn projected_box(camera: &Camera, points: &[Vec3]) -> (f32, f32, f32, f32) {
    points.iter().fold(
        (f32::MAX, f32::MIN, f32::MAX, f32::MIN),
        |(x0, x1, y0, y1), p| {
            let (x, y, depth) = project(camera, *p);
            assert!(depth > 0.0, "a point of the car is behind the camera");
            (x0.min(x), x1.max(x), y0.min(y), y1.max(y))
        },
    )
}

#[test]
fn the_loader_finds_each_test_cars_nose() {
    for car in cars() {
        let found = DVec3::from(car.scene.orientation.front_in_file);
        assert!(
            found.dot(car.nose_in_file) > 0.999,
            "{}: the loader took {found:?} for the nose ({})",
            car.name,
            car.scene.orientation.reason
        );
        assert_eq!(
            car.scene.orientation.up_in_file,
            [0.0, 1.0, 0.0],
            "{}",
            car.name
        );
    }
}

/// The framing test: from the default view the car's projected box fills
/// 60–90 % of the frame's width, the whole car is in the frame, and the front faces
/// the camera (the nose nearer than the tail), in wide frames and in the tall
/// panes of a side-by-side comparison alike.
#[test]
fn the_default_view_frames_the_car_nose_first() {
    for car in cars() {
        let framing = SceneFraming::new(&car.scene);
        let points = car_points(&car.scene);
        // Wide, and the tall panes of the preview's side-by-side comparison
        // (316×400 at its largest, narrower in a narrow window).
        for (w, h) in [(960, 540), (320, 180), (800, 600), (316, 400), (200, 400)] {
            let camera = framing
                .camera(&ViewChoice::default(), w, h)
                .expect("the default view");
            let (x0, x1, y0, y1) = projected_box(&camera, &points);
            let fill = (x1 - x0) / w as f32;
            assert!(
                (0.6..=0.9).contains(&fill),
                "{} at {w}x{h}: the car fills {:.0} % of the width",
                car.name,
                100.0 * fill
            );
            assert!(
                x0 >= 0.0 && x1 <= w as f32 && y0 >= 0.0 && y1 <= h as f32,
                "{} at {w}x{h}: the car leaves the frame: x {x0}..{x1}, y {y0}..{y1}",
                car.name
            );
            let (lo, hi) = framing.car_bounds().unwrap();
            let centre = 0.5 * (Vec3::from(lo) + Vec3::from(hi));
            let nose = Vec3::new(centre.x, centre.y, hi[2]);
            let tail = Vec3::new(centre.x, centre.y, lo[2]);
            let (nose_depth, tail_depth) = (project(&camera, nose).2, project(&camera, tail).2);
            assert!(
                nose_depth < tail_depth,
                "{}: nose at depth {nose_depth}, tail at {tail_depth}",
                car.name
            );
        }
    }
}

/// ToyCar's cloth drape is four times the car's size: framed on the car, the car
/// still fills the frame (it filled about half of it when the scene was framed).
#[test]
fn the_drape_is_not_the_car() {
    let Some(dir) = testdata() else { return };
    let scene = load(&dir.join("ToyCar/ToyCar.gltf"), &LoadOptions::default()).unwrap();
    let framing = SceneFraming::new(&scene);
    let (lo, hi) = framing.car_bounds().unwrap();
    let (scene_lo, scene_hi) = scene.mesh.bounds().unwrap();
    // The car alone is about 0.0187 × 0.0384 m in a 0.073 × 0.074 m scene.
    let car_length = hi[2] - lo[2];
    let scene_length = scene_hi[2] - scene_lo[2];
    assert!(
        (car_length / scene_length - 0.0384 / 0.074).abs() < 0.03,
        "car {lo:?}..{hi:?} in {scene_lo:?}..{scene_hi:?}"
    );
    assert!(
        (hi[0] - lo[0]) / car_length < 0.55,
        "the car's width {lo:?}..{hi:?}"
    );
}

#[test]
fn each_named_view_looks_from_its_side() {
    for car in cars() {
        let framing = SceneFraming::new(&car.scene);
        let (lo, hi) = framing.car_bounds().unwrap();
        let (lo, hi) = (Vec3::from(lo), Vec3::from(hi));
        let centre = 0.5 * (lo + hi);
        let points = car_points(&car.scene);
        let (w, h) = (640, 360);
        let default = framing.named(NamedView::FrontThreeQuarter, w, h);
        for view in NamedView::ALL {
            let camera = framing.named(view, w, h);
            // The camera's place seen from the car's centre, as a unit vector:
            // x toward the car's left, y up, z toward the nose.
            let from = (Vec3::from(camera.position()) - centre).normalize();
            let what = format!("{}: {view}: from {from:?}", car.name);
            let ok = match view {
                NamedView::FrontThreeQuarter => from.x > 0.3 && from.z > 0.3 && from.y > 0.1,
                NamedView::RearThreeQuarter => from.x > 0.3 && from.z < -0.3 && from.y > 0.1,
                NamedView::Side => from.x > 0.95,
                NamedView::Front => from.z > 0.95,
                NamedView::Rear => from.z < -0.95,
                NamedView::Top => from.y > 0.99,
                NamedView::CloseUp => from.x > 0.5 && from.z > 0.0,
            };
            assert!(ok, "{what}");
            if view == NamedView::CloseUp {
                // Nearer than the default, looking at the left flank.
                let distance =
                    |c: &Camera| (Vec3::from(c.position()) - Vec3::from(c.look_at())).length();
                assert!(distance(&camera) < 0.6 * distance(&default), "{what}");
                assert!(
                    camera.look_at()[0] > centre.x + 0.3 * (hi.x - lo.x),
                    "{what}"
                );
                continue;
            }
            let (x0, x1, y0, y1) = projected_box(&camera, &points);
            assert!(
                x0 >= 0.0 && x1 <= w as f32 && y0 >= 0.0 && y1 <= h as f32,
                "{what}: the car leaves the frame"
            );
            // Fitted: the tighter axis is filled to the framing's 85 %.
            let fill = ((x1 - x0) / w as f32).max((y1 - y0) / h as f32);
            assert!((0.8..=0.86).contains(&fill), "{what}: fills {fill}");
        }
        // Straight down, the nose is up the image.
        let top = framing.named(NamedView::Top, w, h);
        let nose = project(&top, Vec3::new(centre.x, centre.y, hi.z));
        let tail = project(&top, Vec3::new(centre.x, centre.y, lo.z));
        assert!(nose.1 < tail.1, "{}: top view upside down", car.name);
    }
}

#[test]
fn the_free_camera_is_placed_as_asked() {
    let scene = generate(&CarParameters::default());
    let framing = SceneFraming::new(&scene);
    let (lo, hi) = framing.car_bounds().unwrap();
    let centre = 0.5 * (Vec3::from(lo) + Vec3::from(hi));
    let choice: ViewChoice = "90,30,10,50".parse().unwrap();
    let camera = framing.camera(&choice, 320, 180).unwrap();
    let offset = Vec3::from(camera.position()) - centre;
    assert!((offset.length() - 10.0).abs() < 1e-3);
    // Yaw 90° from the nose toward the left is +x; pitch 30° up.
    let expected = Vec3::new(30f32.to_radians().cos(), 30f32.to_radians().sin(), 0.0);
    assert!((offset / 10.0 - expected).length() < 1e-4, "{offset:?}");
    assert_eq!(camera.vertical_fov_deg(), 50.0);
    assert_eq!(Vec3::from(camera.look_at()), centre);
}

/// A turntable's cameras stand on one orbit around the car's centre: one distance,
/// one elevation, azimuths at equal steps of 360°/N from the front three-quarter's,
/// each looking at the centre with the whole car in its frame.
#[test]
fn a_turntable_circles_the_car_in_equal_steps() {
    let scene = generate(&CarParameters::default());
    let framing = SceneFraming::new(&scene);
    let points = car_points(&scene);
    let (lo, hi) = framing.car_bounds().unwrap();
    let centre = 0.5 * (Vec3::from(lo) + Vec3::from(hi));
    let (w, h) = (320, 180);
    let turntable = Turntable::new(8).unwrap();
    let spec: ViewSpec = "turntable:8".parse().unwrap();
    assert_eq!(spec, ViewSpec::Turntable(turntable));
    assert_eq!(spec.frames().len(), 8);
    let cameras: Vec<Camera> = spec
        .frames()
        .into_iter()
        .map(|f| framing.view(f, w, h))
        .collect();
    let distance = (Vec3::from(cameras[0].position()) - centre).length();
    for (k, camera) in cameras.iter().enumerate() {
        let offset = Vec3::from(camera.position()) - centre;
        assert!(
            (offset.length() - distance).abs() < 1e-3 * distance,
            "frame {k}"
        );
        assert_eq!(Vec3::from(camera.look_at()), centre, "frame {k}");
        let elevation = (offset.y / offset.length()).asin().to_degrees();
        assert!(
            (elevation - FRAMING_ELEVATION_DEG).abs() < 1e-2,
            "frame {k}: {elevation}"
        );
        // Azimuth from +Z toward +X.
        let azimuth = offset.x.atan2(offset.z).to_degrees();
        let expected = FRAMING_AZIMUTH_DEG + 45.0 * k as f32;
        let step = (azimuth - expected).rem_euclid(360.0);
        assert!(
            step.min(360.0 - step) < 1e-2,
            "frame {k}: azimuth {azimuth}°"
        );
        let (x0, x1, y0, y1) = projected_box(camera, &points);
        assert!(
            x0 >= 0.0 && y0 >= 0.0 && x1 <= w as f32 && y1 <= h as f32,
            "frame {k}: the car leaves the frame ({x0}, {x1}, {y0}, {y1})"
        );
    }
    // The tightest frame is filled as a named view is: the distance is no larger
    // than the turn needs.
    let widest = cameras
        .iter()
        .map(|c| {
            let (x0, x1, y0, y1) = projected_box(c, &points);
            ((x1 - x0) / w as f32).max((y1 - y0) / h as f32)
        })
        .fold(0.0, f32::max);
    assert!(
        widest > 0.75,
        "the turntable's fullest frame is {widest:.2} of the image"
    );
    // One frame by itself is the same camera as in the whole turn.
    let third: ViewSpec = "turntable:8:3".parse().unwrap();
    assert_eq!(framing.view(third, w, h), cameras[3]);
}

#[test]
fn bad_turntables_are_refused_naming_the_value() {
    for (text, expected) in [
        (
            "turntable:0",
            "'turntable:0': 0 frames: a turntable takes 1 to 360",
        ),
        ("turntable:361", "361 frames: a turntable takes 1 to 360"),
        ("turntable:x", "'turntable:x': N 'x' is not a whole number"),
        ("turntable:-3", "N '-3' is not a whole number"),
        (
            "turntable:8:8",
            "'turntable:8:8': frame 8 of 8: the frames are 0 to 7",
        ),
        ("turntable:", "N '' is not a whole number"),
    ] {
        let error = text.parse::<ViewSpec>().unwrap_err();
        assert!(matches!(error, ViewParseError::OutOfRange { .. }), "{text}");
        assert!(error.to_string().contains(expected), "{text}: {error}");
    }
    let unknown = "spin".parse::<ViewSpec>().unwrap_err().to_string();
    assert_eq!(
        unknown,
        "'spin' is not a view: use front-34, rear-34, side, front, rear, top, closeup or turntable:N"
    );
    for spec in ["side", "turntable:12", "turntable:12:11"] {
        assert_eq!(spec.parse::<ViewSpec>().unwrap().to_string(), spec);
    }
}

/// `--camera gltf:N`: ToyCar's cameras, carried through the loader's transform,
/// still look at the car: the ray through the image centre of each hits it.
#[test]
fn the_files_cameras_see_the_car() {
    let Some(dir) = testdata() else { return };
    let scene = load(&dir.join("ToyCar/ToyCar.gltf"), &LoadOptions::default()).unwrap();
    assert_eq!(scene.cameras.len(), 8);
    assert_eq!(scene.cameras[1].name, "Camera002");
    // yfov 0.41 rad in the file.
    assert!((scene.cameras[1].vertical_fov_deg - 0.41f32.to_degrees()).abs() < 1e-3);
    let framing = SceneFraming::new(&scene);
    let accel = Accel::build(&scene.mesh).unwrap();
    let car = car_triangles(&scene.mesh, &scene.paint_materials);
    let mut sees_the_car = 0;
    for (index, file_camera) in scene.cameras.iter().enumerate() {
        let camera = framing
            .camera(&ViewChoice::SceneCamera(index), 320, 180)
            .unwrap();
        assert_eq!(camera.position(), file_camera.position);
        assert_eq!(camera.vertical_fov_deg(), file_camera.vertical_fov_deg);
        let (origin, direction) = camera.ray(160.0, 90.0);
        let hit = accel
            .closest_hit(origin, direction, 1e3)
            .unwrap_or_else(|| panic!("camera {index} looks at nothing"));
        if car[hit.triangle as usize] {
            sees_the_car += 1;
        }
        // Upright: the image's up has a positive world y.
        assert!(camera.up()[1] > 0.0, "camera {index}: {:?}", camera.up());
    }
    // Most of the file's cameras are aimed at the car (some at the drape beside it).
    assert!(
        sees_the_car >= 5,
        "{sees_the_car} of 8 cameras look at the car"
    );
    assert!(matches!(
        framing.camera(&ViewChoice::SceneCamera(8), 320, 180),
        Err(ViewError::NoSuchCamera { index: 8, count: 8 })
    ));
    // The built-in car has none.
    let built_in = SceneFraming::new(&generate(&CarParameters::default()));
    assert!(matches!(
        built_in.camera(&ViewChoice::SceneCamera(0), 320, 180),
        Err(ViewError::NoSuchCamera { index: 0, count: 0 })
    ));
}
