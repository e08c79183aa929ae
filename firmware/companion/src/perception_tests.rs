//! Tests of the onboard perception: the planner's election, the trigger, a re-plan around an
//! obstacle the map has only seen, and the accept rule.

use super::*;
use vt_map::Return;
use vt_tube::Waypoint;

type V2 = vt_plan::Vec2;

pub(crate) fn straight(y: f32, half_width_m: f32) -> CompanionTube {
    CompanionTube::from_waypoints(&[Waypoint::new(3.0, y, half_width_m, half_width_m), Waypoint::new(47.0, y, half_width_m, half_width_m)]).unwrap()
}

pub(crate) fn config() -> PerceptionConfig {
    PerceptionConfig {
        bounds_m: [0.0, 50.0, 0.0, 20.0],
        cell_m: 0.25,
        goal_m: [47.0, 10.0],
        replan_period_ms: 1000,
        plan: PlanParams { need_half_width_m: 1.6, ..PlanParams::default() },
    }
}

/// A 72-sector, 15 m scan from `o` of the circles `(centre, radius)`: each sector the closest
/// of 11 rays across it (0.5 deg apart), cast analytically, as `OBSTACLE_DISTANCE` carries it.
pub(crate) fn scan(o: V2, circles: &[(V2, f32)]) -> Scan {
    let mut s = Scan::new(o, 0.0, 5f32.to_radians(), 15.0);
    for k in 0..72 {
        let hit = (0..11).map(|u| sector_ray(o, circles, (k as f32 * 5.0 - 2.5 + u as f32 * 0.5).to_radians())).fold(f32::INFINITY, f32::min);
        s.returns.push(if hit <= 15.0 { Return::Hit(hit) } else { Return::Clear }).unwrap();
    }
    s
}

fn sector_ray(o: V2, circles: &[(V2, f32)], a: f32) -> f32 {
    // vt_fpu's sine and cosine, not std's: the optimiser folds std's on constant angles with
    // the compiler's own library, so the rays (and a map cell on a boundary) changed with the
    // optimisation level.
    let (s, c) = vt_fpu::sin_cos(a).unwrap_or((0.0, 1.0));
    let d = V2::new(c, s);
    circles
        .iter()
        .filter_map(|(c, r)| {
            let oc = o - c;
            let b = d.dot(&oc);
            let disc = b * b - (oc.norm_squared() - r * r);
            (b < 0.0 && disc >= 0.0).then(|| -b - disc.sqrt())
        })
        .fold(f32::INFINITY, f32::min)
}

#[test]
fn the_lowest_healthy_id_plans_and_the_next_takes_over() {
    assert_eq!(designated_planner(5, |_| true), Some(0));
    assert_eq!(designated_planner(5, |j| j != 0), Some(1));
    assert_eq!(designated_planner(5, |j| j >= 3), Some(3));
    assert_eq!(designated_planner(5, |_| false), None);
}

#[test]
fn a_world_too_large_for_the_map_is_refused() {
    let cfg = PerceptionConfig { bounds_m: [0.0, 100.0, 0.0, 100.0], ..config() };
    assert!(matches!(Perception::new(cfg), Err(vt_map::MapError::TooManyCells { .. })));
    let cfg = PerceptionConfig { cell_m: f32::NAN, ..config() };
    assert!(Perception::new(cfg).is_err());
}

