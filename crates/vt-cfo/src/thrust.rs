//! Thrust-vector limits and the thrust-vector <-> attitude-setpoint conversion.
//!
//! # Frames
//!
//! Thrust vectors are in the ENU world frame (N, `z` up). The body frame is FLU (`x` forward,
//! `y` left, `z` up along the rotor axis, so thrust = `|T| * z_body`). Attitudes are nalgebra
//! `UnitQuaternion`s (Hamilton convention) rotating body vectors into the world frame
//! (`v_world = q * v_body`). A heading is the unit vector `(cos psi, sin psi)` of the body `x`
//! axis projected on the horizontal plane, `psi` measured from east towards north; it is passed
//! as a vector so that no trigonometry runs in the control step.

use nalgebra::{Quaternion, UnitQuaternion, UnitVector2, Vector3};

use crate::CfoError;

/// Default maximum thrust, N (REFERENCE §6 prototype: thrust limit 50 N).
const DEFAULT_THRUST_MAX_N: f32 = 50.0;
/// Default minimum thrust as a fraction of the maximum (keeps the rotors spinning and the
/// attitude controllable; PX4 `MPC_THR_MIN` is 12 % of throttle, 5 % of thrust is a project
/// choice).
const DEFAULT_THRUST_MIN_FRACTION: f32 = 0.05;
/// Default maximum tilt: 45 deg (PX4 `MPC_TILTMAX_AIR` default); `cos 45 deg = 1/sqrt 2`.
const DEFAULT_TILT_MAX_COS: f32 = core::f32::consts::FRAC_1_SQRT_2;
/// `tan 45 deg`.
const DEFAULT_TILT_MAX_TAN: f32 = 1.0;
/// Below this thrust magnitude, N, the thrust direction is undefined: level attitude, zero
/// collective.
const DEGENERATE_THRUST_N: f32 = 1.0e-4;
/// Below this `|y_c x z_b|` the heading cannot fix body `x` (thrust nearly horizontal and along
/// `y_c`): body `x` is the heading projected onto the plane normal to `z_b` instead.
const DEGENERATE_CROSS: f32 = 1.0e-3;

/// Limits on the thrust vector: magnitude in `[thrust_min_n, thrust_max_n]` for the vertical
/// part, `|T| <= thrust_max_n`, and tilt from the vertical `<= tilt_max`.
///
/// The tilt limit is stored as its cosine and tangent, computed once at construction, so that
/// [`clamp`](Self::clamp) runs no trigonometry.
///
/// # Examples
///
/// ```
/// use approx::assert_relative_eq;
/// use nalgebra::Vector3;
/// use vt_cfo::ThrustLimits;
///
/// let limits = ThrustLimits::new(2.5, 50.0, core::f32::consts::FRAC_PI_4)?;
/// // 40 N sideways on 20 N up leans 63 deg: the horizontal part is cut to 20 N (45 deg).
/// let t = limits.clamp(Vector3::new(40.0, 0.0, 20.0), 19.62);
/// assert_relative_eq!(t, Vector3::new(20.0, 0.0, 20.0), epsilon = 1e-4);
/// // NaN falls back to the hover thrust.
/// let t = limits.clamp(Vector3::new(f32::NAN, 0.0, 0.0), 19.62);
/// assert_relative_eq!(t, Vector3::new(0.0, 0.0, 19.62));
/// # Ok::<(), vt_cfo::CfoError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThrustLimits {
    thrust_min_n: f32,
    thrust_max_n: f32,
    tilt_max_cos: f32,
    tilt_max_tan: f32,
    /// Largest vertical component, N: `thrust_max_n`, or `sqrt(thrust_max^2 - reserve^2)` with a
    /// horizontal reserve.
    vertical_max_n: f32,
}

impl ThrustLimits {
    /// Checks the limits and precomputes `cos(tilt_max_rad)` and `tan(tilt_max_rad)` (the only
    /// trigonometry in the crate, run once here).
    ///
    /// # Errors
    ///
    /// [`CfoError::InvalidThrustMin`] if `thrust_min_n` is not finite or negative;
    /// [`CfoError::InvalidThrustMax`] if `thrust_max_n` is not finite or `<= thrust_min_n`;
    /// [`CfoError::InvalidTiltMax`] if `tilt_max_rad` is not in `(0, pi/2)`.
    pub fn new(thrust_min_n: f32, thrust_max_n: f32, tilt_max_rad: f32) -> Result<Self, CfoError> {
        if !(thrust_min_n.is_finite() && thrust_min_n >= 0.0) {
            return Err(CfoError::InvalidThrustMin);
        }
        if !(thrust_max_n.is_finite() && thrust_max_n > thrust_min_n) {
            return Err(CfoError::InvalidThrustMax);
        }
        if !(tilt_max_rad > 0.0 && tilt_max_rad < core::f32::consts::FRAC_PI_2) {
            return Err(CfoError::InvalidTiltMax);
        }
        // `vt_fpu`'s short cosine (within 1 ulp of `libm::cosf` here): `libm`'s brings its full
        // range reduction and `f64` arithmetic, about 7 KiB of the flight MCU's flash.
        let tilt_max_cos = vt_fpu::sin_cos(tilt_max_rad).map_or(f32::NAN, |sc| sc.1);
        // tan = sin / cos with sin = sqrt(1 - cos^2) on (0, pi/2).
        let tilt_max_tan = vt_fpu::sqrt(1.0 - tilt_max_cos * tilt_max_cos) / tilt_max_cos;
        if !(tilt_max_cos > 0.0 && tilt_max_tan.is_finite() && tilt_max_tan > 0.0) {
            return Err(CfoError::InvalidTiltMax);
        }
        Ok(Self {
            thrust_min_n,
            thrust_max_n,
            tilt_max_cos,
            tilt_max_tan,
            vertical_max_n: thrust_max_n,
        })
    }

