//! Control allocation of an X-configuration quadrotor: collective force and body torques to
//! four rotor thrusts, with saturation handling that keeps roll and pitch.
//!
//! # Allocation (Mahony, Kumar & Corke 2012, eq. 4, rotor positions of [`QuadParams`])
//!
//! With `d` the rotor offset from the body x and y axes and `k_m` the yaw-moment coefficient,
//! the thrusts `T_1..T_4` (PX4 "Quadrotor X" numbering) give, body FLU:
//!
//! ```text
//! F     =      T1 + T2 + T3 + T4
//! tau_x = d  (-T1 + T2 + T3 - T4)        (r x F: y_i T_i)
//! tau_y = d  (-T1 + T2 - T3 + T4)        (r x F: -x_i T_i)
//! tau_z = k_m(-T1 - T2 + T3 + T4)        (rotors 1, 2 CCW react clockwise)
//! ```
//!
//! The four columns `(1,1,1,1)`, `a = (-1,1,1,-1)`, `b = (-1,1,-1,1)`, `c = (-1,-1,1,1)` are
//! orthogonal, so the inverse is `T_i = F/4 + a_i tau_x/(4d) + b_i tau_y/(4d) + c_i tau_z/(4 k_m)`.
//!
//! # Saturation: roll/pitch first, then collective, then yaw
//!
//! Each rotor is limited to `[T_min, T_max]`. The demand is met in this order (PX4
//! `MixerMultirotor` "airmode roll/pitch", Faessler et al. 2017 "thrust mixing" priorities):
//!
//! 1. **Roll and pitch** are kept whole when their differential spread fits in
//!    `T_max - T_min`; only when it does not are they scaled down together (direction kept),
//!    and the collective is then whatever centres them in the range. This is the last resort.
//! 2. **Collective** is moved, up or down, by the least amount that lets roll/pitch fit.
//! 3. **Yaw** gets what is left: it is scaled down until every rotor is inside its limits
//!    without moving the collective again.
//!
//! Why: the attitude loop steers the thrust *direction*, which is what the position and
//! formation control of the team rely on, and a tilt error grows into position error within a
//! second; a collective error is a transient vertical force that the outer loop and the cable
//! absorb; yaw is irrelevant to the transport (the firmware holds it) and the weakest axis
//! (`k_m << d`). Collective may go *up* to keep roll/pitch (PX4's airmode) because a UAV that
//! carries a load must not lose attitude authority at low throttle.
//!
//! [`QuadParams`]: super::QuadParams

/// Per-rotor sign of the roll torque column (`a`), PX4 X numbering.
pub(super) const ROLL_SIGN: [f64; 4] = [-1.0, 1.0, 1.0, -1.0];
/// Per-rotor sign of the pitch torque column (`b`).
pub(super) const PITCH_SIGN: [f64; 4] = [-1.0, 1.0, -1.0, 1.0];
/// Per-rotor sign of the yaw torque column (`c`): rotors 1, 2 CCW (react -), 3, 4 CW (+).
pub(super) const YAW_SIGN: [f64; 4] = [-1.0, -1.0, 1.0, 1.0];

/// Rotor geometry and limits the allocation needs (from [`super::QuadParams`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mixer {
    /// Rotor offset from the body x and y axes (`arm / sqrt 2`), m (> 0).
    pub rotor_offset_m: f64,
    /// Yaw torque per newton of rotor thrust, m (>= 0).
    pub yaw_moment_coeff_m: f64,
    /// Smallest rotor thrust, N.
    pub thrust_min_n: f64,
    /// Largest rotor thrust, N (> min).
    pub thrust_max_n: f64,
}

/// Whether the last allocation had to give up part of the demand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Saturation {
    /// The collective differs from the demand (moved to keep roll/pitch).
    pub collective: bool,
    /// Roll/pitch were scaled down (spread wider than the rotor range).
    pub roll_pitch: bool,
    /// Yaw was scaled down.
    pub yaw: bool,
}

impl Mixer {
    /// Body wrench `(F, tau_x, tau_y, tau_z)` (N, N m, FLU) produced by rotor thrusts `t` (N).
    #[must_use]
    pub fn wrench(&self, t: &[f64; 4]) -> (f64, [f64; 3]) {
        let (d, km) = (self.rotor_offset_m, self.yaw_moment_coeff_m);
        let dot = |s: &[f64; 4]| s.iter().zip(t).map(|(a, b)| a * b).sum::<f64>();
        (t.iter().sum(), [d * dot(&ROLL_SIGN), d * dot(&PITCH_SIGN), km * dot(&YAW_SIGN)])
    }

