//! [`Progress`]: what an experiment reports while it runs, as typed events, so that a
//! front end (the CLI's progress bar, a Python callback) counts steps without reading
//! the library's message text.

/// One progress event of an experiment.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Progress {
    /// An experiment of [`all`](super::all) begins.
    Experiment {
        /// Its title.
        title: String,
    },
    /// A phase begins; `total` [`Progress::Step`]s follow (0 when the count is not
    /// known in advance).
    Start {
        /// What the phase does.
        phase: String,
        /// Steps that follow.
        total: usize,
    },
    /// One step of the current phase begins.
    Step {
        /// What the step does.
        label: String,
    },
    /// A message that is not a step (loading a mesh, a repair before the solves).
    Note {
        /// The message.
        label: String,
    },
}

impl Progress {
    /// A [`Progress::Start`].
    pub fn start(phase: impl Into<String>, total: usize) -> Self {
        Progress::Start {
            phase: phase.into(),
            total,
        }
    }

    /// A [`Progress::Step`].
    pub fn step(label: impl Into<String>) -> Self {
        Progress::Step {
            label: label.into(),
        }
    }

    /// A [`Progress::Note`].
    pub fn note(label: impl Into<String>) -> Self {
        Progress::Note {
            label: label.into(),
        }
    }
}

/// The callback experiments report [`Progress`] to.
pub type ProgressFn<'a> = dyn FnMut(Progress) + 'a;
