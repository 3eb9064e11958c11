//! Reference trajectories (docs/model.md §3): C², rest-to-rest, orientation held at zero,
//! with analytic velocity and acceleration.

use nalgebra::{UnitQuaternion, Vector3, Vector6};

use crate::kinematics::Pose;

/// Which path to follow.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrajectoryKind {
    /// Stay at home.
    Hold,
    /// Out and back along home → home + (0.1, 0.1, 0.1) m, in the paper's plane x + y − 2z + 1 = 0.
    Line,
    /// One turn of radius 0.2 m about (0, 0.2, h) in the horizontal plane, starting at home.
    Circle,
}

impl TrajectoryKind {
    /// Every kind, in the order of the controller's `trajectory` items.
    pub const ALL: [TrajectoryKind; 3] = [Self::Hold, Self::Line, Self::Circle];

    /// The one spelling scenario files, the controller's enumeration items and result
    /// folders share, so that none of them drifts from the others.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Hold => "hold",
            Self::Line => "line",
            Self::Circle => "circle",
        }
    }

    /// The kind [`name`](Self::name) spells, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The names of [`ALL`](Self::ALL), comma-separated, for error messages.
    pub fn names() -> String {
        Self::ALL.map(Self::name).join(", ")
    }
}

/// A sampled reference: pose, world twist and its derivative.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reference {
    pub pose: Pose,
    /// World twist (v, ω), m/s and rad/s.
    pub twist: Vector6<f64>,
    /// Derivative of the twist (v̇, ω̇), m/s² and rad/s².
    pub accel: Vector6<f64>,
}

/// A trajectory with its duration and home height.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trajectory {
    pub kind: TrajectoryKind,
    /// Duration T, s. Line default 15, circle default 5.
    pub duration: f64,
    /// Home height h, m. Default 0.5.
    pub home_height: f64,
}

/// Line displacement from home to the far end, m.
pub const LINE_DISPLACEMENT: [f64; 3] = [0.1, 0.1, 0.1];
/// Circle radius, m.
pub const CIRCLE_RADIUS: f64 = 0.2;

/// Quintic time law s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ and its first two derivatives in τ,
/// clamped to rest outside [0, 1].
fn quintic(tau: f64) -> (f64, f64, f64) {
    if tau <= 0.0 {
        return (0.0, 0.0, 0.0);
    }
    if tau >= 1.0 {
        return (1.0, 0.0, 0.0);
    }
    let t2 = tau * tau;
    let t3 = t2 * tau;
    (
        t3 * (10.0 - 15.0 * tau + 6.0 * t2),
        30.0 * t2 * (1.0 - 2.0 * tau + t2),
        60.0 * tau * (1.0 - 3.0 * tau + 2.0 * t2),
    )
}

impl Trajectory {
    /// The paper's line: 15 s out and back.
    pub fn line(home_height: f64) -> Self {
        Self {
            kind: TrajectoryKind::Line,
            duration: 15.0,
            home_height,
        }
    }

    /// The paper's circle: one turn in 5 s.
    pub fn circle(home_height: f64) -> Self {
        Self {
            kind: TrajectoryKind::Circle,
            duration: 5.0,
            home_height,
        }
    }

    /// Holding home for `duration` seconds.
    pub fn hold(home_height: f64, duration: f64) -> Self {
        Self {
            kind: TrajectoryKind::Hold,
            duration,
            home_height,
        }
    }

    /// Reference at time `t` (s from the start of the trial); rest at the end points outside [0, T].
    pub fn sample(&self, t: f64) -> Reference {
        let home = Vector3::new(0.0, 0.0, self.home_height);
        let (p, v, a) = match self.kind {
            TrajectoryKind::Hold => (home, Vector3::zeros(), Vector3::zeros()),
            TrajectoryKind::Line => {
                let d = Vector3::from(LINE_DISPLACEMENT);
                let half = self.duration / 2.0;
                if t < half {
                    let (s, sd, sdd) = quintic(t / half);
                    (home + d * s, d * (sd / half), d * (sdd / (half * half)))
                } else {
                    let (s, sd, sdd) = quintic((t - half) / half);
                    (
                        home + d * (1.0 - s),
                        -d * (sd / half),
                        -d * (sdd / (half * half)),
                    )
                }
            }
            TrajectoryKind::Circle => {
                let (s, sd, sdd) = quintic(t / self.duration);
                let tp = std::f64::consts::TAU;
                let th = tp * s;
                let thd = tp * sd / self.duration;
                let thdd = tp * sdd / (self.duration * self.duration);
                let (sn, cs) = th.sin_cos();
                let r = CIRCLE_RADIUS;
                (
                    Vector3::new(r * sn, r - r * cs, self.home_height),
                    Vector3::new(r * cs * thd, r * sn * thd, 0.0),
                    Vector3::new(
                        r * (cs * thdd - sn * thd * thd),
                        r * (sn * thdd + cs * thd * thd),
                        0.0,
                    ),
                )
            }
        };
        Reference {
            pose: Pose {
                p_world: p,
                q_world: UnitQuaternion::identity(),
            },
            twist: Vector6::new(v.x, v.y, v.z, 0.0, 0.0, 0.0),
            accel: Vector6::new(a.x, a.y, a.z, 0.0, 0.0, 0.0),
        }
    }
}
