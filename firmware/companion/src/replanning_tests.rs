//! Tests of the re-planning decisions around a companion: the planner's election, an offer
//! round what the map saw, a declined offer retried, and the no-route hold lifted by a route.

use super::*;
use crate::flight::tests::wire::TestIo;
use crate::mission::{on_wire_grid_m, Item};
use crate::perception::tests::{config, scan};
use crate::perception::PerceptionConfig;
use crate::{Companion, Source};

type V2 = vt_plan::Vec2;

fn view<H: Fn(usize) -> bool>(id: usize, n: usize, healthy: H, own: Vec3) -> TeamView<H, core::array::IntoIter<V2, 1>> {
    TeamView { id, n, healthy, positions_m: [own.xy()].into_iter() }
}

fn leaked_tube() -> &'static mut CompanionTube {
    Box::leak(Box::new(CompanionTube::placeholder()))
}

/// A companion flying the straight tube of `perception_tests` (y = 10 m, 3 m each side, x from
/// 3 to 47 m), its UAV at `own`, the load at `load`.
fn companion(own: Vec3, load: Vec3) -> Companion<'static> {
    let mut c = Companion::new(leaked_tube());
    let item = |seq, east: f32, north: f32| Item::tube_waypoint(seq, (north * 1e4) as i32, (east * 1e4) as i32, 3.0, 3.0);
    c.upload_tube(&[item(0, 3.0, 10.0), item(1, 47.0, 10.0)], &mut TestIo(Vec::new())).unwrap();
    c.position(Source::Load, load, Vec3::zeros(), 0, &mut TestIo(Vec::new()));
    c.position(Source::Own, own, Vec3::zeros(), 0, &mut TestIo(Vec::new()));
    c
}

fn replanning(cfg: PerceptionConfig) -> Replanning<'static, 'static> {
    Replanning::new(Box::leak(Box::new(Perception::new(cfg).unwrap())), Box::leak(Box::new(crate::perception::PlannerSpace::zeroed())), leaked_tube(), leaked_tube())
}

#[test]
fn only_the_lowest_healthy_id_plans_and_its_offer_goes_round_what_it_saw() {
    let (own, load) = (Vec3::new(14.0, 10.0, 7.0), Vec3::new(14.0, 10.0, 3.0));
    let mut c = companion(own, load);
    let mut r = replanning(config());
    let rock = (V2::new(20.0, 10.5), 1.5);
    // The sequence of perception_tests' trigger test: seen from 12 m twice, then from 6 m.
    for o in [V2::new(8.0, 10.0), V2::new(8.0, 10.0), V2::new(14.0, 10.0), V2::new(14.0, 10.0)] {
        r.fold(c.tube(), &scan(o, &[rock]), &load);
    }
    assert!(r.map().blocked(), "the rock lies in the tube ahead of the load");
    assert_eq!(r.plan(&c, view(1, 3, |_| true, own), &load, 0), Planned::Idle, "member 1 is not the planner");
    assert_eq!(r.map().replans(), 0);
    assert!(r.plan(&c, view(1, 3, |j| j != 0, own), &load, 0).replanned(), "member 0 silent: member 1 plans");
    // The schedule restarted with that plan; member 0 plans at the next due time.
    assert_eq!(r.plan(&c, view(0, 3, |_| true, own), &load, 500), Planned::Idle, "not due");
    let offer: Vec<Waypoint> = match r.plan(&c, view(0, 3, |_| true, own), &load, 1000) {
        Planned::Offer { waypoints, route_again } => {
            assert!(!route_again, "the team never held for want of a route");
            waypoints.to_vec()
        }
        other => panic!("{other:?}"),
    };
    assert_eq!(r.map().replans(), 2);
    for w in &offer {
        assert_eq!(on_wire_grid_m(w.pos_m.x), w.pos_m.x, "on the mission protocol's grid");
        assert_eq!(on_wire_grid_m(w.pos_m.y), w.pos_m.y);
    }
    // A UAV north of the rock lies outside the new tube (it bends south round the rock):
    // without a dissipative flight to join it widened, it keeps its tube.
    let north = Vec3::new(20.0, 12.5, 7.0);
    c.position(Source::Own, north, Vec3::zeros(), 20, &mut TestIo(Vec::new()));
    let old_len = c.tube().unwrap().length_m();
    assert_eq!(r.take_offer(&mut c, &offer), Err(Some(Keep::OwnOutside)));
    assert_eq!(c.tube().unwrap().length_m(), old_len, "kept");
    assert!(!r.watch(&mut c, &north), "still declined from where it is");
    // Back above the load it may switch: the next watch retries the offer and takes it.
    c.position(Source::Own, own, Vec3::zeros(), 40, &mut TestIo(Vec::new()));
    assert!(r.watch(&mut c, &own), "the retry switches");
    let new = c.tube().unwrap();
    assert!(new.length_m() != old_len && (new.samples()[0].pos_m - offer[0].pos_m).norm() < 1e-3, "flying the offer");
    assert!(!r.watch(&mut c, &own), "nothing left to retry");
}

