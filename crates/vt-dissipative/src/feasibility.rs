//! Pre-flight feasibility: can the team hold the load's weight, with margin, at its cable lean?
//! (docs/design.md, "Pre-flight feasibility check").
//!
//! Per UAV, the largest tension `c` its cable may carry is the smaller of the cable's rating
//! and what the rotors can hold beyond the UAV's own weight at the allowed tilt
//! ([`rotor_capacity_n`]), with a fraction of the thrust kept for control: the rotors are
//! rated at `(1 - r_c) F_max` (issue 29; docs/design.md, "Control thrust reserve"). With `n` UAVs whose cables lean `theta` from vertical, the team's
//! available vertical force is `F_avail = n c cos(theta)`; the load needs `F_need = m_L g`.
//! The margin is `F_avail / F_need - 1`; the mission starts when it is at least the required
//! margin. The lean is an input: today the take-off formation's (host: the scenario's geometry;
//! firmware: the calibration's measured mean lean).
//!
//! Runs once, before take-off (host) and at mission start (firmware).

use crate::calibration::GRAVITY_MPS2;
use core::fmt;

/// Default required margin (fraction): 1 % (docs/design.md gives the reasons: 2 % before the
/// capacity-aware formation, which flies 19.8 kg at +1.4 % 10/10 and 20.0 kg at +0.4 % 9/10).
pub const DEFAULT_MIN_MARGIN: f32 = 0.01;

/// Default control thrust reserve `r_c`: the fraction of each UAV's largest thrust the check
/// keeps for control (attitude, formation and gusts), 10 % (docs/design.md, "Control thrust
/// reserve": generated teams hovering at 93 % of their thrust lost their formation in calm air).
pub const DEFAULT_THRUST_RESERVE: f32 = 0.1;

/// What the check needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeasibilityParams {
    /// Team size `n`.
    pub n_uavs: usize,
    /// Declared load mass `m_L`, kg.
    pub load_mass_kg: f32,
    /// Mass of one UAV `m_u`, kg.
    pub uav_mass_kg: f32,
    /// Largest thrust of one UAV `F_max`, N.
    pub thrust_max_n: f32,
    /// Largest tilt of the thrust from vertical `alpha`, rad.
    pub tilt_max_rad: f32,
    /// Rated tension of one cable `T_rated`, N.
    pub cable_rated_n: f32,
    /// The formation's cable lean, cos of the angle `theta` from vertical, in `(0, 1]`.
    pub cos_lean: f32,
    /// Required margin `F_avail / F_need - 1` (fraction; e.g. 0.02 = 2 %), > -1.
    pub min_margin: f32,
    /// Control thrust reserve `r_c`, fraction of `thrust_max_n` kept for control, in `[0, 0.5]`.
    pub thrust_reserve: f32,
}

/// The numbers of a feasible team.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Feasibility {
    /// Vertical force the load needs, `m_L g`, N.
    pub needed_n: f32,
    /// Vertical force the team has, `n c cos(theta)`, N.
    pub available_n: f32,
    /// `available / needed - 1` (fraction).
    pub margin: f32,
    /// Per-UAV cable tension capacity `c = min(T_rated, rotor capacity)`, N.
    pub capacity_n: f32,
    /// What the rotors can hold along the cable beyond the UAV's weight, N.
    pub rotor_capacity_n: f32,
}

/// Why a team may not start.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FeasibilityError {
    /// A parameter is NaN, infinite or out of range; names it.
    InvalidParameter(&'static str),
    /// The team cannot carry the load with the required margin.
    Infeasible {
        /// Vertical force the load needs, N.
        needed_n: f32,
        /// Vertical force the team has, N.
        available_n: f32,
        /// `available / needed - 1` (fraction).
        margin: f32,
        /// The required margin (fraction).
        min_margin: f32,
    },
}

impl fmt::Display for FeasibilityError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::InvalidParameter(name) => write!(f, "invalid feasibility parameter `{name}`"),
            Self::Infeasible { needed_n, available_n, margin, min_margin } => write!(
                f,
                "the team cannot carry the load with margin: needed vertical force {needed_n:.1} N, available {available_n:.1} N, margin {:.1} % (required {:.1} %)",
                100.0 * margin,
                100.0 * min_margin
            ),
        }
    }
}

impl core::error::Error for FeasibilityError {}

