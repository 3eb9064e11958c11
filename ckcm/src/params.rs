//! Mechanism parameters, one struct per concern.
//!
//! Values marked "Table 1" are the paper's; the others are this project's own choices
//! (docs/model.md §3) and documented as such.

use nalgebra::Vector3;

/// Where the twelve spherical joints sit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    /// Radius of the base joint circle, m. Default 0.36 (Table 1).
    pub base_radius: f64,
    /// Radius of the platform joint circle, m. Default 0.27 (Table 1).
    pub platform_radius: f64,
    /// Height of the platform frame {A} above the base frame {B} at home, m. Default 0.5 (Table 1).
    pub home_height: f64,
    /// Half-separation θB of a base joint pair, rad. Default 2.5° (Table 1).
    pub base_joint_offset: f64,
    /// Half-separation θA of a platform joint pair, rad. Default 10° (Table 1).
    pub platform_joint_offset: f64,
}

impl Default for Geometry {
    fn default() -> Self {
        Self {
            base_radius: 0.36,
            platform_radius: 0.27,
            home_height: 0.5,
            base_joint_offset: 2.5_f64.to_radians(),
            platform_joint_offset: 10.0_f64.to_radians(),
        }
    }
}

/// The moving platform, a rigid body whose centre of mass is the frame {A} origin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Platform {
    /// Mass, kg. Default 4.92 (Table 1).
    pub mass: f64,
    /// Principal inertia (Ixx, Iyy, Izz) about the centre of mass in {A}, kg·m².
    /// Default (0.09, 0.09, 0.18) (Table 1).
    pub inertia: Vector3<f64>,
}

impl Default for Platform {
    fn default() -> Self {
        Self {
            mass: 4.92,
            inertia: Vector3::new(0.09, 0.09, 0.18),
        }
    }
}

/// One leg: a cylinder hinged at the base and a rod (piston) ball-jointed to the platform,
/// neither spinning about the leg axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Legs {
    /// Cylinder mass, kg. Default 10.29 (Table 1).
    pub cylinder_mass: f64,
    /// Distance of the cylinder's centre of mass from the base joint, along the leg, m. Default 0.20 (project).
    pub cylinder_com: f64,
    /// Cylinder transverse inertia about its centre of mass, kg·m². Default 0.1395 (project).
    pub cylinder_inertia: f64,
    /// Rod mass, kg. Default 1.0 (project).
    pub rod_mass: f64,
    /// Distance of the rod's centre of mass from the platform joint, along the leg, m. Default 0.15 (project).
    pub rod_com: f64,
    /// Rod transverse inertia about its centre of mass, kg·m². Default 0.0076 (project).
    pub rod_inertia: f64,
}

impl Default for Legs {
    fn default() -> Self {
        Self {
            cylinder_mass: 10.29,
            cylinder_com: 0.20,
            cylinder_inertia: 0.1395,
            rod_mass: 1.0,
            rod_com: 0.15,
            rod_inertia: 0.0076,
        }
    }
}

/// Actuator friction: −viscous·l̇ − coulomb·s(l̇ / velocity), acting along each leg, with s
/// the smoothed sign function chosen by `curve` (docs/model.md §3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Friction {
    /// Viscous coefficient, N·s/m. Default 100 (project).
    pub viscous: f64,
    /// Coulomb level, N. Default 20 (project).
    pub coulomb: f64,
    /// Velocity scale of the smoothing, m/s. Default 0.02 (project).
    pub velocity: f64,
    /// Smoothing curve of the Coulomb term, no unit. Default [`FrictionCurve::Tanh`].
    pub curve: FrictionCurve,
}

/// The smoothed sign function s of the Coulomb friction term (docs/model.md §3). Both are
/// odd, have slope 1 at 0 and tend to ±1, so they agree to first order about rest and far
/// from it; they differ in how fast they saturate (tanh exponentially, the algebraic curve
/// as 1 − 1/(2x²)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FrictionCurve {
    /// s(x) = tanh x: the model's friction, the default.
    #[default]
    Tanh,
    /// s(x) = x / √(1 + x²): a different model, one square root and one division instead
    /// of libm's `expm1` and a division, offered for speed in sweeps.
    Algebraic,
}

