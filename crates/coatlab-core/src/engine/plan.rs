//! The live engine's state machine, as pure functions: what a change or an
//! outcome of the back-end does to the engine's [`State`], and which
//! [`Actions`] (rebuilds and restarts) it asks for. [`super::LiveEngine`]
//! executes the actions; nothing here touches a render.
//!
//! Two parts make the state: the first view's [`Phase`] and the second view's
//! [`Pairing`]. Commands reach [`transition`] as a [`Change`] (what the command
//! alters, found by comparing it with what is set; the same value again is
//! [`Change::Nothing`]); what the back-end reports reaches [`advance`] as an
//! [`Outcome`].
//!
//! | change | phase after | pairing after | rebuilds |
//! |---|---|---|---|
//! | `Nothing` | unchanged | unchanged | nothing |
//! | `Paint` (gloss kept), one view, at full size | `EditPending` | `Single` | tables (updated), shading; re-shade |
//! | `Paint` otherwise, `Gloss` | `Coarse` | `Fitting` if two views | tables (updated), shading, second shading; retrace |
//! | `Views` | `Coarse` | `Fitting` or `Single` | shading; second shading built or dropped; retrace |
//! | `PaintMaterials` | `Coarse` | `Fitting` if two views | shading, second shading; retrace |
//! | `Scene` | `Coarse` | `Fitting` if two views | BVH (when taken), tables from scratch, shading, second shading; retrace |
//! | `Lighting` | `Coarse` | unchanged | lighting (when taken); retrace |
//! | `Grid` | `Coarse` | `Fitting` if two views | lighting (when taken), tables from scratch, shading, second shading, renders; retrace |
//! | `Camera`, `Size`, `Target` | `Coarse` | unchanged | nothing; retrace |
//! | `Display` | unchanged | unchanged | nothing; the images shown again |
//!
//! | outcome | from | to |
//! |---|---|---|
//! | `CoarseDone` | `Coarse` | `CoarseShown` |
//! | `PassDone` | `CoarseShown`, `EditShown`, `Refining` | `Refining`, or `Converged` at the sample target |
//! | `EditReshaded` | `EditPending` | `EditShown` |
//! | `EditRefused` (no complete cache, a mirror, a wider lobe) | `EditPending` | `Coarse`, retrace |
//! | `EditRefined` | `EditShown` | `Refining` |
//! | `DesignInvalid` | any | `Refining` or `Converged` (the last image stays) |
//! | `SecondShared` / `SecondIndependent` / `SecondInvalid` | `Fitting` | `Shared` / `Independent` / `Failed` |
//! | `SharedFailed` | `Shared` | `Independent` (the second view's own render goes on) |
//! | `OutOfStep` (a second view's pass cancelled or behind) | any | phase `Coarse`, retrace |

/// Where the first view's picture stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// A change waits for its first image: the next pass is the coarse one, at
    /// 1/[`super::COARSE_FACTOR`] of the resolution, so it shows within a frame or two.
    Coarse,
    /// The coarse image is shown; the next pass is at full resolution.
    CoarseShown,
    /// A paint edit waits to be shown re-shaded from the edit base.
    EditPending,
    /// An edit is shown re-shaded from the first recorded samples; the re-shade
    /// from all of them comes next, then fresh passes.
    EditShown,
    /// Full-resolution passes accumulate.
    Refining,
    /// The sample target is reached: nothing to do until a command.
    Converged,
}

/// How the second view of a comparison is made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pairing {
    /// One view.
    Single,
    /// The second view's shading is being built on a thread of its own; the
    /// first pass of the first view decides how the second is made.
    Fitting,
    /// The second view is rendered on its own, one pass of each in turn, and
    /// its pane combines that render with the first view's recorded paths
    /// re-shaded with the second shading: the panes share samples (the
    /// difference shows the models, not noise) and each converges to its own
    /// model's image.
    Shared,
    /// The second view is rendered on its own (same scene, lighting, camera and
    /// seed), one pass of each in turn.
    Independent,
    /// The second design could not be modelled: one view is shown.
    Failed,
}

impl Pairing {
    /// Whether the views have a second view (shown or not).
    pub fn has_second(self) -> bool {
        self != Pairing::Single
    }
}

/// The engine's state: the first view's phase and the second view's pairing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct State {
    /// The first view.
    pub phase: Phase,
    /// The second view.
    pub pairing: Pairing,
}

impl State {
    /// A new engine: one view, its coarse pass next.
    pub const START: State = State {
        phase: Phase::Coarse,
        pairing: Pairing::Single,
    };