#[test]
fn an_obstacle_seen_in_the_tube_triggers_a_replan_that_goes_around_it() {
    let mut p = Box::new(Perception::new(config()).unwrap());
    let tube = straight(10.0, 3.0);
    let rock = (V2::new(20.0, 10.5), 1.5);
    let load = Vec3::new(14.0, 10.0, 3.0);
    assert!(!p.blocked());
    // An obstacle off the tube does not trigger: a scan that only sees a circle far north.
    p.integrate(&scan(V2::new(8.0, 10.0), &[(V2::new(8.0, 18.5), 1.0)]), Some(&tube), 5.0);
    assert!(!p.blocked(), "an obstacle outside the tube");
    // Seen from 12 m the rock is marked at its sectors' centres only (gaps of a metre), and is
    // already in the tube ahead. Those cells were seen free by the first scan: a sector's miss
    // cancels one hit (perception::SECTOR_MISS), so the second scan of the rock marks them.
    p.integrate(&scan(V2::new(8.0, 10.0), &[rock]), Some(&tube), 5.0);
    assert!(!p.blocked(), "one hit only cancels the free evidence of the first scan");
    p.integrate(&scan(V2::new(8.0, 10.0), &[rock]), Some(&tube), 5.0);
    assert!(p.blocked(), "the rock lies in the tube ahead");
    // From 6 m the sectors' arcs close the gaps. The first scan saw the rock's place free, and
    // a sector's miss cancels one hit: two looks (0.1 s at 10 Hz) mark the rock there.
    for _ in 0..2 {
        p.integrate(&scan(V2::new(14.0, 10.0), &[rock]), Some(&tube), 11.0);
    }
    // The companion stops when the rock is less than STOP_AHEAD_M ahead of the load, and a
    // switch to another tube clears it.
    let s_rock = p.blocked_ahead_m(0.0);
    assert!(s_rock > 14.0 && s_rock < 17.5, "{s_rock}");
    let stop = stop_distance_m(0.4, 1.0);
    assert!((stop - (0.4 + 0.5 + STOP_MARGIN_M)).abs() < 1e-6, "{stop}");
    assert!(!p.must_stop(s_rock - stop - 0.1, stop) && p.must_stop(s_rock - stop + 0.1, stop));
    assert!(p.must_stop(s_rock - 0.01, stop));
    // Past the nearest cell the rest of the rock's face is still ahead: the UAV stays stopped.
    assert!(p.must_stop(s_rock + 0.5, stop), "past the nearest cell, not the rock");
    // Beyond the rock's far side (its diameter past the nearest cell) nothing seen lies ahead.
    assert!(!p.must_stop(s_rock + 2.0 * rock.1 + 0.01, stop), "behind the UAV it no longer stops it");
    assert!(!p.must_stop(f32::NAN, stop), "no section, no stop decision from the map");
    assert_eq!(stop_distance_m(f32::NAN, -1.0), STOP_MARGIN_M, "bad inputs count as 0");
    assert!(p.replan_due(0));
    let mut check = Box::new(CompanionTube::placeholder());
    let planned = p.replan(&tube, &load, 0, &mut Box::new(PlannerSpace::zeroed()), &mut check).unwrap();
    assert!(p.must_stop(s_rock - 1.0, stop), "a re-plan alone does not clear the block: the tube is still the old one");
    assert!(!p.blocked() && !p.replan_due(999) && p.replan_due(1000), "the schedule restarts");
    assert_eq!(p.replans(), 1);
    let new = CompanionTube::from_waypoints(&planned.waypoints).unwrap();
    // The plan's waypoints are on the mission protocol's grid, and the planner's check tube is
    // the tube a member builds from them, bit for bit.
    for w in &planned.waypoints {
        let on_grid = |m: f32| crate::mission::on_wire_grid_m(m).to_bits() == m.to_bits();
        assert!(on_grid(w.pos_m.x) && on_grid(w.pos_m.y), "{w:?} off the wire grid");
    }
    assert_eq!(check.samples(), new.samples(), "the check tube is the offered one");
    assert_eq!(check.length_m().to_bits(), new.length_m().to_bits());
    // Starts at the team's section, 4 m behind the load, and ends at the goal.
    let first = planned.waypoints[0].pos_m;
    assert!((first - V2::new(10.0, 10.0)).norm() < 0.3, "{first:?}");
    assert!((planned.waypoints.last().unwrap().pos_m - V2::new(47.0, 10.0)).norm() < 0.3);
    // No part of the new tube comes within the planner's margin of the rock (less one cell of
    // rasterisation and half a cell of the sector arc).
    for smp in new.samples() {
        for b in [smp.left_boundary_m(), smp.right_boundary_m()] {
            let d = (b - rock.0).norm() - rock.1;
            assert!(d > 0.4 - 0.4, "boundary point {b:?} is {d} m from the rock");
        }
    }
    // A UAV above the load may switch. The new tube bends south round the rock, so its
    // barrier is nearer there than the old tube's (1.0 against 3.0 m, inside the 1.2 m band):
    // it joins with the barrier widened (`accept_joining`: Ok(true)); a UAV on the new tube's
    // side of the load (0.5 m south) switches outright.
    assert_eq!(accept_joining(&new, Some(&tube), &Vec3::new(14.0, 10.0, 7.0), &load, 0.5, 1.2), Ok(true));
    assert_eq!(accept(&new, Some(&tube), &Vec3::new(14.0, 9.5, 7.0), &load, 0.5, 1.2), Ok(()));
    p.handed_over();
    assert!(!p.must_stop(s_rock - 1.0, stop), "switched: what blocked the old tube is gone");
}

