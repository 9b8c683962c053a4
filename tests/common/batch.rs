//! What the batch tests share: a small manifest and the binary run without any
//! scheduler's index variable from the test's own environment.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The scheduler variables `batch run` reads its index from.
const INDEX_VARIABLES: [&str; 3] = [
    "SLURM_ARRAY_TASK_ID",
    "JOB_COMPLETION_INDEX",
    "AWS_BATCH_JOB_ARRAY_INDEX",
];

/// `review.toml` in `dir`: the signal red and deep blue designs, studio and
/// booth-d65 lighting, 2 spp on 4 wavelengths into `deck/`, then `lines`.
pub fn write_manifest(dir: &Path, lines: &str) -> PathBuf {
    let path = dir.join("review.toml");
    std::fs::write(
        &path,
        format!(
            r#"format = "coatlab-batch"
version = 1
output = "deck"
designs = ["signal-red.toml", "deep-blue.toml"]
lighting = ["studio", "booth-d65"]
spp = 2
wavelengths = 4
{lines}
"#
        ),
    )
    .expect("write the manifest");
    path
}

/// `coatlab args` with `env` set and no other scheduler index in its environment.
pub fn coatlab_batch(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_coatlab"));
    command.args(args);
    for name in INDEX_VARIABLES {
        command.env_remove(name);
    }
    command.envs(env.iter().copied());
    command.output().expect("coatlab runs")
}
