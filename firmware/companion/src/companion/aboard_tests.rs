//! The companion's re-planning through its MAVLink interface: range scans placed at their
//! senders, a member's offer pushed and acknowledged, and the planner's own offer on the wire.

use crate::companion::Companion;
use crate::flight::tests::wire::{frame, lpn, TestIo};
use crate::mission::Item;
use crate::params::Param;
use crate::perception::tests::{config, scan};
use crate::perception::Perception;
use crate::replanning::Replanning;
use crate::scans::encode;
use crate::{CompanionTube, Vec3, AUTOPILOT_COMPONENT_ID, COMPANION_COMPONENT_ID};
use mavlink::dialects::common::*;
use mavlink::{MavlinkVersion, Message};

type V2 = vt_plan::Vec2;

impl TestIo {
    /// The messages sent since the last call, decoded.
    fn take(&mut self) -> Vec<MavMessage> {
        let mut out = Vec::new();
        let mut framer = crate::framer::Framer::new();
        for b in core::mem::take(&mut self.0) {
            framer.push(b);
            while let Some(f) = framer.next_frame() {
                out.push(MavMessage::parse(MavlinkVersion::V2, f.message_id, f.payload).unwrap());
            }
        }
        out
    }
}

fn leaked_tube() -> &'static mut CompanionTube {
    Box::leak(Box::new(CompanionTube::placeholder()))
}

/// UAV 0 (system 1) of 3 in lockstep before its mission, flying perception_tests' straight
/// tube (y = 10 m, 3 m each side), with re-planning on that test's 50 x 20 m map.
fn companion() -> (Companion<'static>, TestIo) {
    companion_on(&[(3.0, 10.0), (47.0, 10.0)])
}

/// As [`companion`], on the tube through `waypoints` (east, north; 3 m each side).
fn companion_on(waypoints: &[(f32, f32)]) -> (Companion<'static>, TestIo) {
    let mut c = Companion::new(leaked_tube());
    let mut io = TestIo(Vec::new());
    for (p, v) in [(Param::Lockstep, 1.0), (Param::NUavs, 3.0)] {
        c.set_param(p, v).unwrap();
    }
    let items: Vec<Item> = (0u16..).zip(waypoints).map(|(seq, (e, n))| Item::tube_waypoint(seq, (n * 1e4) as i32, (e * 1e4) as i32, 3.0, 3.0)).collect();
    c.upload_tube(&items, &mut io).unwrap();
    for (p, v) in config().params() {
        c.set_param(p, v).unwrap();
    }
    let map = Box::leak(Box::new(Perception::placeholder()));
    let space = Box::leak(Box::new(crate::perception::PlannerSpace::zeroed()));
    let slot = Box::leak(Box::new(crate::ReplanSlot::new()));
    assert!(c.attach_replanning(slot, Replanning::new(map, space, leaked_tube(), leaked_tube())).is_none());
    (c, io)
}

/// One lockstep period at `t` before the mission: the load, member 1 at `m1`, `extra` frames,
/// then the own state at `own` (which runs the perception step).
fn period(c: &mut Companion<'static>, io: &mut TestIo, t: u32, own: &Vec3, m1: &Vec3, extra: &[u8]) {
    let mut b = frame(1, 100, &lpn(t, &Vec3::new(own.x, own.y, 3.0)));
    b.extend(frame(2, AUTOPILOT_COMPONENT_ID, &lpn(t, m1)));
    b.extend_from_slice(extra);
    b.extend(frame(1, AUTOPILOT_COMPONENT_ID, &lpn(t, own)));
    c.on_bytes(&b, io);
}

fn occupied(c: &Companion<'static>) -> usize {
    c.replanning().unwrap().map().map().occupied_count()
}

/// Occupied cells whose centre lies within `r` of `p`.
fn occupied_near(c: &Companion<'static>, p: V2, r: f32) -> usize {
    let g = c.replanning().unwrap().map().map();
    (0..g.height()).flat_map(|j| (0..g.width()).map(move |i| (i, j))).filter(|&(i, j)| g.is_occupied(i, j) && (g.cell_center_m(i, j).unwrap() - p).norm() <= r).count()
}