#[test]
fn with_no_route_close_ahead_the_team_holds_and_a_later_route_lifts_the_hold() {
    let (own, load) = (Vec3::new(18.0, 10.0, 7.0), Vec3::new(18.0, 10.0, 3.0));
    let c = companion(own, load);
    let mut r = replanning(config());
    // perception_tests' wall of circles across the world at x = 25, 7 m ahead of the load.
    let wall: Vec<(V2, f32)> = (0..23).map(|k| (V2::new(25.0, k as f32 * 0.9), 0.6)).collect();
    for y in [2.0, 6.0, 10.0, 14.0, 18.0] {
        r.fold(c.tube(), &scan(V2::new(18.0, y), &wall), &load);
    }
    assert_eq!(r.plan(&c, view(0, 1, |_| true, own), &load, 0), Planned::NoRoute);
    // The wall goes (seen empty again and again): the next plan finds the straight way, and the
    // offer lifts the hold the planner declared.
    for _ in 0..12 {
        for y in [2.0, 6.0, 10.0, 14.0, 18.0] {
            r.fold(c.tube(), &scan(V2::new(18.0, y), &[]), &load);
        }
    }
    match r.plan(&c, view(0, 1, |_| true, own), &load, 1000) {
        Planned::Offer { route_again, .. } => assert!(route_again),
        other => panic!("{other:?}"),
    }
    // The same wall 21 m ahead of the load: no route on the map as seen, but the block is far
    // enough to fly on and look again (HOLD_AHEAD_M): no hold.
    let mut far = replanning(config());
    let wall_far: Vec<(V2, f32)> = (0..23).map(|k| (V2::new(40.0, k as f32 * 0.9), 0.6)).collect();
    for y in [2.0, 6.0, 10.0, 14.0, 18.0] {
        far.fold(c.tube(), &scan(V2::new(33.0, y), &wall_far), &load);
    }
    assert!(far.map().blocked_ahead_m(15.0) > HOLD_AHEAD_M);
    assert_eq!(far.plan(&c, view(0, 1, |_| true, own), &load, 0), Planned::Failed);
}

#[test]
fn a_needed_plan_that_leaves_a_member_outside_is_followed_by_one_from_the_load() {
    let (own, load) = (Vec3::new(14.0, 10.0, 7.0), Vec3::new(14.0, 10.0, 3.0));
    let c = companion(own, load);
    let mut r = replanning(config());
    let rock = (V2::new(20.0, 10.5), 1.5);
    for o in [V2::new(8.0, 10.0), V2::new(8.0, 10.0), V2::new(14.0, 10.0), V2::new(14.0, 10.0)] {
        r.fold(c.tube(), &scan(o, &[rock]), &load);
    }
    // A member 1 m beyond the tube's north edge: the plan, needed (the rock), is kept.
    let outside = TeamView { id: 0, n: 2, healthy: |_: usize| true, positions_m: [own.xy(), V2::new(14.0, 14.0)].into_iter() };
    assert_eq!(r.plan(&c, outside, &load, 0), Planned::Kept);
    assert!((r.offer()[0].pos_m - V2::new(10.0, 10.0)).norm() < 0.3, "the first plan starts 4 m behind the load: {:?}", r.offer()[0].pos_m);
    // The next starts at the load's section; the one after that behind it again.
    let first = |r: &mut Replanning<'static, 'static>, t| match r.plan(&c, view(0, 1, |_| true, own), &load, t) {
        Planned::Offer { waypoints, .. } => waypoints[0].pos_m,
        other => panic!("{other:?}"),
    };
    let p = first(&mut r, 1000);
    assert!((p - V2::new(14.0, 10.0)).norm() < 0.3, "from the load: {p:?}");
    let p = first(&mut r, 2000);
    assert!((p - V2::new(10.0, 10.0)).norm() < 0.3, "back to the back-off point: {p:?}");
}

