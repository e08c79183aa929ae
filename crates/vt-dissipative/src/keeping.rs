//! Tube-keeping term eq:2-14/eq:2-15: `vbar_t = -(I - t_c t_c^T) c_i`.
//!
//! `r_t` and `m` depend on `q` only through `s(q)`, whose gradient is tangential, so after the
//! projection `(I - t_c t_c^T)` only the `(q - m)` part of `c_i` survives and the term reduces
//! to `vbar_t = (dV_t/dd_t) (q - m) / |q - m|` (REFERENCE §2). With `dV_t/dd_t <= 0` it points
//! from the node towards the section's midpoint, i.e. away from the nearer boundary.
//! A node exactly on the midpoint gets zero (both boundaries equally far; gradient undefined).
//!
//! [`team_keeping_velocity`] is an extension (issue 27; docs/design.md, "The tube keeps the
//! team, not one node"): every UAV adds the team's mean keeping term, so a boundary that one
//! node meets moves the whole formation instead of pressing that node into its neighbours.

use crate::Vec2;
use vt_tube::{BarrierParams, Section, Tube};

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

/// The share of its own node's keeping term a UAV keeps beside the team's mean in
/// [`team_keeping_velocity`] (measured, docs/design.md "The tube keeps the team, not one node":
/// 0 lets a node near the boundary, 1 squeezes pairs as the paper's term alone does).
pub const OWN_KEEPING_SHARE: f32 = 0.5;

/// How often the team's mean keeping term is recomputed: every this many high-level steps
/// (8.3 Hz at 50 Hz), held between (locating every other node costs about 420 Cortex-M4
/// instructions each, 3,700 a step for ten UAVs; held, the per-UAV step stays within the
/// 5,000 budget; docs/design.md "The tube keeps the team, not one node"). The own share is
/// computed at every step.
pub const TEAM_KEEPING_EVERY: u8 = 6;

/// Team keeping (extension), the team's part: the mean over the team's `n` nodes of their
/// keeping terms (eq:2-14/15 at each node, each limited to `clip_mps`, a missing node counting
/// zero), m/s (node velocity). [`team_keeping_velocity`] adds [`OWN_KEEPING_SHARE`] times the
/// own node's term.
///
/// The limit is the controller's speed limit `v_max` (eq:2-21): no node moves the team faster
/// than it could command itself, so one node deep in its barrier (whose term is unbounded) does
/// not drive another into the opposite boundary against that one's own share.
///
/// The mean is the same for every UAV that sees the same nodes, so it moves the formation as
/// a whole: it is `-1/n` times the gradient of the team's tube potential `sum_j V_t(q_j)` with
/// respect to a common translation, along which that potential decreases. The own share keeps
/// the paper's per-node barrier, halved: still unbounded at the safety radius, so a node the
/// formation presses towards the boundary is held inside.
///
/// `own` is the UAV's index, `own_v_t` its own term (as [`keeping_velocity`] or the
/// controller's overload variant gives it) and `own_sec` its node's section: every other node's
/// [`Tube::locate`] starts at the segment the node projects to along that section's tangent
/// (no memory of the nodes between steps, so nothing is added to the controller).
/// `widen` maps a located section to the one the barrier sees. A node outside the tube's table
/// contributes zero.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub fn team_mean_keeping<const S: usize, const N: usize>(
    tube: &Tube<S>,
    nodes: &[Option<Vec2>; N],
    n: usize,
    own: usize,
    own_v_t: Vec2,
    own_sec: &Section,
    clip_mps: f32,
    barrier: &BarrierParams,
    widen: impl Fn(&Section) -> Section,
) -> Vec2 {
    let own_at = nodes.get(own).copied().flatten().unwrap_or(own_sec.point_m);
    let mut sum = Vec2::zeros();
    for (j, node) in nodes.iter().enumerate().take(n) {
        let Some(q) = node else { continue };
        if j == own {
            sum += limited(own_v_t, clip_mps);
        } else if let Some(sec) = tube.locate(*q, projected_segment(tube, own_at, own_sec, q)) {
            sum += limited(keeping_velocity(&widen(&sec), q, barrier).0, clip_mps);
        }
    }
    if n > 0 { sum / n as f32 } else { Vec2::zeros() }
}

