//! Mechanism maths for the 6-DOF closed-kinematic-chain manipulator (a Stewart platform):
//! parameters, kinematics, rigid-body dynamics with two-body legs, reference trajectories,
//! integrators, error metrics and the HLCS control law.
//!
//! Conventions (docs/model.md §3): {B} at the base centroid with z up, {A} at the platform joint
//! centroid; orientation is a unit quaternion inside, Z-Y-X Euler angles only at interfaces;
//! velocities are the world twist ν = (v, ω).
#![forbid(unsafe_code)]

pub mod closed_loop;
pub mod control;
pub mod convergence;
pub mod dynamics;
pub mod integrate;
pub mod kinematics;
pub mod learning;
pub mod metrics;
pub mod params;
pub mod rotation;
pub mod trajectory;
pub mod workspace;

pub use control::{
    ControlInput, ControlOutput, ControlSettings, Gains, Hlcs, LearningLaw, ReferenceTable,
    ReferenceTerms,
};
pub use dynamics::{DynamicsError, DynamicsTerms, JointSpaceDynamics};
pub use integrate::{DormandPrince, Inside, IntegrationError, Integrator, Rk4, State};
pub use kinematics::{FkError, FkOptions, LEGS, LegGeometry, Mechanism, Pose};
pub use params::{
    Friction, FrictionCurve, Geometry, Legs, ParamError, ParamProblem, Params, Platform,
};
pub use trajectory::{Reference, Trajectory, TrajectoryKind};
pub use workspace::{Workspace, WorkspaceError};

pub use nalgebra;