    /// Rotor thrusts (N) for collective `force_n` (N) and body torques `torque_nm` (N m, FLU),
    /// by the priority rule of the module doc. Non-finite demands are treated as zero; the
    /// result is always inside `[thrust_min_n, thrust_max_n]`.
    #[must_use]
    pub fn mix(&self, force_n: f64, torque_nm: [f64; 3]) -> ([f64; 4], Saturation) {
        let finite_or_zero = |x: f64| if x.is_finite() { x } else { 0.0 };
        let [tx, ty, tz] = torque_nm.map(finite_or_zero);
        let (lo, hi) = (self.thrust_min_n, self.thrust_max_n);
        let span = hi - lo;
        let mut sat = Saturation::default();

        // 1. Roll/pitch differential per rotor, scaled only if its spread exceeds the range.
        let roll = tx / (4.0 * self.rotor_offset_m);
        let pitch = ty / (4.0 * self.rotor_offset_m);
        let mut rp = [0.0; 4];
        for ((r, a), b) in rp.iter_mut().zip(ROLL_SIGN).zip(PITCH_SIGN) {
            *r = a * roll + b * pitch;
        }
        let (rp_min, rp_max) = min_max(&rp);
        let spread = rp_max - rp_min;
        if spread > span {
            let scale = span / spread;
            rp.iter_mut().for_each(|r| *r *= scale);
            sat.roll_pitch = true;
        }
        let (rp_min, rp_max) = min_max(&rp);

        // 2. Collective per rotor, moved by the least amount that fits roll/pitch.
        let wanted = finite_or_zero(force_n) / 4.0;
        let (c_lo, c_hi) = (lo - rp_min, hi - rp_max);
        let collective = if c_lo > c_hi { 0.5 * (c_lo + c_hi) } else { wanted.clamp(c_lo, c_hi) };
        sat.collective = (collective - wanted).abs() > 1e-12 * span.max(1.0);

        // 3. Yaw scaled by the largest s in [0, 1] that keeps every rotor in range.
        let yaw = if self.yaw_moment_coeff_m > 0.0 { tz / (4.0 * self.yaw_moment_coeff_m) } else { 0.0 };
        // Every rotor's yaw share is +-yaw, so the bound is the least headroom in the
        // direction each rotor moves over |yaw|: one division (a correctly rounded division
        // by a positive number is monotone, so this is the minimum of the per-rotor ratios
        // bit for bit).
        let mut headroom = f64::INFINITY;
        for (r, c) in rp.iter().zip(YAW_SIGN) {
            let base = collective + r;
            let y = c * yaw;
            if y > 0.0 {
                headroom = headroom.min(hi - base);
            } else if y < 0.0 {
                headroom = headroom.min(base - lo);
            }
        }
        let s = if headroom < f64::INFINITY { (headroom / yaw.abs()).clamp(0.0, 1.0) } else { 1.0 };
        sat.yaw = s < 1.0;

        let mut out = [0.0; 4];
        for ((o, r), c) in out.iter_mut().zip(rp).zip(YAW_SIGN) {
            // The clamp only removes rounding: every term was fitted above.
            *o = (collective + r + s * c * yaw).clamp(lo, hi);
        }
        (out, sat)
    }
}

/// Smallest and largest of four numbers.
fn min_max(v: &[f64; 4]) -> (f64, f64) {
    v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| (lo.min(x), hi.max(x)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper preset's mixer.
    fn mixer() -> Mixer {
        let p = super::super::QuadParams::paper();
        Mixer {
            rotor_offset_m: p.rotor_offset_m(),
            yaw_moment_coeff_m: p.yaw_moment_coeff_m,
            thrust_min_n: p.rotor_thrust_min_n,
            thrust_max_n: p.rotor_thrust_max_n,
        }
    }

    #[test]
    fn unsaturated_demand_is_allocated_exactly() {
        let m = mixer();
        let (t, sat) = m.mix(20.0, [0.3, -0.2, 0.05]);
        assert_eq!(sat, Saturation::default());
        let (f, tau) = m.wrench(&t);
        assert!((f - 20.0).abs() < 1e-12);
        for (got, want) in tau.iter().zip([0.3, -0.2, 0.05]) {
            assert!((got - want).abs() < 1e-12, "{got} vs {want}");
        }
    }

    #[test]
    fn full_collective_gives_way_to_roll_and_yaw_gives_way_first() {
        let m = mixer();
        let (t, sat) = m.mix(1e3, [0.5, 0.0, 0.5]);
        let (f, tau) = m.wrench(&t);
        assert!((tau[0] - 0.5).abs() < 1e-12, "roll torque kept: {}", tau[0]);
        assert!(sat.collective && sat.yaw && !sat.roll_pitch);
        assert!(f < 4.0 * m.thrust_max_n);
        assert!(tau[2].abs() < 0.5);
        assert!(t.iter().all(|&x| x >= m.thrust_min_n && x <= m.thrust_max_n));
    }

    #[test]
    fn roll_beyond_the_range_is_scaled_keeping_direction() {
        let m = mixer();
        let (t, sat) = m.mix(20.0, [100.0, 50.0, 0.0]);
        let (_, tau) = m.wrench(&t);
        assert!(sat.roll_pitch);
        assert!((tau[0] / tau[1] - 2.0).abs() < 1e-9, "direction kept: {tau:?}");
        // Largest roll/pitch torque the rotors can make in that direction: spread = range.
        let (lo, hi) = min_max(&t);
        assert!((lo - m.thrust_min_n).abs() < 1e-9 && (hi - m.thrust_max_n).abs() < 1e-9);
    }

    #[test]
    fn non_finite_demand_is_zero() {
        let m = mixer();
        let (t, _) = m.mix(f64::NAN, [f64::INFINITY, 0.0, f64::NAN]);
        assert!(t.iter().all(|x| x.is_finite()));
        let (_, tau) = m.wrench(&t);
        assert!(tau.iter().all(|x| x.abs() < 1e-12));
    }
}