    /// The same limits with the tilt cone's tangent `tilt_max_tan` (the tangent of the largest
    /// tilt from the vertical); a non-finite or non-positive tangent keeps `self`.
    #[must_use]
    pub fn with_tilt_max_tan(self, tilt_max_tan: f32) -> Self {
        if !vt_fpu::positive_finite(tilt_max_tan) {
            return self;
        }
        // cos = 1 / sqrt(1 + tan^2) on (0, pi/2).
        Self { tilt_max_cos: 1.0 / vt_fpu::sqrt(1.0 + tilt_max_tan * tilt_max_tan), tilt_max_tan, ..self }
    }

    /// The same limits keeping `fraction` (in `[0, 1)`) of `thrust_max_n` for the horizontal
    /// part: the vertical component is capped at `thrust_max_n sqrt(1 - fraction^2)`, so a
    /// saturated climb can never starve the horizontal demand (tube keeping, springs) of
    /// `fraction thrust_max_n` (within the tilt cone), and no UAV pulls on its cable with more
    /// than that cap less its weight. Beyond the paper, whose clamp gives the vertical demand
    /// priority; PX4's `MPC_THR_XY_MARG` keeps a margin only while the horizontal demand asks
    /// for it, which measured worse here (docs/design.md, "Overload in flight"). 0 keeps the
    /// vertical priority bit for bit.
    ///
    /// # Errors
    ///
    /// [`CfoError::InvalidHorizontalReserve`] when `fraction` is NaN, outside `[0, 1)`, or leaves
    /// the vertical cap at or below `thrust_min_n`.
    pub fn with_horizontal_reserve(self, fraction: f32) -> Result<Self, CfoError> {
        if !(0.0..1.0).contains(&fraction) {
            return Err(CfoError::InvalidHorizontalReserve);
        }
        let vertical_max_n = if fraction == 0.0 {
            self.thrust_max_n
        } else {
            self.thrust_max_n * vt_fpu::sqrt((1.0 - fraction) * (1.0 + fraction))
        };
        if !(vertical_max_n.is_finite() && vertical_max_n > self.thrust_min_n) {
            return Err(CfoError::InvalidHorizontalReserve);
        }
        Ok(Self { vertical_max_n, ..self })
    }

    /// The horizontal reserve an airframe can afford while its vertical cap still holds its
    /// weight plus the cable pull `pull_n` (docs/design.md, "Overload in flight"; derived
    /// aboard from the companion's `VL_MASS`, `VL_T_MAX` and its `reserve_pull_n`: the cable's
    /// rating, or the declared load's share when that is less, issue 29):
    /// `min(cap, sqrt(1 - ((m g + pull) / T_max)^2))`, 0 when the airframe cannot lift that
    /// much at all. Every degenerate input (NaN, `T_max <= 0`) gives 0: the paper's vertical
    /// priority.
    #[must_use]
    pub fn rated_pull_reserve(mass_kg: f32, pull_n: f32, thrust_max_n: f32, cap: f32) -> f32 {
        let need = (mass_kg * crate::GRAVITY_MPS2 + pull_n) / thrust_max_n;
        if !((0.0..1.0).contains(&need) && cap > 0.0) {
            return 0.0;
        }
        let room = vt_fpu::sqrt((1.0 - need) * (1.0 + need));
        if room < cap { room } else { cap }
    }

    /// Largest vertical thrust component, N (`thrust_max_n` without a horizontal reserve). The
    /// hover thrust must stay below it.
    #[must_use]
    pub fn vertical_max_n(&self) -> f32 {
        self.vertical_max_n
    }

    /// Smallest vertical thrust component, N.
    #[must_use]
    pub fn thrust_min_n(&self) -> f32 {
        self.thrust_min_n
    }

    /// Largest thrust magnitude, N.
    #[must_use]
    pub fn thrust_max_n(&self) -> f32 {
        self.thrust_max_n
    }

    /// Cosine of the largest tilt from the vertical.
    #[must_use]
    pub fn tilt_max_cos(&self) -> f32 {
        self.tilt_max_cos
    }

    /// Tangent of the largest tilt from the vertical.
    #[must_use]
    pub fn tilt_max_tan(&self) -> f32 {
        self.tilt_max_tan
    }