impl FrictionCurve {
    /// Above this |x| the algebraic curve is ±1 to the last bit; clamping there keeps x²
    /// from overflowing (x / √(1 + ∞) would give 0 instead of ±1).
    const ALGEBRAIC_SATURATION: f64 = 1e100;

    /// s(x), no unit, in [−1, 1].
    #[inline]
    pub fn smoothed_sign(self, x: f64) -> f64 {
        match self {
            FrictionCurve::Tanh => fdlibm_tanh::tanh(x),
            FrictionCurve::Algebraic => {
                let x = x.clamp(-Self::ALGEBRAIC_SATURATION, Self::ALGEBRAIC_SATURATION);
                x / (1.0 + x * x).sqrt()
            }
        }
    }
}

/// tanh x as fdlibm computes it from expm1, step for step. glibc's `tanh` (what `f64::tanh`
/// calls on Linux) is that code, so the bits are the same there
/// (`tests::tanh_is_libm_tanh_bit_for_bit`); elsewhere it is fdlibm's tanh on that
/// platform's expm1, the same on every path of the model. Written out so each value costs
/// one libm call instead of two (`tanh` calling `expm1`), and so six legs need no branch
/// and run two at a time (BENCHMARKS.md, round 11).
mod fdlibm_tanh {
    /// Below 2⁻⁵⁵ tanh x rounds to x.
    const TINY: f64 = f64::from_bits(0x3c80_0000_0000_0000);

    /// The argument of expm1 for |x| = `a`: 2|x| from 1 on, −2|x| below.
    #[inline(always)]
    pub(super) fn expm1_argument(a: f64) -> f64 {
        if a >= 1.0 { 2.0 * a } else { -2.0 * a }
    }

    /// tanh x from |x| = `a` and t = expm1 of [`expm1_argument`]: 1 − 2 / (t + 2) from 1 on,
    /// −t / (t + 2) below; x (1 + x), which is x, below 2⁻⁵⁵ (±0 included); NaN stays NaN.
    /// fdlibm returns 1 from 22 on without calling expm1; the formula rounds to 1 there by
    /// itself (infinity included).
    #[inline(always)]
    pub(super) fn finish(x: f64, a: f64, t: f64) -> f64 {
        let big = a >= 1.0;
        let q = if big { 2.0 } else { -t } / (t + 2.0);
        let z = if big { 1.0 - q } else { q };
        let signed = if x.is_sign_negative() { -z } else { z };
        if a < TINY || a.is_nan() { x } else { signed }
    }

    /// tanh x.
    #[inline]
    pub(super) fn tanh(x: f64) -> f64 {
        let a = x.abs();
        finish(x, a, expm1_argument(a).exp_m1())
    }

    /// tanh of six values: the six libm calls first, then the rest on two values at once.
    #[inline(always)]
    pub(super) fn tanh6(x: &[f64; 6]) -> [f64; 6] {
        let a: [f64; 6] = std::array::from_fn(|i| x[i].abs());
        let arg: [f64; 6] = std::array::from_fn(|i| expm1_argument(a[i]));
        let t: [f64; 6] = std::array::from_fn(|i| arg[i].exp_m1());
        std::array::from_fn(|i| finish(x[i], a[i], t[i]))
    }
}

impl Default for Friction {
    fn default() -> Self {
        Self {
            viscous: 100.0,
            coulomb: 20.0,
            velocity: 0.02,
            curve: FrictionCurve::Tanh,
        }
    }
}

impl Friction {
    /// No friction at all.
    pub const NONE: Friction = Friction {
        viscous: 0.0,
        coulomb: 0.0,
        velocity: 0.02,
        curve: FrictionCurve::Tanh,
    };

