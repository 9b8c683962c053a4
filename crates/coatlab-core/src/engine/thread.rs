//! The engine on a render thread of its own: commands in over a channel, images
//! and events out through a mailbox the UI reads when it draws.
//!
//! The UI never waits on the renderer. [`EngineThread::send`] numbers the command
//! (its *epoch*) and raises a cancel flag so a pass in flight stops at its next
//! tile; the thread takes every waiting command, steps the engine, and posts
//! what it publishes, stamped with the last epoch taken, so the UI can tell
//! which change an image already shows. When the engine has nothing to do it
//! waits for the next command.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, TryRecvError, channel};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;

use crate::design::PaintDesign;

use super::ThreadHook;
use super::backend::RenderBackend;
use super::command::Command;
use super::cpu::CpuBackend;
use super::delta_e::DeltaEMap;
use super::events::{EngineEvent, SceneInfo};
use super::frame::{Frame, SecondUpdate, ViewsUpdate};
use super::live::{LiveEngine, Output, Progress};

/// Work run on the render thread between two steps, with the engine as it
/// stands (an export of its films); what it returns is posted as an event.
pub type Job<B> = Box<dyn FnOnce(&LiveEngine<B>) -> Option<EngineEvent> + Send>;

/// What the app gives the engine's threads.
#[derive(Clone)]
pub struct ThreadHooks {
    /// Called first on every thread the engine starts (the render thread, the
    /// second view's shading): the app lowers their priority here.
    pub on_start: ThreadHook,
    /// Called after something was posted to the mailbox: the app asks for a
    /// repaint here.
    pub on_post: ThreadHook,
}

impl Default for ThreadHooks {
    fn default() -> Self {
        Self {
            on_start: Arc::new(|| {}),
            on_post: Arc::new(|| {}),
        }
    }
}

/// What the render thread posted and the UI has not taken yet.
#[derive(Debug, Default)]
pub struct Mailbox {
    /// The views' latest images.
    pub frames: [Option<Frame>; 2],
    /// Whether `frames` changed since the UI last took them.
    pub fresh: bool,
    /// The latest ΔE00 map between the views.
    pub delta_e: Option<DeltaEMap>,
    /// Whether `delta_e` changed since the UI last took it.
    pub fresh_map: bool,
    /// The scene being rendered, when it changed.
    pub scene: Option<SceneInfo>,
    /// What happened, in order.
    pub events: Vec<EngineEvent>,
}

impl Mailbox {
    fn post(&mut self, output: Output, epoch: u64) {
        match output {
            Output::Views(mut update) => {
                update.frames_mut().for_each(|f| f.epoch = epoch);
                self.take_update(update);
            }
            Output::Event(event) => {
                if let EngineEvent::SceneLoaded(info) = &event {
                    self.scene = Some(info.clone());
                }
                self.events.push(event);
            }
        }
    }

    fn take_update(&mut self, update: ViewsUpdate) {
        self.frames[0] = Some(update.first);
        match update.second {
            SecondUpdate::Keep => {}
            SecondUpdate::Clear => self.frames[1] = None,
            SecondUpdate::Set(frame) => self.frames[1] = Some(frame),
        }
        self.fresh = true;
        if let Some(map) = update.map {
            self.delta_e = map;
            self.fresh_map = true;
        }
    }

    /// The images shown now show every change up to `epoch` (nothing in it
    /// changed the picture).
    fn restamp(&mut self, epoch: u64) {
        for frame in self.frames.iter_mut().flatten() {
            frame.epoch = epoch;
        }
        self.fresh = true;
    }
}

enum Message<B: RenderBackend> {
    Command(Command),
    Job(Job<B>),
}

/// A message with the number of the last picture-changing command sent with or
/// before it.
struct Envelope<B: RenderBackend> {
    epoch: u64,
    message: Message<B>,
}

/// The UI's handle on an engine running on its own thread.
pub struct EngineThread<B: RenderBackend + 'static = CpuBackend> {
    messages: Sender<Envelope<B>>,
    cancel: Arc<AtomicBool>,
    mailbox: Arc<Mutex<Mailbox>>,
    thread: Option<JoinHandle<()>>,
    epoch: u64,
}

