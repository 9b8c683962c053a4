//! The preview's render threads run at a lower OS priority than the window.
//!
//! The path tracer keeps every core busy for as long as the picture converges; the
//! window's own thread and, on a machine without a GPU, the software rasteriser's
//! threads (Mesa's lavapipe draws each frame on the CPU) need only a few
//! milliseconds a frame but need them *now*. At equal priority the scheduler shares
//! the cores evenly and a frame waits behind the renderer's time slices; with the
//! render threads niced, the window's work runs first and the renderer takes the
//! rest, losing only what the window actually uses.
//!
//! [`install_render_pool`] builds rayon's global pool (the tracer's tiles, the film's
//! conversion, the ΔE00 map) with its threads niced and named `coatlab-render-N`;
//! [`lower_render_thread`] is the live engine's thread hook: the engine's own
//! threads (the render thread, the second view's shading) call it when they start.
//! Both apply only once [`install_render_pool`] enabled them (the window does; the
//! headless tests and benches leave every thread at normal priority).
//!
//! Linux only (`setpriority` on a thread id); elsewhere these do nothing.

use std::sync::atomic::{AtomicI32, Ordering};

/// The nice value of the render threads in the window: 10 gives a thread about a
/// tenth of the CPU weight of a normal one (the kernel's weights 110 against 1024),
/// so the window wins a contended core ~9 times in 10, and an idle core still runs
/// the renderer at full speed.
pub const RENDER_NICE: i32 = 10;

/// The nice value render threads take when they start; 0 until enabled.
static ENABLED_NICE: AtomicI32 = AtomicI32::new(0);

/// Builds rayon's global pool with its threads at `nice` and makes the preview's
/// threads ([`lower_render_thread`]) take it too. Call before anything uses rayon.
/// Returns why not, if the pool already existed (then it keeps normal priority).
pub fn install_render_pool(nice: i32) -> Result<(), String> {
    ENABLED_NICE.store(nice, Ordering::Relaxed);
    render_pool_builder(nice)
        .build_global()
        .map_err(|e| format!("the render threads keep normal priority: {e}"))
}

/// A rayon pool builder whose threads are named `coatlab-render-N` and set
/// themselves to `nice` when they start.
pub fn render_pool_builder(nice: i32) -> rayon::ThreadPoolBuilder {
    rayon::ThreadPoolBuilder::new()
        .thread_name(|i| format!("coatlab-render-{i}"))
        .start_handler(move |_| {
            if let Err(e) = set_current_thread_nice(nice) {
                eprintln!("coatlab: render thread keeps normal priority: {e}");
            }
        })
}

/// Lowers the calling thread to the render threads' priority, if enabled.
pub fn lower_render_thread() {
    let nice = ENABLED_NICE.load(Ordering::Relaxed);
    if nice != 0
        && let Err(e) = set_current_thread_nice(nice)
    {
        eprintln!("coatlab: render thread keeps normal priority: {e}");
    }
}

/// Sets the calling thread's nice value (Linux: per thread, by its id).
#[cfg(target_os = "linux")]
pub fn set_current_thread_nice(nice: i32) -> std::io::Result<()> {
    // SAFETY: gettid has no preconditions; setpriority only reads its arguments.
    let result = unsafe {
        let tid = libc::gettid();
        libc::setpriority(libc::PRIO_PROCESS, tid as libc::id_t, nice)
    };
    if result == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error())
    }
}

/// Elsewhere the threads keep their priority.
#[cfg(not(target_os = "linux"))]
pub fn set_current_thread_nice(_nice: i32) -> std::io::Result<()> {
    Ok(())
}

/// The calling thread's nice value, from `/proc/thread-self/stat` (field 19).
#[cfg(target_os = "linux")]
pub fn current_thread_nice() -> std::io::Result<i32> {
    let stat = std::fs::read_to_string("/proc/thread-self/stat")?;
    // "tid (comm) state ...": fields after the last ')' start at field 3.
    let after = stat.rfind(')').map(|i| &stat[i + 1..]).unwrap_or("");
    after
        .split_whitespace()
        .nth(19 - 3)
        .and_then(|f| f.parse().ok())
        .ok_or_else(|| std::io::Error::other(format!("no nice field in {stat:?}")))
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    #[test]
    fn a_lowered_thread_reports_its_nice_value() {
        let nice = std::thread::spawn(|| {
            let before = current_thread_nice().expect("nice before");
            set_current_thread_nice(before + 3).expect("setpriority");
            (before, current_thread_nice().expect("nice after"))
        })
        .join()
        .expect("thread");
        assert_eq!(nice.1, nice.0 + 3, "before {} after {}", nice.0, nice.1);
        // Only that thread changed: this one keeps its own.
        assert_eq!(current_thread_nice().expect("nice here"), nice.0);
    }

    #[test]
    fn render_pool_threads_run_at_the_render_priority_and_the_caller_does_not() {
        let caller = current_thread_nice().expect("caller's nice");
        let pool = render_pool_builder(caller + RENDER_NICE)
            .num_threads(2)
            .build()
            .expect("pool");
        let (name, nice) = pool.install(|| {
            (
                std::thread::current().name().map(str::to_owned),
                current_thread_nice().expect("worker's nice"),
            )
        });
        assert_eq!(nice, (caller + RENDER_NICE).min(19));
        assert!(
            name.as_deref()
                .is_some_and(|n| n.starts_with("coatlab-render-")),
            "{name:?}"
        );
        assert_eq!(current_thread_nice().expect("caller's nice after"), caller);
    }
}