#[test]
fn scans_are_placed_at_their_senders_and_one_before_any_position_keeps_the_map() {
    let (mut c, mut io) = companion();
    let rock = [(V2::new(20.0, 10.0), 1.0)];
    let wire = |o: V2| encode(&scan(o, &rock), 5, 0).unwrap();
    // Before any own position the own scan cannot be placed: dropped, the re-planning kept.
    c.on_bytes(&frame(1, AUTOPILOT_COMPONENT_ID, &wire(V2::new(14.0, 10.0))), &mut io);
    assert!(c.replanning().is_some(), "a scan that cannot be placed must not lose the map");
    assert_eq!(occupied(&c), 0);
    // The own scan, taken 6 m short of the rock, is placed at the own position: the rock's face
    // is marked at x = 19 m, not where a scan from elsewhere would put it.
    let own = Vec3::new(14.0, 10.0, 7.0);
    period(&mut c, &mut io, 0, &own, &Vec3::new(10.0, 10.0, 7.0), &[]);
    for _ in 0..2 {
        c.on_bytes(&frame(1, AUTOPILOT_COMPONENT_ID, &wire(V2::new(14.0, 10.0))), &mut io);
    }
    assert!(occupied_near(&c, V2::new(19.0, 10.0), 0.4) > 0, "the rock's face where the own UAV saw it");
    let marked = occupied(&c);
    // Member 1's scan (system 2) of the same rock from 10 m, placed at member 1's position: the
    // same face, nothing where a scan from the own position would have put it (5 m further).
    c.on_bytes(&frame(2, AUTOPILOT_COMPONENT_ID, &wire(V2::new(10.0, 10.0))), &mut io);
    assert_eq!(occupied_near(&c, V2::new(24.0, 10.0), 1.0), 0, "nothing where the own position would have put it");
    assert!(occupied(&c) >= marked);
    // A system outside the team is ignored, counted.
    let ignored = c.value_counters().ignored;
    c.on_bytes(&frame(9, AUTOPILOT_COMPONENT_ID, &wire(V2::new(14.0, 10.0))), &mut io);
    assert_eq!(c.value_counters().ignored, ignored + 1);
    // A message the convention does not carry (increment 7 deg) is a bad value.
    let bad = c.value_counters().bad_values;
    let mut odd = wire(V2::new(14.0, 10.0));
    odd.increment = 7;
    c.on_bytes(&frame(1, AUTOPILOT_COMPONENT_ID, &odd), &mut io);
    assert_eq!(c.value_counters().bad_values, bad + 1);
}

