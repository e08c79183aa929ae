//! Passing term eq:2-13: `vbar_l = sat(k1 l(q) eta(q) t_c(q), v_m)`.
//!
//! The paper defers `l` and `eta` to Quan et al. (RAS 2023). Reading used here (REFERENCE §2,
//! `docs/design.md`): `l(q) = L - s(q)`, the arc length left to the end terminal (the command
//! fades out at the end, where the line-integral Lyapunov function eq:2-13-1 has its minimum),
//! and `eta(q) = 1 - kappa (q - gamma) . n`, so that nodes on the outside of a bend advance in
//! `s` as fast as those on the inside. `eta` is clamped to `[0, 2]`: inside a valid tube
//! (`w |kappa| < 1`) it already lies there, outside it the clamp keeps the term from reversing.

use crate::Vec2;
use vt_tube::{sat, Section};

/// Upper clamp of the curvature factor `eta` (its range inside any valid tube is `(0, 2)`).
pub const ETA_MAX: f32 = 2.0;

/// Curvature factor `eta(q) = 1 - kappa (q - gamma) . n`, clamped to `[0, ETA_MAX]`.
#[inline]
pub fn curvature_factor(section: &Section, q_m: &Vec2) -> f32 {
    (1.0 - section.curvature_pm * section.lateral_offset_m(*q_m)).clamp(0.0, ETA_MAX)
}

/// Passing velocity eq:2-13 of a node at `q_m` in `section`, m/s (`|v| <= v_max_mps`).
#[inline]
pub fn passing_velocity(section: &Section, q_m: &Vec2, k1: f32, v_max_mps: f32) -> Vec2 {
    let gain = k1 * section.remaining_m * curvature_factor(section, q_m);
    sat(section.tangent * gain, v_max_mps)
}

/// `sec`, a node's section, with the arc length left to the end terminal taken from the
/// tray-centre replica's section `center` when there is one: the passing term fades with the
/// formation's `l`, not each node's own (extension; docs/design.md, "The formation stops as one
/// at the end terminal"). With each node's own `l` the front of the formation slows before its
/// rear, whose passing term is up to `k1` times their spacing faster, and the rear closes on it
/// along the tube.
#[inline]
#[must_use]
pub fn formation_faded(sec: &Section, center: Option<&Section>) -> Section {
    match center {
        Some(c) => Section { remaining_m: c.remaining_m, ..*sec },
        None => *sec,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use vt_tube::{Tube, Waypoint};

    fn arc_tube() -> Tube<256> {
        // Left turn of radius 20 m, 3 m half-widths.
        let wps: Vec<Waypoint> = (0..10)
            .map(|i| {
                let a = 1.2 * i as f32 / 9.0;
                Waypoint::new(20.0 * a.sin(), 20.0 - 20.0 * a.cos(), 3.0, 3.0)
            })
            .collect();
        Tube::from_waypoints(&wps).unwrap()
    }

    #[test]
    fn saturated_along_the_tangent_far_from_the_end() {
        let tube = arc_tube();
        let q = Vec2::new(5.0, 0.8);
        let sec = tube.locate(q, 0).unwrap();
        let v = passing_velocity(&sec, &q, 1.0, 1.5);
        assert_relative_eq!(v.norm(), 1.5, epsilon = 1e-5);
        assert_relative_eq!(v.normalize().dot(&sec.tangent), 1.0, epsilon = 1e-5);
    }

    #[test]
    fn fades_out_at_the_end_terminal() {
        let tube = arc_tube();
        let end = tube.samples()[255];
        let q = end.pos_m - end.tangent * 0.5;
        let sec = tube.locate(q, 250).unwrap();
        let v = passing_velocity(&sec, &q, 1.0, 1.5);
        // l = 0.5 m, on the centreline eta = 1: |v| = k1 l = 0.5 m/s.
        assert_relative_eq!(v.norm(), 0.5, epsilon = 1e-3);
        let past = end.pos_m + end.tangent * 2.0;
        let sec = tube.locate(past, 250).unwrap();
        assert_eq!(passing_velocity(&sec, &past, 1.0, 1.5), Vec2::zeros());
    }

    #[test]
    fn outside_of_a_bend_is_faster() {
        // eta = 1 - kappa * offset: kappa = +0.05 (left turn), offset -2 m (right, outside) -> 1.1.
        let tube = arc_tube();
        let mid = tube.samples()[128];
        let outside = mid.pos_m - mid.normal() * 2.0;
        let inside = mid.pos_m + mid.normal() * 2.0;
        let so = tube.locate(outside, 0).unwrap();
        let si = tube.locate(inside, 0).unwrap();
        assert_relative_eq!(curvature_factor(&so, &outside), 1.1, epsilon = 2e-3);
        assert_relative_eq!(curvature_factor(&si, &inside), 0.9, epsilon = 2e-3);
    }

    #[test]
    fn the_formation_s_fade_takes_only_the_replica_s_arc_length_left() {
        let tube = arc_tube();
        let (front, rear) = (Vec2::new(8.0, 0.5), Vec2::new(4.0, -0.5));
        let (sf, sr) = (tube.locate(front, 0).unwrap(), tube.locate(rear, 0).unwrap());
        let faded = formation_faded(&sf, Some(&sr));
        assert_eq!(faded.remaining_m, sr.remaining_m);
        assert_eq!(Section { remaining_m: sf.remaining_m, ..faded }, sf, "every other field is the node's own");
        assert_eq!(formation_faded(&sf, None), sf);
        // Near the end: the front node's own l would slow it below the rear's speed; faded, both
        // advance at the replica's rate.
        let k1 = 1.0;
        let v = passing_velocity(&formation_faded(&sf, Some(&sr)), &front, k1, 1e3);
        assert_relative_eq!(v.norm(), k1 * sr.remaining_m * curvature_factor(&sf, &front), max_relative = 1e-6);
    }
}
