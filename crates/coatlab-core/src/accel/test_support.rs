//! Inputs for the accel's unit tests.

use super::boxes::Bounds;

/// Marsaglia's xorshift64: reproducible numbers without a dependency.
pub(super) struct XorShift(pub u64);

impl XorShift {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// Uniform in [0, 1), 24 bits.
    pub fn uniform(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// Long thin triangles in every direction, crossing in a unit cube (the kind the
/// spatial pass splits), and their boxes.
pub(super) fn slivers(count: usize) -> (Vec<[[f32; 3]; 3]>, Vec<Bounds>) {
    let mut rng = XorShift(0x9e37_79b9_7f4a_7c15);
    let triangles: Vec<[[f32; 3]; 3]> = (0..count)
        .map(|_| {
            let a: [f32; 3] = std::array::from_fn(|_| rng.uniform());
            let b: [f32; 3] = std::array::from_fn(|_| rng.uniform());
            let c: [f32; 3] = std::array::from_fn(|k| a[k] + 0.01 * rng.uniform());
            [a, b, c]
        })
        .collect();
    let boxes = triangles
        .iter()
        .filter_map(|t| Bounds::from_points(t))
        .collect();
    (triangles, boxes)
}

/// Runs `check` compiled for `path` where the CPU has it, else says it is skipped.
pub(super) fn on_path(path: crate::simd_path::SimdPath, check: fn()) {
    if !path.is_available() {
        println!("no {} on this CPU: skipped", path.name());
        return;
    }
    crate::simd_path::dispatch!(path, _ => check());
}
