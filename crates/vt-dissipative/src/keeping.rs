//! Tube-keeping term eq:2-14/eq:2-15: `vbar_t = -(I - t_c t_c^T) c_i`.
//!
//! `r_t` and `m` depend on `q` only through `s(q)`, whose gradient is tangential, so after the
//! projection `(I - t_c t_c^T)` only the `(q - m)` part of `c_i` survives and the term reduces
//! to `vbar_t = (dV_t/dd_t) (q - m) / |q - m|` (REFERENCE §2). With `dV_t/dd_t <= 0` it points
//! from the node towards the section's midpoint, i.e. away from the nearer boundary.
//! A node exactly on the midpoint gets zero (both boundaries equally far; gradient undefined).

use crate::Vec2;
use vt_tube::{BarrierParams, Section};

/// `|q - m|` below this is "on the midpoint", m.
pub const ON_MIDPOINT_M: f32 = 1e-6;

/// Tube-keeping velocity of a node at `q_m` in `section` (eq:2-14, eq:2-15), m/s, and the
/// node's boundary distance `d_t`, m.
#[inline]
pub fn keeping_velocity(section: &Section, q_m: &Vec2, barrier: &BarrierParams) -> (Vec2, f32) {
    let off = q_m - section.midpoint_m;
    let r = vt_fpu::sqrt(off.norm_squared());
    let d_t = section.half_width_m - r;
    if r < ON_MIDPOINT_M {
        return (Vec2::zeros(), d_t);
    }
    let b = barrier.eval(d_t);
    (off * (b.deriv / r), d_t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;
    use vt_tube::{Tube, Waypoint};

    const BARRIER: BarrierParams = BarrierParams::tube(1.0, 0.5, 1.5);

    fn tube() -> Tube<256> {
        Tube::from_waypoints(&[
            Waypoint::new(0.0, 0.0, 3.0, 2.0),
            Waypoint::new(15.0, 3.0, 2.0, 2.5),
            Waypoint::new(30.0, 0.0, 3.0, 3.0),
        ])
        .unwrap()
    }

    #[test]
    fn straight_tube_by_hand() {
        let t = Tube::<256>::from_waypoints(&[Waypoint::new(0.0, 0.0, 2.0, 2.0), Waypoint::new(10.0, 0.0, 2.0, 2.0)])
            .unwrap();
        let q = Vec2::new(5.0, 1.0); // d_t = 1.0, barrier slope -5 (see vt-tube barrier tests)
        let sec = t.locate(q, 0).unwrap();
        let (v, d) = keeping_velocity(&sec, &q, &BARRIER);
        assert_relative_eq!(d, 1.0, epsilon = 1e-4);
        assert_relative_eq!(v.x, 0.0, epsilon = 1e-4);
        assert_relative_eq!(v.y, -5.0, max_relative = 1e-3);
    }

    /// The end terminal is a stop (issue 29): past the end every point locates to the end
    /// section, whose disk `|q - m| < r_t` the barrier keeps. A node carried past the end is
    /// pushed back along the end's tangent, harder the further it goes; the passing term there
    /// is zero (`l = 0`), so nothing pushes on.
    #[test]
    fn the_end_terminal_stops_a_node_carried_past_it() {
        let t = Tube::<256>::from_waypoints(&[Waypoint::new(0.0, 0.0, 2.0, 2.0), Waypoint::new(10.0, 0.0, 2.0, 2.0)]).unwrap();
        let mut last = 0.0;
        // Within the barrier's active band (d_t from 1.4 m down to 0.8 m; r_s 0.5, r_a 1.5).
        for past_m in [0.6, 0.9, 1.2] {
            let q = Vec2::new(10.0 + past_m, 0.0);
            let sec = t.locate(q, 0).unwrap();
            let (v, d) = keeping_velocity(&sec, &q, &BARRIER);
            assert_relative_eq!(d, 2.0 - past_m, epsilon = 1e-4);
            assert!(v.x < last && v.y.abs() < 1e-6, "{past_m} m past: {v:?}");
            last = v.x;
            assert_eq!(crate::passing::passing_velocity(&sec, &q, 1.0, 1.5), Vec2::zeros());
        }
    }

    #[test]
    fn zero_on_the_midpoint_and_far_from_the_boundary() {
        let t = tube();
        let sec = t.locate(Vec2::new(7.0, 1.0), 0).unwrap();
        let (v, _) = keeping_velocity(&sec, &sec.midpoint_m, &BARRIER);
        assert_eq!(v, Vec2::zeros());
    }

    proptest! {
        #[test]
        fn tube_term_points_from_the_node_towards_the_midpoint(
            s in 0.5f32..29.0, lateral in -1.0f32..1.0,
        ) {
            let t = tube();
            let k = ((s / t.ds_m()) as usize).min(254);
            let smp = t.samples()[k];
            let q = smp.pos_m + smp.normal() * (lateral * 3.2);
            let sec = t.locate(q, k).unwrap();
            let (v, d_t) = keeping_velocity(&sec, &q, &BARRIER);
            prop_assert!(v.x.is_finite() && v.y.is_finite());
            let to_mid = sec.midpoint_m - q;
            if v.norm() > 0.0 && to_mid.norm() > 1e-3 {
                let cos = v.dot(&to_mid) / (v.norm() * to_mid.norm());
                prop_assert!(cos > 0.9999, "cos = {}", cos);
            }
            if d_t >= 1.5 {
                prop_assert_eq!(v, Vec2::zeros());
            }
        }
    }
}