    /// [`Friction::force`] of six legs, the same bits.
    #[inline(always)]
    pub(crate) fn force6(&self, ldot: &[f64; 6]) -> [f64; 6] {
        match self.curve {
            FrictionCurve::Tanh => {
                let s = fdlibm_tanh::tanh6(&std::array::from_fn(|i| ldot[i] / self.velocity));
                std::array::from_fn(|i| self.with_sign(ldot[i], s[i]))
            }
            FrictionCurve::Algebraic => std::array::from_fn(|i| self.force(ldot[i])),
        }
    }

    /// Friction force on one leg at leg rate `ldot`, N (opposes the motion).
    #[inline]
    pub fn force(&self, ldot: f64) -> f64 {
        self.with_sign(ldot, self.curve.smoothed_sign(ldot / self.velocity))
    }

    /// The force at leg rate `ldot` given s(l̇ / v), N.
    #[inline(always)]
    fn with_sign(&self, ldot: f64, s: f64) -> f64 {
        -self.viscous * ldot - self.coulomb * s
    }
}

/// All parameters of the mechanism.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    pub geometry: Geometry,
    pub platform: Platform,
    pub legs: Legs,
    pub friction: Friction,
    /// Gravitational acceleration along −z of {B}, m/s². Default 9.81.
    pub gravity: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            geometry: Geometry::default(),
            platform: Platform::default(),
            legs: Legs::default(),
            friction: Friction::default(),
            gravity: 9.81,
        }
    }
}

impl Params {
    /// The controller's nominal model (docs/model.md §4): the plant's defaults without the rod
    /// and without friction. The mismatch is the repeating disturbance learning removes.
    pub fn nominal() -> Self {
        Self {
            legs: Legs {
                rod_mass: 0.0,
                rod_inertia: 0.0,
                ..Legs::default()
            },
            friction: Friction::NONE,
            ..Self::default()
        }
    }
}

/// A rejected or unknown parameter, naming it as docs/model.md and the FMU variables do.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("parameter `{field}` {problem}")]
pub struct ParamError {
    /// The parameter's name, e.g. `rod_mass`, `platform_inertia[2]`. A caller that exposes
    /// the fields under other names (the controller's `model.rod_mass`) renames it here.
    pub field: String,
    /// What is wrong with it.
    pub problem: ParamProblem,
}

/// What is wrong with a parameter.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamProblem {
    #[error("= {0} is not finite")]
    NotFinite(f64),
    #[error("= {0} must be positive")]
    NotPositive(f64),
    #[error("= {0} must not be negative")]
    Negative(f64),
    #[error("= {value} is out of range: {reason}")]
    OutOfRange { value: f64, reason: &'static str },
    #[error("is not a mechanism parameter (they are: {})", Params::FIELDS.join(", "))]
    Unknown,
}

impl ParamError {
    fn new(field: &str, problem: ParamProblem) -> Self {
        Self {
            field: field.to_owned(),
            problem,
        }
    }
}

