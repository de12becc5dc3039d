//! Frequency response diagrams (the paper's Figs. 9 and 11): one branch per method and
//! number of harmonics, each traced by pseudo-arclength continuation
//! ([`crate::continuation::arclength::trace_branch`], docs/theory.md §10) from the
//! contact-free response at the start frequency, with folds located (docs/theory.md (T76)),
//! stability changes (when the Floquet multipliers are computed; docs/theory.md §11) and,
//! for the penalty method, the penetration of every point.
//!
//! The computation is the library's: [`trace_diagram`] (or [`trace_frd_branch`] for one
//! branch) takes typed, validated [`FrdSettings`] and the [`MethodSettings`] of each
//! method, reports every point, fold and stability change to an [`FrdObserver`] as it is
//! found (the CLI streams them to CSV and drives a progress bar), and returns an
//! [`FrdReport`]. Callers only choose settings, observe and write.
//!
//! [`MethodSettings`]: crate::method::settings::MethodSettings

mod report;
mod settings;
mod trace;

pub use report::{
    branch_values_at, describe_stop, BifurcationReport, BranchReport, BranchValue, FoldReport,
    FrdPoint, FrdReport,
};
pub use settings::{
    check_frequencies, response_dof, FrdSettings, DEFAULT_INITIAL_STEP, DEFAULT_MAX_POINTS,
    DEFAULT_MAX_STEP, DEFAULT_MAX_TURN_DEG, DEFAULT_MIN_STEP,
};
pub use trace::{
    trace_diagram, trace_frd_branch, BranchInfo, FrdObserver, PointEvent, TracedBranch,
};