    /// Whether the first view is at its full resolution (not in its coarse
    /// pass), which a re-shaded edit needs.
    fn full_size(self) -> bool {
        matches!(
            self.phase,
            Phase::EditPending | Phase::EditShown | Phase::Refining | Phase::Converged
        )
    }
}

/// What a command changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Change {
    /// Nothing the picture shows: the same value again, or a load that failed.
    Nothing,
    /// A paint edit that keeps the gloss reading: it may be shown re-shaded
    /// from the recorded paths (the back-end refuses a lobe it cannot re-weight).
    Paint,
    /// A paint edit of the gloss reading: a new lobe is covered poorly by the old
    /// one's samples, so it is traced fresh.
    Gloss,
    /// The first view's model or the comparison; `second`: a second view after it.
    Views {
        /// Whether the views have a second view after the change.
        second: bool,
    },
    /// Which scene materials carry the paint.
    PaintMaterials,
    /// A new scene (its BVH was built when the command was taken).
    Scene,
    /// New lighting on the same grid (built when the command was taken).
    Lighting,
    /// A new wavelength grid (the lighting was rebuilt on it when the command was
    /// taken).
    Grid,
    /// The view: orbit, zoom or pan.
    Camera,
    /// The image size.
    Size,
    /// The sample target or the resolution divisor.
    Target,
    /// How the images are shown (tone mapping, exposure): nothing is rendered
    /// again.
    Display,
}

/// What happens to the first view's derived tables (the paint model).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Default)]
pub enum Tables {
    /// Kept.
    #[default]
    Keep,
    /// Brought up to the design: only the tables its changed fields touch
    /// ([`crate::design::PaintDesign::update_model`]).
    Update,
    /// Built from scratch (a new grid, a new scene).
    Rebuild,
}

/// What happens to the second view.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Default)]
pub enum Second {
    /// Kept as it is.
    #[default]
    Keep,
    /// Its shading is built again and how it is made decided again.
    Rebuild,
    /// Dropped (no second view any more).
    Drop,
}

/// How the first view's samples start again.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Default)]
pub enum Restart {
    /// They are kept.
    #[default]
    Keep,
    /// The new shading is shown re-shaded from the edit base, then refined.
    Reshade,
    /// Traced anew from nothing, coarse pass first.
    Retrace,
}

/// What a transition asks the engine to do. Actions of several commands merge
/// ([`Actions::merge`]): each rebuild happens once per batch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Actions {
    /// The first view's paint model.
    pub tables: Tables,
    /// The first view's shading (the paint model in the view's model, for the
    /// scene's materials).
    pub shading: bool,
    /// The second view.
    pub second: Second,
    /// New renders (a new wavelength grid).
    pub renders: bool,
    /// Give the renders the new lighting.
    pub relight: bool,
    /// Give the renders the new scene.
    pub rescene: bool,
    /// How the first view's samples start again.
    pub restart: Restart,
    /// Show the images again (the display changed), when no pass will.
    pub republish: bool,
}

impl Actions {
    /// Nothing to do.
    pub const NONE: Actions = Actions {
        tables: Tables::Keep,
        shading: false,
        second: Second::Keep,
        renders: false,
        relight: false,
        rescene: false,
        restart: Restart::Keep,
        republish: false,
    };

    /// Only a restart from nothing.
    const RETRACE: Actions = Actions {
        restart: Restart::Retrace,
        ..Actions::NONE
    };

    /// Both sets of actions, each rebuild at its strongest. A later `Drop` of the
    /// second view wins over an earlier `Rebuild`, and a later `Rebuild` over an
    /// earlier `Drop` (the views were switched off and on again).
    pub fn merge(self, later: Actions) -> Actions {
        Actions {
            tables: self.tables.max(later.tables),
            shading: self.shading || later.shading,
            second: match later.second {
                Second::Keep => self.second,
                other => other,
            },
            renders: self.renders || later.renders,
            relight: self.relight || later.relight,
            rescene: self.rescene || later.rescene,
            restart: self.restart.max(later.restart),
            republish: self.republish || later.republish,
        }
    }

    /// Whether anything is to be done.
    pub fn any(&self) -> bool {
        *self != Actions::NONE
    }
}