impl Params {
    /// Checks every field; the error names the first offending one.
    pub fn validate(&self) -> Result<(), ParamError> {
        let g = &self.geometry;
        let positive = [
            ("base_radius", g.base_radius),
            ("platform_radius", g.platform_radius),
            ("home_height", g.home_height),
            ("platform_mass", self.platform.mass),
            ("platform_inertia[1]", self.platform.inertia.x),
            ("platform_inertia[2]", self.platform.inertia.y),
            ("platform_inertia[3]", self.platform.inertia.z),
            ("cylinder_mass", self.legs.cylinder_mass),
            ("friction_velocity", self.friction.velocity),
        ];
        let non_negative = [
            ("base_joint_offset", g.base_joint_offset),
            ("platform_joint_offset", g.platform_joint_offset),
            ("cylinder_com", self.legs.cylinder_com),
            ("cylinder_inertia", self.legs.cylinder_inertia),
            ("rod_mass", self.legs.rod_mass),
            ("rod_com", self.legs.rod_com),
            ("rod_inertia", self.legs.rod_inertia),
            ("viscous_friction", self.friction.viscous),
            ("coulomb_friction", self.friction.coulomb),
            ("gravity", self.gravity),
        ];
        for &(field, value) in positive.iter().chain(non_negative.iter()) {
            if !value.is_finite() {
                return Err(ParamError::new(field, ParamProblem::NotFinite(value)));
            }
        }
        for (field, value) in positive {
            if value <= 0.0 {
                return Err(ParamError::new(field, ParamProblem::NotPositive(value)));
            }
        }
        for (field, value) in non_negative {
            if value < 0.0 {
                return Err(ParamError::new(field, ParamProblem::Negative(value)));
            }
        }
        // Pairs at 120°k ± θ: θ = 0 makes two legs share a joint, θ = 60° merges neighbouring pairs.
        let sixty = 60f64.to_radians();
        for (field, value) in [
            ("base_joint_offset", g.base_joint_offset),
            ("platform_joint_offset", g.platform_joint_offset),
        ] {
            if value <= 1e-6 || value >= sixty - 1e-6 {
                return Err(ParamError::new(
                    field,
                    ParamProblem::OutOfRange {
                        value,
                        reason: "joint pairs coincide unless 0 < offset < 60°",
                    },
                ));
            }
        }
        Ok(())
    }
}

impl Params {
    /// The names [`Params::set_field`] accepts, one per real field (every field but the
    /// friction curve, an enumeration the plant FMU sets directly).
    pub const FIELDS: [&'static str; 19] = [
        "base_radius",
        "platform_radius",
        "home_height",
        "base_joint_offset",
        "platform_joint_offset",
        "platform_mass",
        "platform_inertia[1]",
        "platform_inertia[2]",
        "platform_inertia[3]",
        "cylinder_mass",
        "cylinder_com",
        "cylinder_inertia",
        "rod_mass",
        "rod_com",
        "rod_inertia",
        "viscous_friction",
        "coulomb_friction",
        "friction_velocity",
        "gravity",
    ];