/// [`team_mean_keeping`] plus [`OWN_KEEPING_SHARE`] times `own_v_t`: the team keeping term of
/// the UAV whose own term is `own_v_t` for the team's mean `mean`, m/s.
#[must_use]
pub fn team_keeping_velocity(mean: Vec2, own_v_t: Vec2) -> Vec2 {
    mean + own_v_t * OWN_KEEPING_SHARE
}

/// The segment node `q` projects to from the own node at `own_at` along the own section's
/// tangent: the warm start of its [`Tube::locate`] (within a segment or two of its own for
/// nodes in the formation's span).
fn projected_segment<const S: usize>(tube: &Tube<S>, own_at: Vec2, own_sec: &Section, q: &Vec2) -> usize {
    let ds = tube.ds_m();
    let k = own_sec.segment as f32 + (q - own_at).dot(&own_sec.tangent) / ds;
    if k.is_finite() && k > 0.0 { vt_fpu::min(k, S.saturating_sub(2) as f32) as usize } else { 0 }
}

/// `v` limited to magnitude `clip_mps` (direction kept), m/s: also for a finite `v` whose
/// square overflows (a barrier term deep in its safety radius saturates at `f32::MAX`); zero for
/// a non-finite `v` or a limit that is not a number >= 0.
#[inline(never)]
fn limited(v: Vec2, clip_mps: f32) -> Vec2 {
    let m = v.amax();
    if !(m > 0.0 && m.is_finite() && clip_mps >= 0.0) {
        return Vec2::zeros();
    }
    let u = v / m;
    let n = vt_fpu::norm(&u);
    if m * n <= clip_mps { v } else { u * (clip_mps / n) }
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

    /// A straight 4 m-wide tube and a row of three nodes across it, 0.8 m apart, offset by
    /// `shift` (m, to the left).
    fn row(shift: f32) -> (Tube<256>, [Option<Vec2>; 4]) {
        let t = Tube::<256>::from_waypoints(&[Waypoint::new(0.0, 0.0, 2.0, 2.0), Waypoint::new(20.0, 0.0, 2.0, 2.0)]).unwrap();
        let node = |y: f32| Some(Vec2::new(10.0, y + shift));
        (t, [node(0.8), node(0.0), node(-0.8), None])
    }

    fn sec_of(t: &Tube<256>, nodes: &[Option<Vec2>; 4], own: usize) -> Section {
        t.locate(nodes[own].unwrap_or(Vec2::new(10.0, 0.0)), 0).unwrap()
    }

    fn own_term(t: &Tube<256>, q: Vec2) -> Vec2 {
        keeping_velocity(&t.locate(q, 0).unwrap(), &q, &BARRIER).0
    }

    fn team_term(t: &Tube<256>, nodes: &[Option<Vec2>; 4], n: usize, own: usize) -> Vec2 {
        let own_v_t = nodes[own].map_or(Vec2::zeros(), |q| own_term(t, q));
        team_keeping_velocity(team_mean_keeping(t, nodes, n, own, own_v_t, &sec_of(t, nodes, own), f32::INFINITY, &BARRIER, |s| *s), own_v_t)
    }

    #[test]
    fn a_boundary_one_node_meets_moves_the_whole_team_away() {
        // Shifted 0.45 m left: the left node is 0.75 m from the boundary (inside the active
        // band, 0.5-1.5 m), the others 1.55 and 1.65 m (beyond it).
        let (t, nodes) = row(0.45);
        let pushed = own_term(&t, nodes[0].unwrap());
        assert!(pushed.y < -1.0, "{pushed:?}");
        let mean = pushed / 3.0;
        // The two free nodes get the same velocity, the team's mean, away from the boundary.
        for own in [1, 2] {
            assert_relative_eq!(team_term(&t, &nodes, 3, own), mean, epsilon = 1e-6);
        }
        // The pushed node: the mean plus half its own term, less than the paper's term alone.
        let v0 = team_term(&t, &nodes, 3, 0);
        assert_relative_eq!(v0, mean + pushed * OWN_KEEPING_SHARE, epsilon = 1e-6);
        assert!(v0.y < 0.0 && v0.y > pushed.y);
    }

    #[test]
    fn a_formation_pressed_from_both_sides_is_not_moved_only_held() {
        // A row 3.2 m wide in a 4 m tube: both outer nodes in the band, the pushes cancel in
        // the mean; each outer node keeps half its own term, inwards.
        let t = Tube::<256>::from_waypoints(&[Waypoint::new(0.0, 0.0, 2.0, 2.0), Waypoint::new(20.0, 0.0, 2.0, 2.0)]).unwrap();
        let nodes = [Some(Vec2::new(10.0, 1.6)), Some(Vec2::new(10.0, 0.0)), Some(Vec2::new(10.0, -1.6)), None];
        assert!(team_term(&t, &nodes, 3, 1).norm() < 1e-5);
        let left = own_term(&t, nodes[0].unwrap());
        assert_relative_eq!(team_term(&t, &nodes, 3, 0), left * OWN_KEEPING_SHARE, epsilon = 1e-5);
    }

    #[test]
    fn the_common_translation_lowers_the_teams_tube_potential() {
        // Lyapunov: moving every node by the team's mean term (a small step) lowers
        // sum_j V_t(q_j), the team's tube potential (dV/dt = -|sum grad|^2 / n <= 0).
        let potential = |t: &Tube<256>, nodes: &[Option<Vec2>; 4]| -> f32 {
            nodes.iter().flatten().map(|q| BARRIER.eval(t.locate(*q, 0).unwrap().boundary_distance_m(*q)).value).sum()
        };
        for shift in [0.3f32, 0.45, -0.35] {
            let (t, nodes) = row(shift);
            let before = potential(&t, &nodes);
            let mean = team_term(&t, &nodes, 3, 1);
            let moved = nodes.map(|q| q.map(|q| q + mean * 0.01));
            let after = potential(&t, &moved);
            assert!(before > 0.0 && after < before, "shift {shift}: {before} -> {after}");
        }
    }

    #[test]
    fn missing_nodes_count_zero_and_an_empty_team_keeps_the_own_share() {
        let (t, nodes) = row(0.45);
        let pushed = own_term(&t, nodes[0].unwrap());
        // The pushed node unseen by UAV 1: nothing from it.
        let unseen = [None, nodes[1], nodes[2], None];
        assert!(team_term(&t, &unseen, 3, 1).norm() < 1e-6);
        let alone = team_keeping_velocity(team_mean_keeping(&t, &[None; 4], 0, 0, pushed, &t.locate(nodes[0].unwrap(), 0).unwrap(), f32::INFINITY, &BARRIER, |s| *s), pushed);
        assert_relative_eq!(alone, pushed * OWN_KEEPING_SHARE);
    }

    #[test]
    fn no_node_moves_the_team_faster_than_the_speed_limit() {
        // The left node deep in its barrier (0.05 m past the safety radius): its term is large,
        // its share of the team's motion at most the limit over n.
        let (t, _) = row(0.0);
        let nodes = [Some(Vec2::new(10.0, 1.45)), Some(Vec2::new(10.0, 0.0)), Some(Vec2::new(10.0, -0.3)), None];
        let deep = own_term(&t, nodes[0].unwrap());
        assert!(deep.norm() > 10.0, "{deep:?}");
        let v1 = team_keeping_velocity(team_mean_keeping(&t, &nodes, 3, 1, Vec2::zeros(), &sec_of(&t, &nodes, 1), 1.5, &BARRIER, |s| *s), Vec2::zeros());
        assert_relative_eq!(v1, Vec2::new(0.0, -1.5 / 3.0), epsilon = 1e-5);
        // The deep node itself keeps its whole half share, unlimited.
        let v0 = team_keeping_velocity(team_mean_keeping(&t, &nodes, 3, 0, deep, &sec_of(&t, &nodes, 0), 1.5, &BARRIER, |s| *s), deep);
        assert_relative_eq!(v0, limited(deep, 1.5) / 3.0 + deep * OWN_KEEPING_SHARE, max_relative = 1e-5);
        assert_relative_eq!(limited(Vec2::new(f32::MAX, f32::MAX), 1.5).norm(), 1.5, epsilon = 1e-5);
        assert_eq!(limited(Vec2::new(f32::NAN, 0.0), 1.5), Vec2::zeros());
        assert_eq!(limited(Vec2::new(1.0, 0.0), f32::NAN), Vec2::zeros());
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
