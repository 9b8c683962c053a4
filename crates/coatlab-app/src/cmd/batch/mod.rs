//! `coatlab batch`: many renders from one manifest, on one machine or as the
//! tasks of a cluster scheduler's array job (Slurm, Kubernetes Indexed Jobs,
//! AWS Batch), which pick their task by an environment variable. See
//! `docs/batch.md`.
//!
//! The manifest and its task order are in [`manifest`]; running a task, the
//! up-to-date check and the sidecar in [`task`]; the review deck in [`mod@report`].

pub mod manifest;
pub mod report;
pub mod task;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;

use clap::Subcommand;

use super::failure::{Classify, Failure};
use manifest::Manifest;
use task::{Outcome, run_task};

/// The environment variables a scheduler's array task finds its index in, in
/// the order they are looked at (the first set wins): Slurm job arrays,
/// Kubernetes Indexed Jobs, AWS Batch array jobs. All count from 0 here (start
/// Slurm arrays at 0: `--array=0-N`).
pub const INDEX_VARIABLES: [&str; 3] = [
    "SLURM_ARRAY_TASK_ID",
    "JOB_COMPLETION_INDEX",
    "AWS_BATCH_JOB_ARRAY_INDEX",
];

#[derive(clap::Args, Debug)]
pub struct BatchArgs {
    #[command(subcommand)]
    pub command: BatchCommand,
}

