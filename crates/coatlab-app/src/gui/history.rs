//! Undo and redo of design edits, and of the choice of the scene materials
//! that carry the design.
//!
//! The history stores whole states ([`Edit`]: the design and the paint-material
//! choice): a design is a few kilobytes (two 81-sample spectra at most), so
//! snapshots are simpler and safer than inverse operations, and every kind of
//! edit — a slider, a preset, an import, a loaded file, a material toggled in
//! the paint list or by a click on the car — is undoable by the same path.
//!
//! Edits are *committed*, not recorded per change: the UI calls [`History::commit`]
//! once a gesture is over (no pointer button held), so a slider drag over 200
//! frames is one undo step, as a person expects.

use coatlab_core::design::PaintDesign;

/// How many undo steps are kept; older ones are dropped.
pub const MAX_UNDO: usize = 200;

/// One undoable state of the document.
#[derive(Debug, Clone, PartialEq)]
pub struct Edit {
    pub design: PaintDesign,
    /// Which of the preview scene's materials carry the design; `None` while
    /// the preview shows no scene.
    pub paint: Option<PaintChoice>,
}

/// The preview's paint-material choice and the scene it was made on (material
/// indices mean nothing on another scene).
#[derive(Debug, Clone, PartialEq)]
pub struct PaintChoice {
    /// The scene's name as the preview reports it.
    pub scene: String,
    /// The materials chosen, or `None` for the loader's choice.
    pub chosen: Option<Vec<u32>>,
}

/// Undo and redo stacks around the last committed state (a design, an [`Edit`]).
#[derive(Debug, Clone)]
pub struct History<T = PaintDesign> {
    undo: Vec<T>,
    redo: Vec<T>,
    committed: T,
}

impl<T: Clone + PartialEq> History<T> {
    /// A history whose only state is `initial`.
    pub fn new(initial: T) -> Self {
        Self {
            undo: Vec::new(),
            redo: Vec::new(),
            committed: initial,
        }
    }

    /// Records `current` as a new step if it differs from the last committed design.
    /// Returns whether a step was recorded. A new step clears the redo stack.
    pub fn commit(&mut self, current: &T) -> bool {
        if *current == self.committed {
            return false;
        }
        let previous = std::mem::replace(&mut self.committed, current.clone());
        self.undo.push(previous);
        if self.undo.len() > MAX_UNDO {
            self.undo.remove(0);
        }
        self.redo.clear();
        true
    }

    /// Forgets every step and starts again from `design` (a newly opened file is
    /// still undoable: callers commit it instead when that is wanted).
    pub fn reset(&mut self, design: T) {
        self.undo.clear();
        self.redo.clear();
        self.committed = design;
    }

    /// The design before the last step, or `None` when there is nothing to undo.
    /// `current` is committed first, so an edit still in progress is not lost to redo.
    pub fn undo(&mut self, current: &T) -> Option<T> {
        self.commit(current);
        let previous = self.undo.pop()?;
        let undone = std::mem::replace(&mut self.committed, previous.clone());
        self.redo.push(undone);
        Some(previous)
    }

    /// The design the last undo went back from, or `None`.
    pub fn redo(&mut self, current: &T) -> Option<T> {
        if *current != self.committed {
            // An uncommitted edit after an undo is a new branch: redo has nothing left.
            self.commit(current);
            return None;
        }
        let next = self.redo.pop()?;
        let previous = std::mem::replace(&mut self.committed, next.clone());
        self.undo.push(previous);
        Some(next)
    }

    /// Whether an undo step exists (counting an uncommitted edit).
    pub fn can_undo(&self, current: &T) -> bool {
        !self.undo.is_empty() || *current != self.committed
    }

    /// Whether a redo step exists.
    pub fn can_redo(&self, current: &T) -> bool {
        !self.redo.is_empty() && *current == self.committed
    }

    /// The last committed state.
    pub fn committed(&self) -> &T {
        &self.committed
    }

    /// Takes `current` as the committed state without recording a step: a
    /// change that is not the user's edit (a new scene's paint choice).
    pub fn amend(&mut self, current: T) {
        self.committed = current;
    }

    /// Number of undo steps recorded.
    pub fn undo_len(&self) -> usize {
        self.undo.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use coatlab_core::design::presets;

    fn designs() -> (PaintDesign, PaintDesign, PaintDesign) {
        let a = presets::all()[0].design.clone();
        let mut b = a.clone();
        b.thickness_um += 5.0;
        let mut c = b.clone();
        c.thickness_um += 5.0;
        (a, b, c)
    }

    #[test]
    fn undo_and_redo_walk_the_steps() {
        let (a, b, c) = designs();
        let mut h = History::new(a.clone());
        assert!(h.commit(&b));
        assert!(!h.commit(&b), "an unchanged design is not a step");
        assert!(h.commit(&c));
        assert_eq!(h.undo(&c), Some(b.clone()));
        assert_eq!(h.undo(&b), Some(a.clone()));
        assert_eq!(h.undo(&a), None);
        assert_eq!(h.redo(&a), Some(b.clone()));
        assert_eq!(h.redo(&b), Some(c.clone()));
        assert_eq!(h.redo(&c), None);
    }

    #[test]
    fn undo_of_an_uncommitted_edit_returns_to_the_committed_design() {
        let (a, b, _) = designs();
        let mut h = History::new(a.clone());
        assert!(h.can_undo(&b));
        assert_eq!(h.undo(&b), Some(a.clone()));
        assert_eq!(h.redo(&a), Some(b));
    }

    #[test]
    fn a_new_edit_after_undo_clears_redo() {
        let (a, b, c) = designs();
        let mut h = History::new(a.clone());
        h.commit(&b);
        h.undo(&b);
        let mut d = a.clone();
        d.name = "other".into();
        assert_eq!(h.redo(&d), None);
        assert!(!h.can_redo(&d));
        assert_eq!(h.undo(&d), Some(a));
        let _ = c;
    }
}