#[test]
fn no_route_is_an_error_not_a_tube() {
    let mut p = Box::new(Perception::new(config()).unwrap());
    let tube = straight(10.0, 3.0);
    // A wall of circles across the whole world at x = 25 (0.9 m apart: no gap the team fits).
    let wall: Vec<(V2, f32)> = (0..23).map(|k| (V2::new(25.0, k as f32 * 0.9), 0.6)).collect();
    for y in [2.0, 6.0, 10.0, 14.0, 18.0] {
        p.integrate(&scan(V2::new(18.0, y), &wall), Some(&tube), 15.0);
    }
    assert!(p.blocked());
    let r = p.replan(&tube, &Vec3::new(18.0, 10.0, 3.0), 0, &mut Box::new(PlannerSpace::zeroed()), &mut Box::new(CompanionTube::placeholder()));
    assert!(matches!(r, Err(PlanError::TooNarrow { .. })), "{r:?}");
}

/// A re-plan asks for the half-width the flown formation needs (`Crew::need_half_width_m`) when
/// that is more than `PR_HALF_W`: a gap the configured need fits but the formation's does not
/// gives no route, never a tube the shaped formation cannot keep its floor in.
#[test]
fn a_replan_asks_for_the_width_the_formation_needs() {
    let mut p = Box::new(Perception::new(config()).unwrap());
    let tube = straight(10.0, 3.0);
    // A wall across the world at x = 25 with a 5.6 m gap between circle edges, centred on y = 10.
    let wall: Vec<(V2, f32)> = (0..23).map(|k| k as f32 * 0.9).filter(|y| (y - 10.0).abs() > 3.4).map(|y| (V2::new(25.0, y), 0.6)).collect();
    for y in [4.0, 7.0, 10.0, 13.0, 16.0] {
        p.integrate(&scan(V2::new(19.0, y), &wall), Some(&tube), 15.0);
    }
    let load = Vec3::new(18.0, 10.0, 3.0);
    let mut space = Box::new(PlannerSpace::zeroed());
    let mut check = Box::new(CompanionTube::placeholder());
    let mut plan = |p: &mut Perception, need_m: f32| {
        let prepared = p.prepare(&tube, &load, BACKOFF_M, need_m, 0, &mut space).unwrap();
        space.plan(&prepared, &mut check)
    };
    let fits = plan(&mut p, 0.0).expect("the configured 1.6 m fits the gap");
    assert!(fits.bottleneck.half_width_m >= 1.6, "{:?}", fits.bottleneck);
    assert!(matches!(plan(&mut p, 2.6), Err(PlanError::TooNarrow { .. })), "a formation that needs 2.6 m gets no route");
    // Asking for less than `PR_HALF_W`, or for nothing finite, leaves the configured need; no
    // need beyond the configured widest half-width.
    for need in [0.0, 1.0, f32::NAN, f32::INFINITY] {
        assert_eq!(p.plan_params(need), config().plan, "{need}");
    }
    assert_eq!(p.plan_params(2.6).need_half_width_m, 2.6);
    assert_eq!(p.plan_params(9.0).need_half_width_m, config().plan.max_half_width_m);
}