#[derive(Subcommand, Debug)]
pub enum BatchCommand {
    /// List the numbered tasks of a manifest, in their fixed order.
    Plan {
        /// The manifest (TOML, docs/batch.md).
        manifest: PathBuf,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Render task I (from --index, else SLURM_ARRAY_TASK_ID, JOB_COMPLETION_INDEX
    /// or AWS_BATCH_JOB_ARRAY_INDEX), or, without any, every task not yet done.
    Run {
        /// The manifest (TOML, docs/batch.md).
        manifest: PathBuf,
        /// The task to render (0-based; see `coatlab batch plan`).
        #[arg(long)]
        index: Option<usize>,
        /// Without an index: how many tasks render at once on this machine (each
        /// also renders its tiles on every core).
        #[arg(long, default_value_t = 2)]
        jobs: usize,
    },
    /// Write the review deck, OUTPUT/index.html: per design the renders, the
    /// readings, ΔE00 to the target per angle with pass or fail, and swatches.
    /// Tasks not rendered yet are shown as missing.
    Report {
        /// The manifest (TOML, docs/batch.md).
        manifest: PathBuf,
    },
}

pub fn run(args: &BatchArgs, out: &mut impl Write) -> anyhow::Result<()> {
    match &args.command {
        BatchCommand::Plan { manifest, json } => plan(manifest, *json, out),
        BatchCommand::Run {
            manifest,
            index,
            jobs,
        } => run_tasks(
            manifest,
            task_index(*index, |name| std::env::var(name).ok())?,
            *jobs,
            out,
        ),
        BatchCommand::Report { manifest } => {
            let summary = report::write_deck(&load(manifest)?)?;
            let compared = if summary.pass + summary.fail > 0 {
                format!("; designs: {} pass, {} fail", summary.pass, summary.fail)
            } else {
                String::new()
            };
            writeln!(
                out,
                "{}: {} tasks, {} rendered, {} missing, {} out of date{compared}",
                summary.path.display(),
                summary.tasks,
                summary.done,
                summary.missing,
                summary.out_of_date
            )?;
            Ok(())
        }
    }
}

fn load(path: &Path) -> anyhow::Result<Manifest> {
    let failure = if path.is_file() {
        Failure::Data
    } else {
        Failure::NoInput
    };
    Manifest::load(path).or_fail(failure)
}

fn plan(path: &Path, json: bool, out: &mut impl Write) -> anyhow::Result<()> {
    let manifest = load(path)?;
    let tasks = manifest.tasks();
    if json {
        let value = serde_json::json!({
            "manifest": manifest.path.display().to_string(),
            "output": manifest.output.display().to_string(),
            "quality": manifest.quality,
            "size": format!("{}x{}", manifest.size.0, manifest.size.1),
            "seed": manifest.seed,
            "image": manifest.image,
            "target": manifest.target.as_ref().map(|t| t.display().to_string()),
            "tasks": tasks,
        });
        serde_json::to_writer_pretty(&mut *out, &value).or_fail(Failure::Io)?;
        writeln!(out)?;
        return Ok(());
    }
    writeln!(
        out,
        "{}: {} tasks ({} designs × {} views × {} lighting × {} models), quality {} \
         ({} spp, {} wavelengths), {}x{}, seed {}, into {}",
        manifest.path.display(),
        tasks.len(),
        manifest.designs.len(),
        manifest.views.len(),
        manifest.lighting.len(),
        manifest.models.len(),
        manifest.quality.label,
        manifest.quality.samples_per_pixel,
        manifest.quality.wavelengths,
        manifest.size.0,
        manifest.size.1,
        manifest.seed,
        manifest.output.display(),
    )?;
    writeln!(out, "index  output")?;
    for task in &tasks {
        writeln!(out, "{:>5}  {}", task.index, task.output)?;
    }
    Ok(())
}

/// The task to run: `--index`, else the first of [`INDEX_VARIABLES`] that
/// `env` has, with where it came from; `None` when none is given.
pub fn task_index(
    flag: Option<usize>,
    env: impl Fn(&str) -> Option<String>,
) -> anyhow::Result<Option<(usize, String)>> {
    if let Some(index) = flag {
        return Ok(Some((index, "--index".into())));
    }
    for name in INDEX_VARIABLES {
        if let Some(value) = env(name) {
            let index = value.trim().parse().map_err(|_| {
                Failure::Usage.error(format!(
                    "{name}='{value}': not a task index (a whole number from 0)"
                ))
            })?;
            return Ok(Some((index, name.to_owned())));
        }
    }
    Ok(None)
}

fn run_tasks(
    path: &Path,
    index: Option<(usize, String)>,
    jobs: usize,
    out: &mut impl Write,
) -> anyhow::Result<()> {
    let manifest = load(path)?;
    let tasks = manifest.tasks();
    if let Some((index, source)) = index {
        let task = tasks.get(index).ok_or_else(|| {
            Failure::Usage.error(format!(
                "{source} {index}: out of range: {} has {} tasks, 0 to {}",
                manifest.path.display(),
                tasks.len(),
                tasks.len() - 1
            ))
        })?;
        let outcome = run_task(&manifest, task).with_context_task(task.index, &task.output)?;
        report(out, task.index, tasks.len(), &task.output, &outcome)?;
        return Ok(());
    }
    if jobs == 0 {
        return Err(Failure::Usage.error("--jobs 0: at least one task at a time"));
    }
    // Workers take the next task in order; every task runs even when one fails.
    // Each outcome is printed as it comes (a long run shows its progress), and
    // the failures are summed up at the end.
    let next = AtomicUsize::new(0);
    let mut failed = Vec::new();
    std::thread::scope(|scope| -> anyhow::Result<()> {
        let (send, receive) = mpsc::channel();
        for _ in 0..jobs.min(tasks.len()) {
            let send = send.clone();
            let (next, tasks, manifest) = (&next, &tasks, &manifest);
            scope.spawn(move || {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(task) = tasks.get(i) else { break };
                    if send.send((i, run_task(manifest, task))).is_err() {
                        break;
                    }
                }
            });
        }
        drop(send);
        for (i, result) in receive {
            let task = &tasks[i];
            match result {
                Ok(outcome) => report(out, i, tasks.len(), &task.output, &outcome)?,
                Err(error) => {
                    writeln!(
                        out,
                        "task {i}/{} {}: failed: {error:#}",
                        tasks.len(),
                        task.output
                    )?;
                    failed.push((i, error));
                }
            }
            out.flush()?;
        }
        Ok(())
    })?;
    failed.sort_by_key(|(i, _)| *i);
    match failed.into_iter().next() {
        None => Ok(()),
        Some((i, error)) => Err(error.context(format!(
            "task {i} ({}) failed (and any listed above)",
            tasks[i].output
        ))),
    }
}

fn report(
    out: &mut impl Write,
    index: usize,
    count: usize,
    output: &str,
    outcome: &Outcome,
) -> anyhow::Result<()> {
    match outcome {
        Outcome::Skipped => writeln!(out, "task {index}/{count} {output}: up to date, skipped")?,
        Outcome::Rendered { seconds } => writeln!(
            out,
            "task {index}/{count} {output}: rendered in {seconds:.1} s"
        )?,
    }
    Ok(())
}

/// Names the task in a task's error.
trait TaskContext<T> {
    fn with_context_task(self, index: usize, output: &str) -> anyhow::Result<T>;
}

impl<T> TaskContext<T> for anyhow::Result<T> {
    fn with_context_task(self, index: usize, output: &str) -> anyhow::Result<T> {
        self.map_err(|e| e.context(format!("task {index} ({output})")))
    }
}