    /// Clamps a thrust demand (N, ENU) to the limits, vertical first (PX4 `PositionControl`
    /// style):
    ///
    /// 1. `T_z` to `[thrust_min_n, thrust_max_n]` (to [`vertical_max_n`](Self::vertical_max_n)
    ///    with a horizontal reserve);
    /// 2. the horizontal part to `min(T_z tan(tilt_max), sqrt(thrust_max^2 - T_z^2))`, keeping
    ///    its direction.
    ///
    /// A vector already inside the limits is returned unchanged. A demand with a NaN or
    /// infinite component becomes `(0, 0, hover_thrust_n)` (clamped; a non-finite
    /// `hover_thrust_n` becomes `thrust_min_n`). The result is always finite.
    #[must_use]
    pub fn clamp(&self, thrust_n: Vector3<f32>, hover_thrust_n: f32) -> Vector3<f32> {
        let t = if vt_fpu::all_finite(&thrust_n) {
            thrust_n
        } else {
            let hover_n = if hover_thrust_n.is_finite() {
                hover_thrust_n
            } else {
                self.thrust_min_n
            };
            Vector3::new(0.0, 0.0, hover_n)
        };
        // Vertical priority below the horizontal reserve's cap (max/min rather than f32::clamp:
        // never panics). `vt_fpu::min`/`max` (a compare and a select; `f32::min`/`max` are calls
        // to `fminf`/`fmaxf` on the Cortex-M4F): `t` is finite here, and a NaN limit is ignored
        // as by `f32::max`/`min`.
        let tz = vt_fpu::min(vt_fpu::max(t.z, self.thrust_min_n), self.vertical_max_n);
        // Horizontal budget: tilt cone and magnitude sphere.
        let h_sphere = vt_fpu::sqrt(vt_fpu::max((self.thrust_max_n - tz) * (self.thrust_max_n + tz), 0.0));
        let h_max = vt_fpu::min(tz * self.tilt_max_tan, h_sphere);
        // |(T_x, T_y)| without overflow: scale by the larger component first.
        let s = vt_fpu::max(t.x.abs(), t.y.abs());
        if s == 0.0 {
            return Vector3::new(0.0, 0.0, tz);
        }
        let (ux, uy) = (t.x / s, t.y / s);
        let u_norm = vt_fpu::sqrt(ux * ux + uy * uy); // in [1, sqrt 2]
        if s * u_norm <= h_max {
            Vector3::new(t.x, t.y, tz)
        } else {
            let k = h_max / u_norm;
            Vector3::new(ux * k, uy * k, tz)
        }
    }
}

impl Default for ThrustLimits {
    /// 2.5 N .. 50 N, 45 deg tilt.
    fn default() -> Self {
        Self {
            thrust_min_n: DEFAULT_THRUST_MIN_FRACTION * DEFAULT_THRUST_MAX_N,
            thrust_max_n: DEFAULT_THRUST_MAX_N,
            tilt_max_cos: DEFAULT_TILT_MAX_COS,
            tilt_max_tan: DEFAULT_TILT_MAX_TAN,
            vertical_max_n: DEFAULT_THRUST_MAX_N,
        }
    }
}

/// What an autopilot's attitude setpoint takes: orientation and normalised collective thrust.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AttitudeSetpoint {
    /// Body (FLU) to world (ENU) rotation, Hamilton convention.
    pub attitude: UnitQuaternion<f32>,
    /// `|T| / thrust_max`, in `[0, 1]`.
    pub collective: f32,
}