/// The largest cable tension, N, a UAV of weight `weight_n` with thrust `thrust_max_n` and
/// tilt limit `tilt_max_rad` holds at rest when its cable leans `acos(cos_lean)` from vertical
/// (docs/design.md): thrust `F = W e_z + T (sin theta, cos theta)`;
/// `|F| <= F_max` gives `T <= sqrt(F_max^2 - W^2 sin^2 theta) - W cos theta`, and the tilt
/// limit, for `theta > alpha`, `T <= W sin alpha / sin(theta - alpha)`. Never negative; 0 for
/// invalid input.
pub fn rotor_capacity_n(weight_n: f32, thrust_max_n: f32, tilt_max_rad: f32, cos_lean: f32) -> f32 {
    let sin2 = (1.0 - cos_lean * cos_lean).max(0.0);
    let sin_lean = vt_fpu::sqrt(sin2);
    let by_thrust = vt_fpu::sqrt((thrust_max_n * thrust_max_n - weight_n * weight_n * sin2).max(0.0)) - weight_n * cos_lean;
    // sin from cos on (0, pi/2), as vt-cfo's thrust limits do, by the same short cosine.
    let ca = vt_fpu::sin_cos(tilt_max_rad).map_or(f32::NAN, |sc| sc.1);
    let sa = vt_fpu::sqrt((1.0 - ca * ca).max(0.0));
    // sin(theta - alpha) > 0 exactly when the cable leans more than the tilt limit.
    let s = sin_lean * ca - cos_lean * sa;
    let by_tilt = if s > 0.0 { weight_n * sa / s } else { f32::INFINITY };
    let c = by_thrust.min(by_tilt);
    if c.is_finite() && c > 0.0 {
        c
    } else {
        0.0
    }
}

impl FeasibilityParams {
    /// The thrust the check lets a UAV hold in steady flight, `(1 - r_c) F_max`, N.
    pub fn sustained_thrust_n(&self) -> f32 {
        (1.0 - self.thrust_reserve) * self.thrust_max_n
    }