/// The new state after a command's `change`, and what it asks for.
pub fn transition(state: State, change: Change) -> (State, Actions) {
    let rebuild_second = if state.pairing.has_second() {
        Second::Rebuild
    } else {
        Second::Keep
    };
    let coarse = State {
        phase: Phase::Coarse,
        ..state
    };
    // A new first shading: the second view's is built again and how it is made
    // decided again.
    let refit = State {
        pairing: if state.pairing.has_second() {
            Pairing::Fitting
        } else {
            Pairing::Single
        },
        ..coarse
    };
    let shading = Actions {
        shading: true,
        second: rebuild_second,
        ..Actions::RETRACE
    };
    match change {
        Change::Nothing => (state, Actions::NONE),
        Change::Paint if state.pairing == Pairing::Single && state.full_size() => (
            State {
                phase: Phase::EditPending,
                ..state
            },
            Actions {
                tables: Tables::Update,
                shading: true,
                restart: Restart::Reshade,
                ..Actions::NONE
            },
        ),
        Change::Paint | Change::Gloss => (
            refit,
            Actions {
                tables: Tables::Update,
                ..shading
            },
        ),
        Change::Views { second } => views_changed(coarse, second),
        Change::PaintMaterials => (refit, shading),
        Change::Scene => (
            refit,
            Actions {
                tables: Tables::Rebuild,
                rescene: true,
                ..shading
            },
        ),
        Change::Grid => (
            refit,
            Actions {
                tables: Tables::Rebuild,
                renders: true,
                ..shading
            },
        ),
        Change::Lighting => (
            coarse,
            Actions {
                relight: true,
                ..Actions::RETRACE
            },
        ),
        Change::Camera | Change::Size | Change::Target => (coarse, Actions::RETRACE),
        Change::Display => (
            state,
            Actions {
                republish: true,
                ..Actions::NONE
            },
        ),
    }
}

/// The views changed: the first view's shading is rebuilt (its model may have
/// changed) and the second view's built anew or dropped.
fn views_changed(coarse: State, second: bool) -> (State, Actions) {
    let (pairing, second) = if second {
        (Pairing::Fitting, Second::Rebuild)
    } else {
        (Pairing::Single, Second::Drop)
    };
    (
        State { pairing, ..coarse },
        Actions {
            shading: true,
            second,
            ..Actions::RETRACE
        },
    )
}

/// The state once the merged `pending` actions are known: a retrace pending
/// puts the first view back to its coarse pass, whatever an earlier command of
/// the batch (or one deferred) planned.
pub fn settle(state: State, pending: Actions) -> State {
    if pending.restart == Restart::Retrace {
        State {
            phase: Phase::Coarse,
            ..state
        }
    } else {
        state
    }
}

/// What the back-end reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// The coarse pass was rendered.
    CoarseDone,
    /// A full-resolution pass was rendered; `converged`: the first view reached
    /// its sample target.
    PassDone {
        /// The sample target is reached.
        converged: bool,
    },
    /// The pending edit is shown re-shaded.
    EditReshaded,
    /// The re-shade refused the edit (no complete path cache yet, a change to or
    /// from an ideal mirror, a wider lobe): it is traced fresh.
    EditRefused,
    /// The re-shade of the edit from all recorded samples replaced its first image.
    EditRefined,
    /// The design could not be modelled: the last image stays, and refinement
    /// goes on unless the target is reached.
    DesignInvalid {
        /// The sample target is reached.
        converged: bool,
    },
    /// The second view's shading is ready and the first view's paths re-shade
    /// into it.
    SecondShared,
    /// The second view's shading is ready, and the first view's paths cannot be
    /// re-shaded into it.
    SecondIndependent,
    /// The second design could not be modelled.
    SecondInvalid,
    /// Re-shading the first view's paths into the second view failed: its own
    /// render alone is shown from now on.
    SharedFailed,
    /// The second view fell out of step with the first (a pass of it was cancelled):
    /// both start again.
    OutOfStep,
}

/// The new state after `outcome`, and what it asks for.
pub fn advance(state: State, outcome: Outcome) -> (State, Actions) {
    let with = |phase| (State { phase, ..state }, Actions::NONE);
    let pair = |pairing| (State { pairing, ..state }, Actions::NONE);
    let converged_or_refining = |converged| {
        if converged {
            Phase::Converged
        } else {
            Phase::Refining
        }
    };
    match outcome {
        Outcome::CoarseDone => with(Phase::CoarseShown),
        Outcome::PassDone { converged } | Outcome::DesignInvalid { converged } => {
            with(converged_or_refining(converged))
        }
        Outcome::EditReshaded => with(Phase::EditShown),
        Outcome::EditRefined => with(Phase::Refining),
        Outcome::EditRefused | Outcome::OutOfStep => (
            State {
                phase: Phase::Coarse,
                ..state
            },
            Actions::RETRACE,
        ),
        Outcome::SecondShared => pair(Pairing::Shared),
        Outcome::SecondIndependent => pair(Pairing::Independent),
        Outcome::SecondInvalid => pair(Pairing::Failed),
        Outcome::SharedFailed => pair(Pairing::Independent),
    }
}
