//! The six cases of the study: two trajectories under three control schemes.

use std::path::{Path, PathBuf};

use ckcm::TrajectoryKind;

use crate::campaign::TrialSummary;

/// A control scheme of the comparison.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Scheme {
    /// PID feedback (with feedforward), learning off.
    Pid,
    /// PID + PD-type ILC: Ψ = 0.
    PdIlc,
    /// PID + PID-type ILC: the HLCS.
    Hlcs,
}

impl Scheme {
    /// All three, in the paper's order.
    pub const ALL: [Scheme; 3] = [Scheme::Pid, Scheme::PdIlc, Scheme::Hlcs];

    /// Directory and file name part.
    pub fn slug(self) -> &'static str {
        match self {
            Scheme::Pid => "pid",
            Scheme::PdIlc => "pd_ilc",
            Scheme::Hlcs => "hlcs",
        }
    }

    /// Parses [`Scheme::slug`].
    pub fn from_slug(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|x| x.slug() == s)
    }

    /// Name in tables and legends.
    pub fn label(self) -> &'static str {
        match self {
            Scheme::Pid => "PID",
            Scheme::PdIlc => "PD-type ILC",
            Scheme::Hlcs => "HLCS (PID-type ILC)",
        }
    }

    /// Whether the scheme learns between trials.
    pub fn learning(self) -> bool {
        self != Scheme::Pid
    }

    /// Ψ of the scheme: Table 1's for HLCS, 0 for PD-type ILC (unused by PID).
    pub fn psi(self) -> f64 {
        if self == Scheme::PdIlc {
            0.0
        } else {
            ckcm::Gains::default().psi
        }
    }

    /// The panel letter of the paper's Fig. 6/7: a PID, b PD-type ILC, c HLCS.
    pub fn letter(self) -> char {
        match self {
            Scheme::Pid => 'a',
            Scheme::PdIlc => 'b',
            Scheme::Hlcs => 'c',
        }
    }

    /// Colour index in every figure, so a scheme keeps its colour throughout.
    pub fn colour_index(self) -> usize {
        match self {
            Scheme::Pid => 7,
            Scheme::PdIlc => 1,
            Scheme::Hlcs => 0,
        }
    }
}

/// The two trajectories, in the paper's order.
pub const TRAJECTORIES: [TrajectoryKind; 2] = [TrajectoryKind::Line, TrajectoryKind::Circle];

/// Directory and file name part of a trajectory.
pub fn traj_slug(k: TrajectoryKind) -> &'static str {
    k.name()
}

/// Parses [`traj_slug`] (line or circle).
pub fn traj_from_slug(s: &str) -> Option<TrajectoryKind> {
    TRAJECTORIES.into_iter().find(|&k| traj_slug(k) == s)
}

/// The paper's figure number of a trajectory: 6 for the line, 7 for the circle.
pub fn figure_number(k: TrajectoryKind) -> u32 {
    if k == TrajectoryKind::Line { 6 } else { 7 }
}

/// Results of one campaign.
#[derive(Debug, Clone)]
pub struct CaseResult {
    /// Trajectory tracked.
    pub trajectory: TrajectoryKind,
    /// Control scheme.
    pub scheme: Scheme,
    /// The campaign directory.
    pub dir: PathBuf,
    /// Per-trial summaries, trial 0 first.
    pub summaries: Vec<TrialSummary>,
}

/// Where `paper` writes a case.
pub fn case_dir(out: &Path, kind: TrajectoryKind, scheme: Scheme) -> PathBuf {
    out.join(traj_slug(kind)).join(scheme.slug())
}