/// Converts a thrust vector (N, ENU) and a heading into an attitude setpoint (PX4
/// `ControlMath::bodyzToAttitude`, with the ENU/FLU axes of this crate).
///
/// `z_b = T/|T|`; `y_c = (-sin psi, cos psi, 0)` from `heading = (cos psi, sin psi)`;
/// `x_b = normalize(y_c x z_b)` (negated when `z_b` points down, to keep the nose forward);
/// `y_b = z_b x x_b`; the quaternion comes from the rotation matrix `[x_b y_b z_b]` by
/// branching on its trace (nalgebra `UnitQuaternion::from_rotation_matrix`: square roots only,
/// no trigonometry). `collective = |T| / thrust_max_n` clamped to `[0, 1]`.
///
/// Degenerate cases (no NaN): `|T|` below 1e-4 N or non-finite -> level attitude with the given
/// heading and zero collective (the caller's thrust must be finite: [`ThrustLimits::clamp`]
/// guarantees it); `z_b` nearly parallel to `y_c` -> `x_b` is the heading projected onto the
/// plane normal to `z_b`. A non-positive or non-finite `thrust_max_n` gives zero collective.
///
/// # Examples
///
/// ```
/// use approx::assert_relative_eq;
/// use nalgebra::{UnitVector2, Vector2, Vector3};
/// use vt_cfo::{attitude_to_thrust, thrust_to_attitude};
///
/// let heading = UnitVector2::new_normalize(Vector2::new(0.0, 1.0)); // nose north
/// let thrust_n = Vector3::new(3.0, -4.0, 20.0);
/// let sp = thrust_to_attitude(thrust_n, heading, 50.0);
/// assert_relative_eq!(sp.attitude * Vector3::z(), thrust_n.normalize(), epsilon = 1e-6);
/// assert_relative_eq!(sp.collective, vt_fpu::norm(&thrust_n) / 50.0);
/// let back = attitude_to_thrust(sp.attitude, sp.collective, 50.0);
/// assert_relative_eq!(back, thrust_n, max_relative = 1e-5);
/// ```
#[must_use]
pub fn thrust_to_attitude(
    thrust_n: Vector3<f32>,
    heading: UnitVector2<f32>,
    thrust_max_n: f32,
) -> AttitudeSetpoint {
    let (cos_psi, sin_psi) = (heading.x, heading.y);
    let heading_3d = Vector3::new(cos_psi, sin_psi, 0.0);
    let y_c = Vector3::new(-sin_psi, cos_psi, 0.0);

    let Some((z_b, thrust_norm_n)) = direction_and_norm(&thrust_n) else {
        // Level, nose along the heading: x_b = heading, y_b = y_c, z_b = up.
        return AttitudeSetpoint {
            attitude: attitude_from_axes(&heading_3d, &y_c, &Vector3::z()),
            collective: 0.0,
        };
    };

    let mut x_b = y_c.cross(&z_b);
    if z_b.z < 0.0 {
        x_b = -x_b; // keep the nose forward when inverted (PX4 bodyzToAttitude)
    }
    let cross_norm = vt_fpu::norm(&x_b);
    let x_b = if cross_norm > DEGENERATE_CROSS {
        x_b / cross_norm
    } else {
        // z_b ~ +-y_c, so the heading is nearly normal to z_b: project it (norm ~ 1).
        let p = heading_3d - z_b * heading_3d.dot(&z_b);
        p / vt_fpu::norm(&p)
    };
    // Re-orthogonalise so that [x_b y_b z_b] is orthonormal to rounding, z_b exact.
    let y_b = z_b.cross(&x_b);
    let y_b = y_b / vt_fpu::norm(&y_b);
    let x_b = y_b.cross(&z_b);

    // thrust_norm_n > 0 here (possibly +inf for huge finite input): the ratio is never NaN.
    let collective = if vt_fpu::positive_finite(thrust_max_n) {
        vt_fpu::min(thrust_norm_n / thrust_max_n, 1.0)
    } else {
        0.0
    };
    AttitudeSetpoint {
        attitude: attitude_from_axes(&x_b, &y_b, &z_b),
        collective,
    }
}

/// The thrust vector (N, ENU) an attitude setpoint asks for: `collective * thrust_max_n * (R e3)`
/// (inverse of [`thrust_to_attitude`] for thrusts up to `thrust_max_n`).
///
/// # Examples
///
/// ```
/// use approx::assert_relative_eq;
/// use nalgebra::{UnitQuaternion, Vector3};
/// use vt_cfo::attitude_to_thrust;
///
/// let t = attitude_to_thrust(UnitQuaternion::identity(), 0.4, 50.0);
/// assert_relative_eq!(t, Vector3::new(0.0, 0.0, 20.0));
/// ```
#[must_use]
pub fn attitude_to_thrust(
    attitude: UnitQuaternion<f32>,
    collective: f32,
    thrust_max_n: f32,
) -> Vector3<f32> {
    attitude * Vector3::z() * (collective * thrust_max_n)
}

/// Unit direction and norm of `v`, or `None` when `v` is non-finite or shorter than
/// [`DEGENERATE_THRUST_N`]. Scales by the largest component first (no overflow).
fn direction_and_norm(v: &Vector3<f32>) -> Option<(Vector3<f32>, f32)> {
    if !vt_fpu::all_finite(v) {
        return None;
    }
    let s = v.amax();
    if s <= 0.0 {
        return None;
    }
    let u = v / s;
    let u_norm = vt_fpu::norm(&u); // in [1, sqrt 3]
    let norm = s * u_norm;
    if norm <= DEGENERATE_THRUST_N {
        return None;
    }
    Some((u / u_norm, norm))
}

