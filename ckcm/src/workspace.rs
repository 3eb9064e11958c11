//! The mechanism's physical workspace: actuator strokes and the base plane.
//!
//! The rigid-body model of docs/model.md §3 has no end stops: under zero forces it falls
//! through the base plane, under large forces its legs grow without bound, and either way
//! it keeps integrating. A real Stewart platform stops at its actuators' stroke ends, so
//! the plant checks every state it reaches against [`Workspace::check`] and refuses a
//! step that leaves the workspace.

use crate::kinematics::{LEGS, LegGeometry, Pose};

/// Leg length limits (actuator stroke ends), m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Workspace {
    /// Shortest allowed leg length, m. Plant default 0.4 (the paper's paths need ≥ 0.500).
    pub length_min: f64,
    /// Longest allowed leg length, m. Plant default 0.95 (the paper's paths need ≤ 0.830).
    pub length_max: f64,
}

/// Why a state lies outside the workspace. Legs and joints are numbered from 1, as the
/// FMU variables `length[1]`..`length[6]` are.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum WorkspaceError {
    #[error("the pose or twist is not finite (the integration diverged)")]
    NonFinite,
    #[error("leg {leg} has length {length} m, outside its stroke [{min}, {max}] m")]
    Stroke {
        leg: usize,
        length: f64,
        min: f64,
        max: f64,
    },
    #[error("platform joint {joint} reached the base plane (z = {z} m)")]
    BasePlane { joint: usize, z: f64 },
    #[error(
        "the stroke [{min}, {max}] m is empty or not finite: length_min must be below length_max"
    )]
    EmptyStroke { min: f64, max: f64 },
}

impl Workspace {
    /// Checks the limits themselves.
    pub fn validate(&self) -> Result<(), WorkspaceError> {
        let (min, max) = (self.length_min, self.length_max);
        if min.is_finite() && max.is_finite() && min >= 0.0 && min < max {
            Ok(())
        } else {
            Err(WorkspaceError::EmptyStroke { min, max })
        }
    }

    /// Checks a pose (`twist_finite`: whether the twist is finite) and its leg geometry:
    /// finite, every platform joint above the base plane, every leg within its stroke.
    pub fn check(
        &self,
        pose: &Pose,
        twist_finite: bool,
        legs: &LegGeometry,
    ) -> Result<(), WorkspaceError> {
        if !(twist_finite && pose.is_finite() && legs.length.iter().all(|l| l.is_finite())) {
            return Err(WorkspaceError::NonFinite);
        }
        for i in 0..LEGS {
            let z = pose.p_world.z + legs.r_world[i].z;
            if z <= 0.0 {
                return Err(WorkspaceError::BasePlane { joint: i + 1, z });
            }
        }
        for (i, &length) in legs.length.iter().enumerate() {
            if !(self.length_min..=self.length_max).contains(&length) {
                return Err(WorkspaceError::Stroke {
                    leg: i + 1,
                    length,
                    min: self.length_min,
                    max: self.length_max,
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Mechanism, Params};

    fn check(mech: &Mechanism, ws: &Workspace, pose: &Pose) -> Result<(), WorkspaceError> {
        ws.check(pose, true, &mech.inverse_kinematics(pose))
    }

    #[test]
    fn home_is_inside_and_each_limit_is_named() {
        let mech = Mechanism::new(Params::default()).unwrap();
        let ws = Workspace {
            length_min: 0.4,
            length_max: 0.95,
        };
        assert_eq!(check(&mech, &ws, &Pose::home(0.5)), Ok(()));
        // Straight down to z = 0.1 m: every leg is about 0.27 m, below the stroke.
        match check(&mech, &ws, &Pose::home(0.1)) {
            Err(WorkspaceError::Stroke { leg: 1, length, .. }) => assert!(length < 0.4),
            other => panic!("{other:?}"),
        }
        // Up to 1 m: legs longer than 0.95 m.
        assert!(matches!(
            check(&mech, &ws, &Pose::home(1.0)),
            Err(WorkspaceError::Stroke { leg: 1, .. })
        ));
        // Through the base plane: reported before the stroke.
        let below = Pose::home(-0.45);
        let e = check(&mech, &ws, &below).unwrap_err();
        assert!(
            matches!(e, WorkspaceError::BasePlane { z, .. } if z < 0.0),
            "{e}"
        );
        let nan = Pose::home(f64::NAN);
        assert_eq!(check(&mech, &ws, &nan), Err(WorkspaceError::NonFinite));
        let legs = mech.inverse_kinematics(&Pose::home(0.5));
        assert_eq!(
            ws.check(&Pose::home(0.5), false, &legs),
            Err(WorkspaceError::NonFinite)
        );
        let e = check(&mech, &ws, &Pose::home(0.1)).unwrap_err().to_string();
        assert!(e.starts_with("leg 1 has length 0.2"), "{e}");
        assert!(e.ends_with("outside its stroke [0.4, 0.95] m"), "{e}");
    }

    /// A platform 5 cm over the base, pitched by 0.6 rad: its joints sit at different heights
    /// (four below the plane, two above it), and the first one (in joint order) at or below
    /// the plane is named, 1-based, with its own height, not the platform centre's.
    #[test]
    fn the_first_joint_through_the_base_plane_is_named_with_its_height() {
        let mech = Mechanism::new(Params::default()).unwrap();
        let ws = Workspace {
            length_min: 0.0,
            length_max: 10.0,
        };
        let pose = Pose::from_xyz_euler(&[0.0, 0.0, 0.05, 0.0, 0.6, 0.0]);
        let legs = mech.inverse_kinematics(&pose);
        let heights: Vec<f64> = (0..LEGS)
            .map(|i| pose.p_world.z + legs.r_world[i].z)
            .collect();
        let first = heights.iter().position(|&z| z <= 0.0).unwrap();
        assert!(heights.iter().any(|&z| z > 0.0), "{heights:?}");
        assert!(legs.r_world[first].z.abs() > 0.05, "{heights:?}");
        assert_eq!(
            ws.check(&pose, true, &legs),
            Err(WorkspaceError::BasePlane {
                joint: first + 1,
                z: heights[first]
            })
        );
    }

    #[test]
    fn empty_strokes_are_refused() {
        for (min, max) in [(0.5, 0.5), (0.6, 0.5), (-0.1, 0.5), (0.4, f64::INFINITY)] {
            let ws = Workspace {
                length_min: min,
                length_max: max,
            };
            assert!(ws.validate().is_err(), "[{min}, {max}]");
        }
    }
}