    /// Checks every field.
    ///
    /// # Errors
    /// [`FeasibilityError::InvalidParameter`] naming the field.
    pub fn validate(&self) -> Result<(), FeasibilityError> {
        let pos = |x: f32| x.is_finite() && x > 0.0;
        let checks: [(bool, &'static str); 9] = [
            (self.n_uavs > 0, "feasibility.n_uavs"),
            (pos(self.load_mass_kg), "feasibility.load_mass_kg"),
            (pos(self.uav_mass_kg), "feasibility.uav_mass_kg"),
            (pos(self.thrust_max_n), "feasibility.thrust_max_n"),
            (self.tilt_max_rad > 0.0 && self.tilt_max_rad < core::f32::consts::FRAC_PI_2, "feasibility.tilt_max_rad"),
            (pos(self.cable_rated_n), "feasibility.cable_rated_n"),
            (self.cos_lean > 0.0 && self.cos_lean <= 1.0, "feasibility.cos_lean"),
            (self.min_margin.is_finite() && self.min_margin > -1.0, "feasibility.min_margin"),
            ((0.0..=0.5).contains(&self.thrust_reserve), "feasibility.thrust_reserve"),
        ];
        for (ok, name) in checks {
            if !ok {
                return Err(FeasibilityError::InvalidParameter(name));
            }
        }
        Ok(())
    }
}

/// The pre-flight check (module docs).
///
/// # Errors
/// [`FeasibilityError::Infeasible`] with the numbers, or an invalid parameter.
pub fn check(p: &FeasibilityParams) -> Result<Feasibility, FeasibilityError> {
    p.validate()?;
    let needed_n = p.load_mass_kg * GRAVITY_MPS2;
    let rotor = rotor_capacity_n(p.uav_mass_kg * GRAVITY_MPS2, p.sustained_thrust_n(), p.tilt_max_rad, p.cos_lean);
    let capacity_n = p.cable_rated_n.min(rotor);
    let available_n = p.n_uavs as f32 * capacity_n * p.cos_lean;
    let margin = available_n / needed_n - 1.0;
    // `!(>=)`: a NaN margin is refused.
    if !(margin >= p.min_margin) {
        return Err(FeasibilityError::Infeasible { needed_n, available_n, margin, min_margin: p.min_margin });
    }
    Ok(Feasibility { needed_n, available_n, margin, capacity_n, rotor_capacity_n: rotor })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The paper's team: 10 x 2 kg UAVs with 50 N of thrust, 35 deg tilt, 20 N cables, the
    /// take-off lean atan(3/10), 18 kg load.
    fn paper() -> FeasibilityParams {
        FeasibilityParams {
            n_uavs: 10,
            load_mass_kg: 18.0,
            uav_mass_kg: 2.0,
            thrust_max_n: 50.0,
            tilt_max_rad: 35.0f32.to_radians(),
            cable_rated_n: 20.0,
            cos_lean: 10.0 / 109.0f32.sqrt(),
            min_margin: DEFAULT_MIN_MARGIN,
            thrust_reserve: 0.0,
        }
    }

    #[test]
    fn the_paper_mission_passes_with_its_8_5_percent() {
        let f = check(&paper()).unwrap();
        assert!((f.needed_n - 176.58).abs() < 1e-3, "{f:?}");
        assert!((f.available_n - 191.57).abs() < 0.01, "{f:?}");
        assert!((f.margin - 0.0849).abs() < 5e-4, "{f:?}");
        assert_eq!(f.capacity_n, 20.0); // the cable binds: the rotors hold ~30.9 N
        assert!((f.rotor_capacity_n - 30.89).abs() < 0.01, "{f:?}");
    }

    #[test]
    fn rotor_capacity_by_hand() {
        // Straight down: all thrust beyond the weight, 50 - 19.62 N.
        assert!((rotor_capacity_n(19.62, 50.0, 0.6, 1.0) - 30.38).abs() < 1e-4);
        // theta = 60 deg > alpha = 30 deg: the tilt binds, W sin 30 / sin 30 = W.
        let c = rotor_capacity_n(10.0, 1000.0, 30.0f32.to_radians(), 0.5);
        assert!((c - 10.0).abs() < 1e-4, "{c}");
        // Thrust below the weight: nothing to spare.
        assert_eq!(rotor_capacity_n(30.0, 20.0, 0.6, 1.0), 0.0);
    }

    #[test]
    fn the_physical_limit_at_the_adapted_lean_passes_19_8_kg_and_refuses_20_kg() {
        // 10 x 20 N at the capacity-aware formation's most vertical lean for the paper team
        // (UAVs 0.9 m apart: cos 0.98522, capacity::tests): 19.8 kg has 1.45 % margin (flies
        // 10/10 with sensor noise), 20.0 kg 0.43 % (9/10).
        let near = FeasibilityParams { load_mass_kg: 19.8, cos_lean: 0.98522, ..paper() };
        let f = check(&near).unwrap();
        assert!(f.margin > 0.014 && f.margin < 0.015, "{f:?}");
        let heavy = FeasibilityParams { load_mass_kg: 20.0, ..near };
        match check(&heavy) {
            Err(FeasibilityError::Infeasible { needed_n, available_n, margin, min_margin }) => {
                assert!((needed_n - 196.2).abs() < 1e-3);
                assert!((available_n - 197.04).abs() < 0.01);
                assert!((margin - (available_n / needed_n - 1.0)).abs() < 1e-7);
                assert_eq!(min_margin, 0.01);
            }
            other => panic!("{other:?}"),
        }
        // 19.5 kg at the paper's lean: 0.2 % (the 2 m sag) is refused.
        assert!(check(&FeasibilityParams { load_mass_kg: 19.5, ..paper() }).is_err());
        assert!(check(&FeasibilityParams { load_mass_kg: 19.0, ..paper() }).is_ok());
        // A scenario may ask for less (or more).
        assert!(check(&FeasibilityParams { load_mass_kg: 19.5, min_margin: 0.0, ..paper() }).is_ok());
        assert!(check(&FeasibilityParams { min_margin: 0.1, ..paper() }).is_err());
    }

    #[test]
    fn weak_rotors_bind_before_the_cable() {
        // The experiment: 1.47 kg, 30 N, 30 deg, 30 N cables, lean atan(1.5/4), 3.06 kg.
        let p = FeasibilityParams {
            n_uavs: 3,
            load_mass_kg: 3.06,
            uav_mass_kg: 1.47,
            thrust_max_n: 30.0,
            tilt_max_rad: 30.0f32.to_radians(),
            cable_rated_n: 30.0,
            cos_lean: 4.0 / 18.25f32.sqrt(),
            min_margin: DEFAULT_MIN_MARGIN,
            thrust_reserve: 0.0,
        };
        let f = check(&p).unwrap();
        assert!(f.capacity_n < 30.0 && f.capacity_n == f.rotor_capacity_n, "{f:?}");
        assert!((f.rotor_capacity_n - 16.07).abs() < 0.01, "{f:?}");
        // With the default control reserve the rotors are rated at 27 N: by the same formula
        // sqrt(27^2 - W^2 sin^2) - W cos, W = 14.42 N, cos = 4 / sqrt(18.25).
        let r = check(&FeasibilityParams { thrust_reserve: DEFAULT_THRUST_RESERVE, ..p }).unwrap();
        let (w, c) = (1.47 * GRAVITY_MPS2, 4.0 / 18.25f32.sqrt());
        let by_hand = (27.0f32 * 27.0 - w * w * (1.0 - c * c)).sqrt() - w * c;
        assert!((r.rotor_capacity_n - by_hand).abs() < 1e-3 && (r.rotor_capacity_n - 13.02).abs() < 0.01, "{r:?}");
        // The experiment's 3.06 kg still flies: 3 x 13.02 N x cos 0.936 = 36.6 N against 30.0 N.
        assert!(r.margin > 0.2, "{r:?}");
    }

    #[test]
    fn the_control_reserve_keeps_a_hovering_uav_below_full_thrust() {
        // At the reserve's limit, a UAV's steady thrust (weight plus its share along the cable)
        // is exactly the sustained thrust (1 - r_c) F_max, whatever the lean.
        for (cos, r_c) in [(1.0f32, 0.1f32), (0.9, 0.1), (0.95, 0.3), (0.8, 0.0)] {
            let p = FeasibilityParams { thrust_reserve: r_c, cos_lean: cos, tilt_max_rad: 1.2, cable_rated_n: 1e4, ..paper() };
            let c = check(&p).map(|f| f.rotor_capacity_n).unwrap_or_else(|e| match e {
                FeasibilityError::Infeasible { available_n, .. } => available_n / (p.n_uavs as f32 * cos),
                e @ FeasibilityError::InvalidParameter(_) => panic!("{e:?}"),
            });
            let w = p.uav_mass_kg * GRAVITY_MPS2;
            let s = (1.0 - cos * cos).sqrt();
            let thrust = ((c * s).powi(2) + (w + c * cos).powi(2)).sqrt();
            assert!((thrust - (1.0 - r_c) * p.thrust_max_n).abs() < 1e-3, "cos {cos} r_c {r_c}: {thrust}");
        }
    }

    #[test]
    fn invalid_parameters_are_named() {
        let cases: [(FeasibilityParams, &str); 9] = [
            (FeasibilityParams { n_uavs: 0, ..paper() }, "feasibility.n_uavs"),
            (FeasibilityParams { load_mass_kg: 0.0, ..paper() }, "feasibility.load_mass_kg"),
            (FeasibilityParams { uav_mass_kg: f32::NAN, ..paper() }, "feasibility.uav_mass_kg"),
            (FeasibilityParams { thrust_max_n: f32::INFINITY, ..paper() }, "feasibility.thrust_max_n"),
            (FeasibilityParams { tilt_max_rad: 1.6, ..paper() }, "feasibility.tilt_max_rad"),
            (FeasibilityParams { cable_rated_n: -1.0, ..paper() }, "feasibility.cable_rated_n"),
            (FeasibilityParams { cos_lean: 0.0, ..paper() }, "feasibility.cos_lean"),
            (FeasibilityParams { min_margin: -1.0, ..paper() }, "feasibility.min_margin"),
            (FeasibilityParams { thrust_reserve: 0.6, ..paper() }, "feasibility.thrust_reserve"),
        ];
        for (p, name) in cases {
            assert_eq!(check(&p), Err(FeasibilityError::InvalidParameter(name)));
        }
    }

    proptest! {
        /// Any valid input: Ok exactly when the margin reaches the requirement, the numbers are
        /// consistent and finite, and more load never turns a refusal into a start.
        #[test]
        fn verdict_matches_the_numbers_and_is_monotone_in_the_load(
            n in 1usize..64, load in 0.1f32..500.0, uav in 0.2f32..20.0, thrust in 1.0f32..500.0,
            tilt in 0.05f32..1.5, rated in 1.0f32..500.0, cos in 0.05f32..=1.0, min_margin in -0.5f32..0.5,
            thrust_reserve in 0.0f32..=0.5,
        ) {
            let p = FeasibilityParams { n_uavs: n, load_mass_kg: load, uav_mass_kg: uav, thrust_max_n: thrust, tilt_max_rad: tilt, cable_rated_n: rated, cos_lean: cos, min_margin, thrust_reserve };
            let (needed, available, margin) = match check(&p) {
                Ok(f) => {
                    prop_assert!(f.margin >= min_margin);
                    prop_assert!(f.capacity_n <= rated && f.capacity_n <= f.rotor_capacity_n && f.capacity_n >= 0.0);
                    (f.needed_n, f.available_n, f.margin)
                }
                Err(FeasibilityError::Infeasible { needed_n, available_n, margin, .. }) => {
                    prop_assert!(margin < min_margin);
                    (needed_n, available_n, margin)
                }
                Err(e) => return Err(TestCaseError::fail(format!("{e:?}"))),
            };
            prop_assert!(needed.is_finite() && available.is_finite() && margin.is_finite());
            prop_assert!(available <= n as f32 * rated * cos * (1.0 + 1e-6));
            let heavier = FeasibilityParams { load_mass_kg: load * 1.5, ..p };
            if check(&p).is_err() {
                prop_assert!(check(&heavier).is_err());
            }
        }
    }
}