    /// Sets the field with the docs/model.md / FMU variable name `name` (e.g. `rod_mass`,
    /// `platform_inertia[2]`, angles in rad). A name that is not one of [`Params::FIELDS`]
    /// is an error naming it, so a parameter renamed on one side only is caught instead of
    /// silently keeping its default.
    pub fn set_field(&mut self, name: &str, value: f64) -> Result<(), ParamError> {
        let slot = match name {
            "base_radius" => &mut self.geometry.base_radius,
            "platform_radius" => &mut self.geometry.platform_radius,
            "home_height" => &mut self.geometry.home_height,
            "base_joint_offset" => &mut self.geometry.base_joint_offset,
            "platform_joint_offset" => &mut self.geometry.platform_joint_offset,
            "platform_mass" => &mut self.platform.mass,
            "platform_inertia[1]" => &mut self.platform.inertia.x,
            "platform_inertia[2]" => &mut self.platform.inertia.y,
            "platform_inertia[3]" => &mut self.platform.inertia.z,
            "cylinder_mass" => &mut self.legs.cylinder_mass,
            "cylinder_com" => &mut self.legs.cylinder_com,
            "cylinder_inertia" => &mut self.legs.cylinder_inertia,
            "rod_mass" => &mut self.legs.rod_mass,
            "rod_com" => &mut self.legs.rod_com,
            "rod_inertia" => &mut self.legs.rod_inertia,
            "viscous_friction" => &mut self.friction.viscous,
            "coulomb_friction" => &mut self.friction.coulomb,
            "friction_velocity" => &mut self.friction.velocity,
            "gravity" => &mut self.gravity,
            _ => return Err(ParamError::new(name, ParamProblem::Unknown)),
        };
        *slot = value;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_field_reaches_every_field_and_validation_names_it() {
        for name in Params::FIELDS {
            let mut p = Params::default();
            p.set_field(name, 12345.0).unwrap();
            assert_ne!(p, Params::default(), "{name} changed nothing");
            // Each name reaches a slot of its own.
            for other in Params::FIELDS.iter().filter(|&&o| o != name) {
                let mut q = Params::default();
                q.set_field(other, 12345.0).unwrap();
                assert_ne!(p, q, "{name} and {other} set the same field");
            }
            p.set_field(name, f64::NAN).unwrap();
            let err = p.validate().unwrap_err().to_string();
            assert!(err.contains(&format!("`{name}`")), "{name}: {err}");
        }
    }

    #[test]
    fn unknown_names_are_errors_naming_them() {
        let mut p = Params::default();
        let err = p.set_field("initial_pose[1]", 0.0).unwrap_err();
        assert_eq!(err.field, "initial_pose[1]");
        assert_eq!(err.problem, ParamProblem::Unknown);
        let text = err.to_string();
        assert!(
            text.starts_with("parameter `initial_pose[1]` is not a mechanism parameter"),
            "{text}"
        );
        assert!(text.contains("rod_mass"), "{text}");
        assert_eq!(p, Params::default(), "nothing set");
    }

    /// The algebraic curve at points where x / √(1 + x²) is a fraction by hand
    /// (3-4-5, 5-12-13 and 1-1-√2 triangles), its limits and its oddness.
    #[test]
    fn algebraic_curve_matches_the_formula() {
        let s = |x| FrictionCurve::Algebraic.smoothed_sign(x);
        assert_eq!(s(0.0), 0.0);
        for (x, expected) in [
            (0.75, 0.6),
            (4.0 / 3.0, 0.8),
            (5.0 / 12.0, 5.0 / 13.0),
            (2.4, 12.0 / 13.0),
            (1.0, std::f64::consts::FRAC_1_SQRT_2),
            (3f64.sqrt(), 3f64.sqrt() / 2.0),
        ] {
            for (x, expected) in [(x, expected), (-x, -expected)] {
                assert!(
                    (s(x) - expected).abs() <= 4.0 * f64::EPSILON * expected.abs(),
                    "s({x}) = {} instead of {expected}",
                    s(x)
                );
            }
        }
        // 1 − s(x) ≈ 1/(2x²): 5e-7 at x = 1000, below one ulp of 1 beyond x ≈ 1e8.
        assert!((1.0 - s(1e3) - 0.5e-6).abs() < 1e-12, "{}", 1.0 - s(1e3));
        for x in [1e8, 1e154, 1e200, f64::MAX, f64::INFINITY] {
            assert_eq!(s(x), 1.0, "s({x})");
            assert_eq!(s(-x), -1.0, "s(-{x})");
        }
        assert!(s(f64::NAN).is_nan());
        // Odd and increasing, bounded by ±1, slope 1 at rest like tanh.
        let mut last = -1.0;
        for k in -400..=400 {
            let x = f64::from(k) * 0.0125;
            assert_eq!(s(-x), -s(x), "oddness at {x}");
            assert!(
                s(x) > last && s(x).abs() < 1.0,
                "monotone and bounded at {x}"
            );
            last = s(x);
        }
        let h = 1e-6;
        assert!(((s(h) - s(-h)) / (2.0 * h) - 1.0).abs() < 1e-10);
    }

    /// The friction's tanh is glibc's to the bit. Only where `f64::tanh` is glibc's: other
    /// C libraries compute tanh their own way. Should a glibc replace fdlibm's tanh, this
    /// fails with the distance in ulps; the friction would still be fdlibm's tanh.
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    #[test]
    fn tanh_is_libm_tanh_bit_for_bit() {
        let same = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        let ulps = |a: f64, b: f64| (a.to_bits() as i64).wrapping_sub(b.to_bits() as i64);
        let mut values = vec![
            0.0,
            f64::MIN_POSITIVE,
            5e-324,
            f64::from_bits(0x3c80_0000_0000_0000),
            f64::from_bits(0x3c7f_ffff_ffff_ffff),
            1.0,
            1.0 - f64::EPSILON / 2.0,
            1.0 + f64::EPSILON,
            22.0,
            22.0 - 22.0 * f64::EPSILON,
            19.06,
            f64::MAX,
            f64::INFINITY,
            f64::NAN,
        ];
        // Every binade from 2⁻⁶⁰ to 2⁶, sixteen bit patterns each, and a sweep through the
        // leg rates / friction velocity of a trial.
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        for e in -60..=6 {
            for _ in 0..16 {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let m = f64::from_bits(0x3ff0_0000_0000_0000 | (state >> 12));
                values.push(m * 2f64.powi(e));
            }
        }
        values.extend((0..200_000).map(|k| (f64::from(k) - 100_000.0) * 2.5e-4));
        let negated: Vec<f64> = values.iter().map(|v| -v).collect();
        values.extend(negated);
        values.resize(values.len().next_multiple_of(6), 0.5);
        for chunk in values.chunks_exact(6) {
            let six: [f64; 6] = chunk.try_into().unwrap();
            let ours6 = fdlibm_tanh::tanh6(&six);
            for (k, &x) in six.iter().enumerate() {
                let libm = x.tanh();
                let ours = fdlibm_tanh::tanh(x);
                assert!(
                    same(ours, libm),
                    "tanh({x:e}) = {ours:e}, libm {libm:e}: {} ulps apart; is this libm's tanh \
                     still fdlibm's?",
                    ulps(ours, libm)
                );
                assert!(
                    same(ours6[k], libm),
                    "tanh6 at {x:e}: {:e}, libm {libm:e}: {} ulps apart",
                    ours6[k],
                    ulps(ours6[k], libm)
                );
            }
        }
    }

    /// The default is tanh, and its force is the tanh law written out bit for bit.
    #[test]
    fn default_curve_is_tanh_unchanged() {
        let f = Friction::default();
        assert_eq!(f.curve, FrictionCurve::Tanh);
        assert_eq!(FrictionCurve::default(), FrictionCurve::Tanh);
        assert_eq!(Params::default().friction.curve, FrictionCurve::Tanh);
        for ldot in [-0.3_f64, -0.02, -1e-4, 0.0, 3e-3, 0.02, 0.07, 1.5] {
            let by_hand = -100.0 * ldot - 20.0 * (ldot / 0.02).tanh();
            assert_eq!(f.force(ldot).to_bits(), by_hand.to_bits(), "at {ldot} m/s");
        }
    }

    /// Friction opposes the motion with either curve, and the curves agree about rest and
    /// far from it but not in between (so the choice is visible).
    #[test]
    fn both_curves_dissipate_and_differ_only_in_saturation() {
        let tanh = Friction::default();
        let algebraic = Friction {
            curve: FrictionCurve::Algebraic,
            ..tanh
        };
        for f in [tanh, algebraic] {
            assert_eq!(f.force(0.0), 0.0);
            for k in 1..=200 {
                let ldot = 1e-5 * 1.08f64.powi(k);
                assert!(f.force(ldot) * ldot < 0.0, "{:?} at {ldot} m/s", f.curve);
                assert!(f.force(-ldot) * -ldot < 0.0, "{:?} at -{ldot} m/s", f.curve);
            }
        }
        let coulomb = |f: &Friction, ldot: f64| f.force(ldot) + f.viscous * ldot;
        // About rest both are −c_c·l̇/v_s to first order; at v_s they differ by 20·(0.762 − 0.707) N.
        assert!((coulomb(&tanh, 1e-7) - coulomb(&algebraic, 1e-7)).abs() < 1e-9);
        let at_scale = coulomb(&algebraic, 0.02) - coulomb(&tanh, 0.02);
        assert!((at_scale - 20.0 * (1f64.tanh() - 0.5f64.sqrt())).abs() < 1e-12);
        assert!((coulomb(&tanh, 100.0) - coulomb(&algebraic, 100.0)).abs() < 1e-6);
    }

    #[test]
    fn messages_read_as_before() {
        let mut p = Params::default();
        p.set_field("rod_mass", -1.0).unwrap();
        assert_eq!(
            p.validate().unwrap_err().to_string(),
            "parameter `rod_mass` = -1 must not be negative"
        );
    }
}