#[test]
fn the_planner_pushes_its_tube_and_a_members_push_is_taken_and_acknowledged() {
    // A tube with a detour north: the straight plan on the empty map is worth a switch.
    let (mut c, mut io) = companion_on(&[(3.0, 10.0), (25.0, 17.0), (47.0, 10.0)]);
    let (own, m1) = (Vec3::new(5.0, 10.5, 7.0), Vec3::new(4.0, 10.0, 7.0));
    // UAV 0 is the lowest healthy id: its first period plans on the empty map and pushes the
    // tube to the team, broadcast, without the ground station's requests.
    period(&mut c, &mut io, 0, &own, &m1, &[]);
    let sent = io.take();
    let count = sent.iter().find_map(|m| if let MavMessage::MISSION_COUNT(d) = m { Some(d.clone()) } else { None }).expect("a MISSION_COUNT");
    let items: Vec<MISSION_ITEM_INT_DATA> = sent.iter().filter_map(|m| if let MavMessage::MISSION_ITEM_INT(d) = m { Some(d.clone()) } else { None }).collect();
    let offer = c.offer_sent().unwrap().to_vec();
    assert_eq!((count.target_system, usize::from(count.count), items.len()), (0, offer.len(), offer.len()));
    for (k, (it, w)) in items.iter().zip(&offer).enumerate() {
        assert_eq!((usize::from(it.seq), it.target_system, it.frame), (k, 0, MavFrame::MAV_FRAME_LOCAL_NED));
        assert_eq!((it.y as f32 / 1e4, it.x as f32 / 1e4, it.param1), (w.pos_m.x, w.pos_m.y, w.w_left_m), "item {k}");
    }
    let r = c.take_replan_report();
    assert!(r.offered && r.replans == 1 && r.planned == 1, "{r:?}");
    // ... and reports its counts on the link (what the MAVLink backends count).
    let debug = |name: &str| sent.iter().find_map(|m| if let MavMessage::DEBUG_VECT(d) = m { (d.name.to_str().unwrap() == name).then_some((d.x, d.y, d.z)) } else { None });
    assert_eq!(debug(super::NAME_REPLAN).map(|(x, y, _)| (x, y)), Some((1.0, 1.0)), "REPLAN: one re-plan, one tube");
    assert_eq!(debug(super::NAME_TUBES), Some((0.0, 0.0, 0.0)), "TUBES: no switch yet, none declined, a route");
    // Member 1 (system 2) pushes a tube bent 1 m north: taken at the next perception step and
    // acknowledged to it.
    let bent = [(3.0, 10.0), (25.0, 11.0), (47.0, 10.0)];
    let mut push = frame(2, COMPANION_COMPONENT_ID, &MISSION_COUNT_DATA { count: 3, target_system: 0, target_component: 0 });
    for (seq, (e, n)) in (0u16..).zip(bent) {
        let it = MISSION_ITEM_INT_DATA {
            seq,
            x: (n * 1e4) as i32,
            y: (e * 1e4) as i32,
            param1: 3.0,
            param2: 3.0,
            command: MavCmd::MAV_CMD_NAV_WAYPOINT,
            frame: MavFrame::MAV_FRAME_LOCAL_NED,
            ..Default::default()
        };
        push.extend(frame(2, COMPANION_COMPONENT_ID, &it));
    }
    let len_before = c.tube().unwrap().length_m();
    period(&mut c, &mut io, 20, &own, &m1, &push);
    let ack = io.take().into_iter().find_map(|m| if let MavMessage::MISSION_ACK(d) = m { Some(d) } else { None }).expect("a MISSION_ACK");
    assert_eq!((ack.target_system, ack.target_component, ack.mavtype), (2, COMPANION_COMPONENT_ID, MavMissionResult::MAV_MISSION_ACCEPTED));
    assert!((c.tube().unwrap().length_m() - len_before).abs() > 1e-3, "flying the pushed tube");
    assert_eq!(c.take_replan_report().switches, 1);
    // A ground station's upload (component 190) is not an offer: it is the mission upload it
    // always was (no flight yet), answered with a request for its first item.
    c.on_bytes(&frame(255, 190, &MISSION_COUNT_DATA { count: 2, target_system: 1, target_component: COMPANION_COMPONENT_ID }), &mut io);
    assert!(io.take().iter().any(|m| matches!(m, MavMessage::MISSION_REQUEST_INT(d) if d.seq == 0 && d.target_system == 255)));
}

#[test]
fn the_map_follows_its_parameters_and_a_start_without_one_is_refused() {
    let (mut c, mut io) = companion();
    let rock = [(V2::new(20.0, 10.0), 1.0)];
    let (own, m1) = (Vec3::new(14.0, 10.0, 7.0), Vec3::new(10.0, 10.0, 7.0));
    period(&mut c, &mut io, 0, &own, &m1, &[]);
    period(&mut c, &mut io, 20, &own, &m1, &encoded(&scan(V2::new(14.0, 10.0), &rock)));
    assert!(occupied(&c) > 0);
    // A `PR_*` parameter set: the map is configured afresh at its next use (empty).
    c.set_param(Param::PrCell, 0.5).unwrap();
    period(&mut c, &mut io, 40, &own, &m1, &[]);
    assert_eq!((occupied(&c), c.replanning().unwrap().map().map().resolution_m()), (0, 0.5));
    // A world the map cannot hold at its cell: no map, and the start says so.
    c.set_param(Param::PrCell, 0.01).unwrap();
    assert_eq!(c.start_mission(&mut io), Err(crate::flight::StartError::NoMap));
    assert!(io.take().iter().any(|m| matches!(m, MavMessage::STATUSTEXT(d) if d.text.to_str().unwrap_or("").contains("no onboard map"))));
    // `PR_MAP` 1 without the storage (a board that gives none): refused the same way.
    c.detach_replanning();
    c.set_param(Param::PrCell, 0.25).unwrap();
    assert_eq!(c.start_mission(&mut io), Err(crate::flight::StartError::NoMap));
}

/// `scan` as the own autopilot's `OBSTACLE_DISTANCE` (system 1).
fn encoded(s: &vt_map::Scan) -> Vec<u8> {
    frame(1, AUTOPILOT_COMPONENT_ID, &encode(s, 5, 0).unwrap())
}