#[test]
fn a_tube_is_kept_when_it_would_leave_a_uav_or_the_load_outside_or_bring_the_barrier_closer() {
    let (wide, narrow, off) = (straight(10.0, 3.0), straight(10.0, 1.6), straight(14.0, 3.0));
    let load = Vec3::new(20.0, 10.0, 3.0);
    let margin = 0.5;
    // A UAV 1 m left of the centreline: 2 m from the wide tube's boundary, 0.6 m from the narrow's.
    let own = Vec3::new(20.0, 11.0, 7.0);
    assert_eq!(accept(&wide, Some(&narrow), &own, &load, margin, 1.2), Ok(()), "wider is always fine");
    assert_eq!(accept(&narrow, Some(&wide), &own, &load, margin, 1.2), Err(Keep::BarrierJump));
    // Outside the activation band on both, the barrier is off either way.
    assert_eq!(accept(&narrow, Some(&wide), &own, &load, margin, 0.5), Ok(()));
    assert_eq!(accept(&off, Some(&wide), &Vec3::new(20.0, 16.0, 7.0), &load, margin, 1.2), Err(Keep::LoadOutside));
    assert_eq!(accept(&off, Some(&wide), &Vec3::new(20.0, 7.5, 7.0), &load, margin, 1.2), Err(Keep::OwnOutside));
    assert_eq!(accept(&wide, None, &Vec3::new(20.0, 10.0, f32::NAN), &load, margin, 1.2), Ok(()), "height does not matter");
    assert_eq!(accept(&wide, None, &Vec3::new(f32::NAN, 10.0, 7.0), &load, margin, 1.2), Err(Keep::OwnOutside));
    // A UAV that can join a tube widened (the dissipative controller) takes it whenever the
    // load is inside; the load outside is still a refusal, whatever the UAV's own position.
    assert_eq!(accept_joining(&wide, Some(&narrow), &own, &load, margin, 1.2), Ok(false));
    assert_eq!(accept_joining(&narrow, Some(&wide), &own, &load, margin, 1.2), Ok(true));
    assert_eq!(accept_joining(&narrow, Some(&wide), &Vec3::new(20.0, 12.5, 7.0), &load, margin, 1.2), Ok(true), "own centre outside");
    assert_eq!(accept_joining(&off, Some(&wide), &Vec3::new(20.0, 7.5, 7.0), &load, margin, 1.2), Err(Keep::LoadOutside));
    assert_eq!(accept_joining(&off, Some(&wide), &Vec3::new(20.0, 16.0, 7.0), &load, margin, 1.2), Err(Keep::LoadOutside));
    assert_eq!(accept_joining(&off, Some(&wide), &Vec3::new(20.0, 7.5, 7.0), &Vec3::new(20.0, f32::NAN, 3.0), margin, 1.2), Err(Keep::LoadOutside));
}

#[test]
fn a_tube_that_leaves_members_outside_is_never_handed_over() {
    let (wide, off) = (straight(10.0, 3.0), straight(12.0, 3.0));
    let team = [V2::new(20.0, 11.0), V2::new(20.0, 8.0), V2::new(30.0, 12.4)];
    assert!(holds_team(&wide, team, 0.5), "every member 0.6 m or more inside");
    assert!(!holds_team(&wide, team, 1.2), "one member only 1 m inside");
    assert!(!holds_team(&off, team, 0.5), "the member at y = 8 m is outside the shifted tube");
    assert!(!holds_team(&off, team, 1.5));
    assert!(!holds_team(&wide, [V2::new(20.0, f32::NAN)], 0.5), "a position that cannot be placed is outside");
    assert!(holds_team(&wide, [], 0.5), "no member known: nothing left outside");
    // A tube that holds the team goes over whenever it is worth it; one that does not, never.
    assert!(hand_over_now(true, true));
    assert!(!hand_over_now(true, false));
    assert!(!hand_over_now(false, true));
}