/// Body-to-world quaternion from the body axes expressed in the world frame (columns of R).
fn attitude_from_axes(
    x_b: &Vector3<f32>,
    y_b: &Vector3<f32>,
    z_b: &Vector3<f32>,
) -> UnitQuaternion<f32> {
    // R = [x_b y_b z_b]; r_ij = row i of column j.
    let (r00, r10, r20) = (x_b.x, x_b.y, x_b.z);
    let (r01, r11, r21) = (y_b.x, y_b.y, y_b.z);
    let (r02, r12, r22) = (z_b.x, z_b.y, z_b.z);
    // Branch-on-trace conversion (square roots only): nalgebra's `from_rotation_matrix`
    // operation for operation, with the FPU's square root (vt-fpu), so the result is the same
    // bits on every target.
    let tr = r00 + r11 + r22;
    let q = if tr > 0.0 {
        let d = vt_fpu::sqrt(tr + 1.0) * 2.0;
        Quaternion::new(0.25 * d, (r21 - r12) / d, (r02 - r20) / d, (r10 - r01) / d)
    } else if r00 > r11 && r00 > r22 {
        let d = vt_fpu::sqrt(1.0 + r00 - r11 - r22) * 2.0;
        Quaternion::new((r21 - r12) / d, 0.25 * d, (r01 + r10) / d, (r02 + r20) / d)
    } else if r11 > r22 {
        let d = vt_fpu::sqrt(1.0 + r11 - r00 - r22) * 2.0;
        Quaternion::new((r02 - r20) / d, (r01 + r10) / d, 0.25 * d, (r12 + r21) / d)
    } else {
        let d = vt_fpu::sqrt(1.0 + r22 - r00 - r11) * 2.0;
        Quaternion::new((r10 - r01) / d, (r02 + r20) / d, (r12 + r21) / d, 0.25 * d)
    };
    // Re-normalise away rounding (as `UnitQuaternion::new_normalize`).
    UnitQuaternion::new_unchecked(Quaternion::from(q.coords / vt_fpu::norm(&q.coords)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use nalgebra::Vector2;
    use proptest::prelude::*;

    const HOVER_N: f32 = 19.62;
    /// Relative slack for comparisons that are exact up to f32 rounding.
    const ROUNDING: f32 = 4.0 * f32::EPSILON;

    fn limits() -> ThrustLimits {
        ThrustLimits::default()
    }

    fn within_limits(t: &Vector3<f32>, l: &ThrustLimits) -> bool {
        let n = t.norm();
        n <= l.thrust_max_n() * (1.0 + ROUNDING)
            && t.z >= l.thrust_min_n()
            && t.z >= l.tilt_max_cos() * n * (1.0 - ROUNDING)
    }

    #[test]
    fn rated_pull_reserve_keeps_the_weight_plus_rated_pull_under_the_vertical_cap() {
        // Paper airframe (2 kg, 50 N) on 20 N cables: need = 39.62 / 50, room 0.61 -> cap 0.5.
        assert_eq!(ThrustLimits::rated_pull_reserve(2.0, 20.0, 50.0, 0.5), 0.5);
        // Experiment airframe (1.47 kg, 30 N) on 30 N cables: it cannot lift its rated pull.
        assert_eq!(ThrustLimits::rated_pull_reserve(1.47, 30.0, 30.0, 0.5), 0.0);
        // Degenerate inputs: the paper's vertical priority.
        for (m, r, t) in [(f32::NAN, 1.0, 50.0), (2.0, 1.0, 0.0), (2.0, 1.0, -5.0), (2.0, f32::INFINITY, 50.0)] {
            assert_eq!(ThrustLimits::rated_pull_reserve(m, r, t, 0.5), 0.0, "{m} {r} {t}");
        }
    }

    proptest! {
        #[test]
        fn rated_pull_reserve_is_bounded_and_leaves_the_need(m in 0.1f32..10.0, rated in 0.0f32..100.0, t_max in 1.0f32..200.0) {
            let r = ThrustLimits::rated_pull_reserve(m, rated, t_max, 0.5);
            prop_assert!((0.0..=0.5).contains(&r));
            if r > 0.0 {
                // The vertical cap with this reserve still lifts weight + rated pull.
                let cap = t_max * vt_fpu::sqrt((1.0 - r) * (1.0 + r));
                prop_assert!(cap >= (m * crate::GRAVITY_MPS2 + rated) * (1.0 - ROUNDING), "cap {cap}");
            }
        }
    }

    /// Any f32, including NaN, infinities and huge values.
    fn any_component() -> impl Strategy<Value = f32> {
        prop_oneof![
            4 => -200.0f32..200.0,
            1 => any::<f32>(),
            1 => Just(f32::NAN),
            1 => Just(f32::INFINITY),
            1 => Just(f32::NEG_INFINITY),
            1 => Just(f32::MAX),
        ]
    }

    fn heading(angle_rad: f32) -> UnitVector2<f32> {
        UnitVector2::new_normalize(Vector2::new(angle_rad.cos(), angle_rad.sin()))
    }

    #[test]
    fn limits_reject_bad_values() {
        assert_eq!(
            ThrustLimits::new(-1.0, 50.0, 0.5),
            Err(CfoError::InvalidThrustMin)
        );
        assert_eq!(
            ThrustLimits::new(5.0, 5.0, 0.5),
            Err(CfoError::InvalidThrustMax)
        );
        assert_eq!(
            ThrustLimits::new(0.0, f32::NAN, 0.5),
            Err(CfoError::InvalidThrustMax)
        );
        assert_eq!(
            ThrustLimits::new(0.0, 50.0, core::f32::consts::FRAC_PI_2),
            Err(CfoError::InvalidTiltMax)
        );
        assert_eq!(
            ThrustLimits::new(0.0, 50.0, 0.0),
            Err(CfoError::InvalidTiltMax)
        );
    }

    #[test]
    fn default_limits_match_the_validating_constructor() {
        let made = ThrustLimits::new(2.5, 50.0, core::f32::consts::FRAC_PI_4).unwrap();
        let d = ThrustLimits::default();
        assert_relative_eq!(made.tilt_max_cos(), d.tilt_max_cos(), epsilon = 1e-6);
        assert_relative_eq!(made.tilt_max_tan(), d.tilt_max_tan(), epsilon = 1e-6);
        assert_eq!(made.thrust_min_n(), d.thrust_min_n());
        assert_eq!(made.thrust_max_n(), d.thrust_max_n());
    }

    #[test]
    fn non_finite_thrust_becomes_hover() {
        let l = limits();
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let t = l.clamp(Vector3::new(1.0, bad, 3.0), HOVER_N);
            assert_eq!(t, Vector3::new(0.0, 0.0, HOVER_N));
        }
        let t = l.clamp(Vector3::new(f32::NAN, 0.0, 0.0), f32::NAN);
        assert_eq!(t, Vector3::new(0.0, 0.0, l.thrust_min_n()));
    }

    #[test]
    fn downward_thrust_is_raised_to_thrust_min() {
        let l = limits();
        let t = l.clamp(Vector3::new(0.0, 0.0, -30.0), HOVER_N);
        assert_eq!(t, Vector3::new(0.0, 0.0, l.thrust_min_n()));
    }

    #[test]
    fn vertical_demand_above_max_keeps_no_horizontal_room() {
        let t = limits().clamp(Vector3::new(10.0, 0.0, 80.0), HOVER_N);
        assert_eq!(t, Vector3::new(0.0, 0.0, 50.0));
    }

    #[test]
    fn huge_horizontal_demand_keeps_its_direction() {
        let t = limits().clamp(Vector3::new(f32::MAX, -f32::MAX, 20.0), HOVER_N);
        assert_relative_eq!(t.x, -t.y, max_relative = 1e-6);
        assert!(t.x > 0.0);
        assert_relative_eq!(Vector2::new(t.x, t.y).norm(), 20.0, max_relative = 1e-5);
    }

    #[test]
    fn level_hover_with_east_heading_is_identity() {
        let sp = thrust_to_attitude(Vector3::new(0.0, 0.0, HOVER_N), heading(0.0), 50.0);
        assert_relative_eq!(sp.attitude, UnitQuaternion::identity(), epsilon = 1e-7);
        assert_relative_eq!(sp.collective, HOVER_N / 50.0);
    }

    #[test]
    fn north_heading_points_body_x_north() {
        let sp = thrust_to_attitude(Vector3::new(0.0, 0.0, HOVER_N), heading(1.0), 50.0);
        assert_relative_eq!(
            sp.attitude * Vector3::x(),
            Vector3::new(1.0f32.cos(), 1.0f32.sin(), 0.0),
            epsilon = 1e-6
        );
    }

    #[test]
    fn zero_or_non_finite_thrust_gives_level_attitude_and_zero_collective() {
        let h = heading(2.0);
        for t in [
            Vector3::zeros(),
            Vector3::new(0.0, f32::NAN, 1.0),
            Vector3::new(1e-6, 0.0, 0.0),
        ] {
            let sp = thrust_to_attitude(t, h, 50.0);
            assert_eq!(sp.collective, 0.0);
            assert_relative_eq!(sp.attitude * Vector3::z(), Vector3::z(), epsilon = 1e-6);
            let x = sp.attitude * Vector3::x();
            assert_relative_eq!(x, Vector3::new(h.x, h.y, 0.0), epsilon = 1e-6);
        }
    }

    #[test]
    fn thrust_along_heading_normal_is_finite() {
        let h = heading(0.3);
        let y_c = Vector3::new(-h.y, h.x, 0.0);
        for t in [
            y_c * 20.0,
            -y_c * 20.0,
            y_c * 20.0 + Vector3::new(0.0, 0.0, 1e-5),
        ] {
            let sp = thrust_to_attitude(t, h, 50.0);
            assert!(sp.attitude.coords.iter().all(|c| c.is_finite()));
            assert_relative_eq!(sp.attitude.norm(), 1.0, epsilon = 1e-6);
            assert_relative_eq!(sp.attitude * Vector3::z(), t.normalize(), epsilon = 1e-5);
        }
    }

    #[test]
    fn collective_saturates_at_one_and_handles_bad_thrust_max() {
        let h = heading(0.0);
        assert_eq!(
            thrust_to_attitude(Vector3::new(0.0, 0.0, 80.0), h, 50.0).collective,
            1.0
        );
        assert_eq!(
            thrust_to_attitude(Vector3::new(0.0, 0.0, 8.0), h, 0.0).collective,
            0.0
        );
        assert_eq!(
            thrust_to_attitude(Vector3::new(0.0, 0.0, 8.0), h, f32::NAN).collective,
            0.0
        );
        let huge = Vector3::new(f32::MAX, f32::MAX, f32::MAX);
        let sp = thrust_to_attitude(huge, h, 50.0);
        assert_eq!(sp.collective, 1.0);
        assert_relative_eq!(
            sp.attitude * Vector3::z(),
            Vector3::repeat(1.0 / 3.0f32.sqrt()),
            epsilon = 1e-6
        );
    }

    proptest! {
        /// The hand-written matrix-to-quaternion conversion is nalgebra's, bit for bit, on
        /// every branch (random rotations from random axis/angle pairs).
        #[test]
        fn attitude_from_axes_is_nalgebras(ax in -1.0f32..1.0, ay in -1.0f32..1.0, az in -1.0f32..1.0, angle in -core::f32::consts::PI..core::f32::consts::PI) {
            use nalgebra::{Matrix3, Rotation3};
            prop_assume!(ax * ax + ay * ay + az * az > 1e-3);
            let axis = nalgebra::Unit::new_normalize(Vector3::new(ax, ay, az));
            let m = Rotation3::from_axis_angle(&axis, angle).into_inner();
            let (x, y, z) = (m.column(0).into_owned(), m.column(1).into_owned(), m.column(2).into_owned());
            let ours = attitude_from_axes(&x, &y, &z);
            let r = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]));
            let theirs = UnitQuaternion::new_normalize(UnitQuaternion::from_rotation_matrix(&r).into_inner());
            prop_assert_eq!(ours.coords.map(f32::to_bits), theirs.coords.map(f32::to_bits));
        }
    }

    /// Overload (issue 15): a climb demand beyond the thrust limit no longer starves the
    /// horizontal demand; the vertical component never exceeds the reserve's cap.
    #[test]
    fn horizontal_reserve_keeps_lateral_authority_when_the_climb_saturates() {
        let base = ThrustLimits::new(2.5, 50.0, 35f32.to_radians()).unwrap();
        let res = base.with_horizontal_reserve(0.3).unwrap();
        let demand = Vector3::new(10.0, 0.0, 80.0);
        assert_eq!(base.clamp(demand, HOVER_N), Vector3::new(0.0, 0.0, 50.0));
        let t = res.clamp(demand, HOVER_N);
        assert_relative_eq!(t.x, 10.0, epsilon = 1e-4);
        assert_eq!(t.z, res.vertical_max_n());
        // A demand beyond the reserve gets the reserve (15 N).
        let t = res.clamp(Vector3::new(0.0, -40.0, 80.0), HOVER_N);
        assert_relative_eq!(t.y, -15.0, epsilon = 1e-3);
        assert_relative_eq!(t.z, 50.0 * (1.0f32 - 0.09).sqrt(), epsilon = 1e-3);
        assert_relative_eq!(res.vertical_max_n(), 50.0 * (1.0f32 - 0.09).sqrt(), epsilon = 1e-4);
        // Purely vertical: the cap.
        assert_eq!(res.clamp(Vector3::new(0.0, 0.0, 80.0), HOVER_N), Vector3::new(0.0, 0.0, res.vertical_max_n()));
        // Bad reserves are refused; 0 is the vertical priority.
        for bad in [f32::NAN, -0.1, 1.0, 2.0] {
            assert_eq!(base.with_horizontal_reserve(bad), Err(CfoError::InvalidHorizontalReserve));
        }
        let tight = ThrustLimits::new(45.0, 50.0, 0.6).unwrap();
        assert_eq!(tight.with_horizontal_reserve(0.5), Err(CfoError::InvalidHorizontalReserve));
        assert_eq!(base.with_horizontal_reserve(0.0), Ok(base));
    }

    proptest! {
        #[test]
        fn clamp_output_is_finite_and_within_limits_for_any_input(
            x in any_component(), y in any_component(), z in any_component(),
            hover in prop_oneof![Just(HOVER_N), Just(f32::NAN), 0.0f32..100.0],
        ) {
            let l = limits();
            let t = l.clamp(Vector3::new(x, y, z), hover);
            prop_assert!(t.iter().all(|c| c.is_finite()), "{t:?}");
            prop_assert!(within_limits(&t, &l), "{t:?} |T| = {}", t.norm());
        }

        /// Any valid limits, the extremes included (the velocity loop relies on a finite clamp
        /// and does not test its output again), and any demand, NaN and infinities included.
        #[test]
        fn clamp_output_is_finite_for_any_valid_limits(
            bits in proptest::array::uniform3(any::<u32>()),
            thrust_max in prop_oneof![Just(f32::MAX), Just(f32::MAX / 2.0), 1e-30f32..1e38],
            min_fraction in prop_oneof![Just(0.0f32), 0.0f32..1.0],
            tilt in prop_oneof![Just(f32::from_bits(core::f32::consts::FRAC_PI_2.to_bits() - 1)), Just(1e-6f32), 1e-6f32..core::f32::consts::FRAC_PI_2],
            reserve in prop_oneof![Just(0.0f32), 0.0f32..0.999],
            hover in prop_oneof![Just(f32::NAN), Just(f32::INFINITY), any::<f32>()],
        ) {
            let Ok(l) = ThrustLimits::new(min_fraction * thrust_max, thrust_max, tilt) else { return Ok(()) };
            let l = l.with_horizontal_reserve(reserve).unwrap_or(l);
            let t = l.clamp(Vector3::from(bits.map(f32::from_bits)), hover);
            prop_assert!(t.iter().all(|c| c.is_finite()), "{t:?} {l:?}");
        }

        #[test]
        fn clamp_bounds_magnitude_and_tilt_for_custom_limits(
            x in -500.0f32..500.0, y in -500.0f32..500.0, z in -500.0f32..500.0,
            min_fraction in 0.0f32..0.5, thrust_max in 1.0f32..200.0, tilt in 0.05f32..1.5,
        ) {
            let l = ThrustLimits::new(min_fraction * thrust_max, thrust_max, tilt).unwrap();
            let t = l.clamp(Vector3::new(x, y, z), thrust_max * 0.5);
            prop_assert!(within_limits(&t, &l), "{t:?} |T| = {}", t.norm());
            prop_assert!(t.z <= l.thrust_max_n());
        }

        /// With a reserve `r`: within the limits, the vertical part within the cap, and the
        /// horizontal part at least `min(|demand_xy|, r, T_z tan(tilt_max))`.
        #[test]
        fn reserve_bounds_hold_for_any_demand(
            x in -500.0f32..500.0, y in -500.0f32..500.0, z in -500.0f32..500.0,
            r in 0.0f32..0.9, tilt in 0.1f32..1.4,
        ) {
            let l = ThrustLimits::new(2.5, 50.0, tilt).unwrap().with_horizontal_reserve(r).unwrap();
            let t = l.clamp(Vector3::new(x, y, z), HOVER_N);
            prop_assert!(within_limits(&t, &l), "{t:?} |T| = {}", t.norm());
            prop_assert!(t.z <= l.vertical_max_n());
            let h = Vector2::new(t.x, t.y).norm();
            let want = Vector2::new(x, y).norm().min(r * 50.0).min(t.z * l.tilt_max_tan());
            // f32: T_z near thrust_max resolves the sphere only to ~thrust_max sqrt(2 eps) = 0.02 N.
            prop_assert!(h >= want * (1.0 - 1e-4) - 0.05, "horizontal {h} < {want} for {t:?}");
        }

        #[test]
        fn clamp_keeps_horizontal_direction(
            x in -500.0f32..500.0, y in -500.0f32..500.0, z in -100.0f32..100.0,
        ) {
            let t_in = Vector3::new(x, y, z);
            let t = limits().clamp(t_in, HOVER_N);
            let h_in = Vector2::new(x, y);
            let h = Vector2::new(t.x, t.y);
            if h.norm() > 1e-3 {
                // Same direction: parallel (zero cross product) and not reversed.
                let cross = h_in.x * h.y - h_in.y * h.x;
                prop_assert!(cross.abs() <= 1e-5 * h_in.norm() * h.norm());
                prop_assert!(h_in.dot(&h) > 0.0);
            }
            prop_assert!(h.norm() <= h_in.norm() * (1.0 + ROUNDING));
        }

        #[test]
        fn clamp_is_identity_inside_the_limits(
            z in 2.5f32..50.0, h_fraction in 0.0f32..0.999, angle in 0.0f32..6.3,
        ) {
            let l = limits();
            let h_room = (z * l.tilt_max_tan()).min((50.0f32 * 50.0 - z * z).sqrt());
            let h = h_fraction * h_room;
            let t_in = Vector3::new(h * angle.cos(), h * angle.sin(), z);
            prop_assert_eq!(l.clamp(t_in, HOVER_N), t_in);
        }

        #[test]
        fn attitude_round_trip_recovers_thrust_within_limits(
            x in -60.0f32..60.0, y in -60.0f32..60.0, z in -10.0f32..60.0,
            yaw in -3.2f32..3.2,
        ) {
            let l = limits();
            let t = l.clamp(Vector3::new(x, y, z), HOVER_N);
            let sp = thrust_to_attitude(t, heading(yaw), l.thrust_max_n());
            prop_assert!((sp.attitude.norm() - 1.0).abs() < 1e-6);
            prop_assert!((0.0..=1.0).contains(&sp.collective));
            let back = attitude_to_thrust(sp.attitude, sp.collective, l.thrust_max_n());
            prop_assert!((back - t).norm() <= 1e-5 * t.norm(), "{back:?} vs {t:?}");
            // Body x stays in the vertical plane of the heading (yaw honoured).
            let x_b = sp.attitude * Vector3::x();
            let y_c = Vector3::new(-yaw.sin(), yaw.cos(), 0.0);
            prop_assert!(x_b.dot(&y_c).abs() < 1e-5);
        }

        #[test]
        fn attitude_is_unit_and_finite_for_any_thrust(
            x in any_component(), y in any_component(), z in any_component(),
            yaw in -3.2f32..3.2,
        ) {
            let sp = thrust_to_attitude(Vector3::new(x, y, z), heading(yaw), 50.0);
            prop_assert!(sp.attitude.coords.iter().all(|c| c.is_finite()));
            prop_assert!((sp.attitude.norm() - 1.0).abs() < 1e-6);
            prop_assert!((0.0..=1.0).contains(&sp.collective));
        }
    }
}