#[test]
fn the_hand_over_margin_adds_the_flight_until_the_tube_arrives() {
    // r_safe 0.5 m, v_m 1 m/s, 100 ms from the re-plan to the team: 0.6 m.
    assert!((hold_margin_m(0.5, 1.0) - 0.6).abs() < 1e-6);
    assert!((hold_margin_m(0.5, 3.0) - 0.8).abs() < 1e-6);
    for bad in [f32::NAN, f32::INFINITY, -1.0] {
        assert_eq!(hold_margin_m(0.5, bad), 0.5, "speed {bad}");
    }
}

/// A board that plans aside gets what the in-line path gets: the same offer from the search
/// it ran in its task, and the same switch from the tube it built there; nothing is decided
/// before the work comes back, and only one search or build is out at a time.
#[test]
fn a_search_and_a_build_run_aside_give_what_the_in_line_path_gives() {
    let (own, load) = (Vec3::new(14.0, 10.0, 7.0), Vec3::new(14.0, 10.0, 3.0));
    let rock = (V2::new(20.0, 10.5), 1.5);
    let seen = |r: &mut Replanning<'static, 'static>, c: &Companion<'static>| {
        for o in [V2::new(8.0, 10.0), V2::new(8.0, 10.0), V2::new(14.0, 10.0), V2::new(14.0, 10.0)] {
            r.fold(c.tube(), &scan(o, &[rock]), &load);
        }
    };
    // In line.
    let (mut c1, mut r1) = (companion(own, load), replanning(config()));
    seen(&mut r1, &c1);
    let in_line = match r1.plan(&c1, view(0, 3, |_| true, own), &load, 0) {
        Planned::Offer { waypoints, .. } => waypoints.to_vec(),
        other => panic!("{other:?}"),
    };
    r1.take_offer(&mut c1, &in_line).unwrap();
    // Aside: prepared, lent, run, given back, then concluded at the next step.
    let (mut c2, mut r2) = (companion(own, load), replanning(config()));
    seen(&mut r2, &c2);
    assert_eq!(r2.plan_aside(&c2, view(0, 3, |_| true, own), &load, 0), Planned::Idle, "prepared, waiting for the task");
    let mut job = r2.lend().expect("the prepared search");
    assert!(r2.lend().is_none(), "one search out at a time");
    assert_eq!(r2.plan_aside(&c2, view(0, 3, |_| true, own), &load, 20), Planned::Idle, "nothing decided while it is out");
    let searched = job.run();
    assert!(searched.found());
    r2.give_back(job, searched);
    let aside = match r2.plan_aside(&c2, view(0, 3, |_| true, own), &load, 40) {
        Planned::Offer { waypoints, .. } => waypoints.to_vec(),
        other => panic!("{other:?}"),
    };
    assert_eq!(aside, in_line, "the same offer");
    assert!(r2.offer_aside(&aside) && !r2.offer_aside(&aside), "one build at a time");
    assert!(r2.take_built(&mut c2).is_none(), "no switch before the build is back");
    let mut build = r2.lend_build().expect("the offer's build");
    let built = build.run();
    r2.give_back_build(build, built);
    assert_eq!(r2.take_built(&mut c2), Some(Ok(())), "the switch after the build came back");
    assert_eq!(c2.tube().unwrap().length_m(), c1.tube().unwrap().length_m(), "the same tube as in line");
}