impl<B: RenderBackend + 'static> EngineThread<B> {
    /// Starts the render thread on `design` (see [`LiveEngine::new`]); an engine
    /// that cannot start posts why and ends.
    pub fn spawn(backend: B, design: PaintDesign, hooks: ThreadHooks) -> Self {
        let (messages, receiver) = channel();
        let cancel = Arc::new(AtomicBool::new(false));
        let mailbox = Arc::new(Mutex::new(Mailbox::default()));
        let worker = Worker {
            messages: receiver,
            cancel: cancel.clone(),
            mailbox: mailbox.clone(),
            hooks: hooks.clone(),
            epoch: 0,
        };
        let thread = std::thread::Builder::new()
            .name("coatlab-preview".into())
            .spawn(move || {
                (hooks.on_start)();
                worker.run(backend, design);
            })
            .ok();
        Self {
            messages,
            cancel,
            mailbox,
            thread,
            epoch: 0,
        }
    }

    /// Sends a picture-changing command and stops the pass in flight, so the
    /// thread takes it at once. Returns its epoch.
    pub fn send(&mut self, command: Command) -> u64 {
        self.epoch += 1;
        self.cancel.store(true, Ordering::Relaxed);
        self.post(Message::Command(command));
        self.epoch
    }

    /// Runs `job` on the render thread after the pass in flight (which it does
    /// not stop: an export keeps the samples).
    pub fn run_job(&mut self, job: Job<B>) {
        self.post(Message::Job(job));
    }

    fn post(&mut self, message: Message<B>) {
        // A closed channel means the thread ended (and said why).
        let _ = self.messages.send(Envelope {
            epoch: self.epoch,
            message,
        });
    }

    /// The number of the last picture-changing command sent.
    pub fn epoch(&self) -> u64 {
        self.epoch
    }

    /// What the thread posted; take what you need while holding it.
    pub fn mailbox(&self) -> MutexGuard<'_, Mailbox> {
        self.mailbox.lock().unwrap_or_else(|p| p.into_inner())
    }
}

impl<B: RenderBackend + 'static> Drop for EngineThread<B> {
    fn drop(&mut self) {
        // Closing the channel ends the thread; the cancel flag ends its pass.
        self.cancel.store(true, Ordering::Relaxed);
        let (closed, _) = channel();
        drop(std::mem::replace(&mut self.messages, closed));
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// The render thread's side.
struct Worker<B: RenderBackend> {
    messages: Receiver<Envelope<B>>,
    cancel: Arc<AtomicBool>,
    mailbox: Arc<Mutex<Mailbox>>,
    hooks: ThreadHooks,
    /// The last epoch taken.
    epoch: u64,
}

impl<B: RenderBackend> Worker<B> {
    fn run(mut self, backend: B, design: PaintDesign) {
        let mut engine = match LiveEngine::new(backend, design, self.hooks.on_start.clone()) {
            Ok(engine) => engine,
            Err(e) => return self.post(Output::Event(EngineEvent::Failed(e))),
        };
        self.mailbox().scene = Some(engine.scene_info().clone());
        // The epoch the mailbox's images show.
        let mut shown = 0;
        loop {
            let Some(batch) = self.next_batch(engine.is_idle()) else {
                return;
            };
            self.cancel.store(false, Ordering::Relaxed);
            for Envelope { epoch, message } in batch {
                self.epoch = self.epoch.max(epoch);
                match message {
                    Message::Command(command) => engine.apply(command, &mut |o| self.post(o)),
                    Message::Job(job) => {
                        if let Some(event) = job(&engine) {
                            self.post(Output::Event(event));
                        }
                    }
                }
            }
            let mut published = false;
            let progress = engine.step(&self.cancel, &mut |o| {
                published |= matches!(o, Output::Views(_));
                self.post(o);
            });
            if published {
                shown = self.epoch;
            } else if progress == Progress::Idle && shown < self.epoch {
                // Commands that changed nothing: the images show them already.
                self.mailbox().restamp(self.epoch);
                (self.hooks.on_post)();
                shown = self.epoch;
            }
        }
    }

    /// The messages waiting; with `wait`, blocks for the first. `None` once the
    /// handle is gone.
    fn next_batch(&self, wait: bool) -> Option<Vec<Envelope<B>>> {
        let mut batch = Vec::new();
        if wait {
            batch.push(self.messages.recv().ok()?);
        }
        loop {
            match self.messages.try_recv() {
                Ok(envelope) => batch.push(envelope),
                Err(TryRecvError::Empty) => return Some(batch),
                Err(TryRecvError::Disconnected) => return None,
            }
        }
    }

    fn mailbox(&self) -> MutexGuard<'_, Mailbox> {
        self.mailbox.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn post(&self, output: Output) {
        self.mailbox().post(output, self.epoch);
        (self.hooks.on_post)();
    }
}
