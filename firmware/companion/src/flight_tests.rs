//! Tests of the armed controllers' failsafe and team failsafe (`docs/design.md`, "Team
//! failsafe"), on the paper experiment's defaults (`Params::new`): three UAVs, 50 Hz high level.

use super::*;
use vt_dissipative::{CalibrationError, DissipativeController, FeasibilityError, Formation, FormationScale, Phase};
use crate::params::Params;
use vt_tube::Waypoint;

const HL_MS: u32 = 20;

fn tube() -> Box<CompanionTube> {
    let mut t = Box::new(CompanionTube::placeholder());
    t.rebuild(&[Waypoint::new(0.0, 0.0, 3.5, 3.5), Waypoint::new(20.0, 0.0, 3.5, 3.5), Waypoint::new(40.0, 0.0, 3.5, 3.5)]).unwrap();
    t
}

fn load_pos() -> Vec3 {
    Vec3::new(5.0, 0.0, 3.0)
}

/// UAV `j` of three on a 1.5 m circle, 2.6 m above the load.
fn uav_pos(j: usize) -> Vec3 {
    let a = j as f32 * core::f32::consts::TAU / 3.0;
    load_pos() + Vec3::new(1.5 * libm::cosf(a), 1.5 * libm::sinf(a), 2.6)
}

/// Everything fresh at `now_ms` (UAV 0's view).
fn sources(now_ms: u32) -> Sources {
    let mut s = Sources::new();
    let st = |p| Stamped { value: State { pos_m: p, vel_mps: Vec3::zeros(), sample_ms: now_ms }, stamp_ms: now_ms };
    s.own = Some(st(uav_pos(0)));
    s.load = Some(st(load_pos()));
    for j in 1..3 {
        s.neighbours[j] = Some(Stamped { value: uav_pos(j), stamp_ms: now_ms });
    }
    s
}

fn params(nbr_act: f32) -> Params {
    let mut p = Params::new();
    p.set(Param::FsNbrAct, nbr_act).unwrap();
    p.set(Param::FsResume, 0.1).unwrap(); // 5 high-level steps
    p.set(Param::FsOwnTmo, 0.02).unwrap(); // 10 low-level steps, as host-sim sets it
    p
}

/// UAV 0's controller stepped beside the Flight with the same inputs (the reference).
fn reference(p: &Params) -> DissipativeController<MAX_UAVS> {
    // As `Flight::start`: calibration, formation, capacity-aware scale.
    let takeoff = [uav_pos(0), uav_pos(1), uav_pos(2)];
    let cal = vt_dissipative::calibrate(0, &takeoff, &load_pos(), &p.calibration()).unwrap();
    let f = Formation::<MAX_UAVS>::from_takeoff(&takeoff, &load_pos(), &p.tray()).unwrap();
    let cap = p.capacity().unwrap();
    let plan = capacity::plan_from_takeoff(&takeoff, &load_pos(), &p.tray(), &cap).unwrap();
    DissipativeController::new(0, p.dissipative(&cal).unwrap(), &f).unwrap().with_capacity(FormationScale::new(&plan, &cap))
}

fn measurements(nb: &[Option<Vec3>]) -> Measurements<'_> {
    Measurements { own_pos_m: uav_pos(0), own_vel_mps: Vec3::zeros(), load_pos_m: load_pos(), load_vel_mps: Vec3::zeros(), neighbours_m: nb, neighbours_vel_mps: &[], own_cable_force_n: Some(Vec3::zeros()) }
}

/// Five quiet high-level steps after the last alarm (`FS_RESUME` = 0.1 s): team hold, flown
/// as the reference's, then transport at the fifth.
fn quiet_steps_resume(fl: &mut Flight, r: &mut DissipativeController<MAX_UAVS>, p: &Params, t: &CompanionTube, mut now: u32) {
    let nb = [Some(uav_pos(0)), Some(uav_pos(1)), Some(uav_pos(2))];
    for k in 0..5 {
        now += HL_MS;
        let v = fl.high_level(t, &sources(now), now);
        let expect = if k < 4 { TeamMode::TeamHold } else { TeamMode::Transport };
        assert_eq!(fl.team_mode(), expect, "quiet step {k}");
        r.set_team_hold(k < 4);
        assert_eq!(v, r.update(t, &measurements(&nb), p.high_level_dt_s()).vel_mps, "quiet step {k}");
    }
}

#[test]
fn a_neighbours_hold_is_followed_with_the_controllers_team_hold_and_released_after_fs_resume() {
    let (p, t) = (params(1.0), tube());
    let mut fl = Flight::start(&p, Some(&t), &sources(0), 0).unwrap();
    let mut r = reference(&p);
    let nb = [Some(uav_pos(0)), Some(uav_pos(1)), Some(uav_pos(2))];
    let mut now = 0;
    // Transport: the command is the controller's, advancing along +x.
    let v = fl.high_level(&t, &sources(now), now);
    assert_eq!(v, r.update(&t, &measurements(&nb), p.high_level_dt_s()).vel_mps);
    assert!(v.x > 0.1, "advancing: {v:?}");
    assert_eq!(fl.team_mode(), TeamMode::Transport);
    // UAV 2 broadcasts Hold: UAV 0 follows, flying the team hold (passing off), bit for bit.
    let mut held = sources(0);
    held.neighbour_hold.set(2, true);
    r.set_team_hold(true);
    for _ in 0..3 {
        now += HL_MS;
        let mut src = sources(now);
        src.neighbour_hold = held.neighbour_hold;
        let v = fl.high_level(&t, &src, now);
        assert_eq!(fl.team_mode(), TeamMode::TeamHold, "following is not broadcast as Hold");
        assert!(fl.hold_reasons().is_clear(), "following is no fault of its own");
        assert_eq!(v, r.update(&t, &measurements(&nb), p.high_level_dt_s()).vel_mps);
        assert!(v.x.abs() < 0.05, "no progress in team hold: {v:?}");
    }
    // The hold flag clears: team hold for FS_RESUME = 5 quiet steps, then transport again.
    quiet_steps_resume(&mut fl, &mut r, &p, &t, now);
    assert!(fl.velocity_command_mps().x > 0.1, "advancing again");
}

/// A neighbour that broadcasts `released` (it refused its start, or was blown off its place,
/// and lands) leaves the armed law: its springs and clearance are dropped, bit for bit as if
/// its position were not there, and no hold is raised for it (docs/design.md, "A refused start
/// lands at once"). Without it, the springs pulled the UAVs still flying over its spot.
#[test]
fn a_released_neighbour_leaves_the_armed_law_without_a_hold() {
    let (p, t) = (params(1.0), tube());
    let mut fl = Flight::start(&p, Some(&t), &sources(0), 0).unwrap();
    let mut r = reference(&p);
    let all = [Some(uav_pos(0)), Some(uav_pos(1)), Some(uav_pos(2))];
    let v = fl.high_level(&t, &sources(0), 0);
    assert_eq!(v, r.update(&t, &measurements(&all), p.high_level_dt_s()).vel_mps);
    // UAV 2 released, and on the ground below its place.
    let without = [Some(uav_pos(0)), Some(uav_pos(1)), None];
    let mut now = 0;
    for _ in 0..5 {
        now += HL_MS;
        let mut src = sources(now);
        src.neighbour_released.set(2, true);
        let landed = Vec3::new(uav_pos(2).x, uav_pos(2).y, 0.0);
        src.neighbours[2] = Some(Stamped { value: landed, stamp_ms: now });
        let v = fl.high_level(&t, &src, now);
        assert_eq!(v, r.update(&t, &measurements(&without), p.high_level_dt_s()).vel_mps);
        assert_eq!(fl.team_mode(), TeamMode::Transport, "a released neighbour holds nobody");
        assert!(fl.hold_reasons().is_clear());
    }
}

/// A hold this UAV raises itself (`raise(fl, true)`): its `reason` shows at once, it is
/// broadcast, and the team hold is flown for three steps; then `before_lift` runs and
/// `raise(fl, false)` lifts it, and the team resumes after `FS_RESUME`.
fn own_hold_is_flown_as_the_team_hold(raise: fn(&mut Flight, bool), reason: u8, before_lift: fn(&mut Flight)) {
    let (p, t) = (params(1.0), tube());
    let mut fl = Flight::start(&p, Some(&t), &sources(0), 0).unwrap();
    let mut r = reference(&p);
    let nb = [Some(uav_pos(0)), Some(uav_pos(1)), Some(uav_pos(2))];
    let mut now = 0;
    assert_eq!(fl.high_level(&t, &sources(now), now), r.update(&t, &measurements(&nb), p.high_level_dt_s()).vel_mps);
    raise(&mut fl, true);
    assert_eq!(fl.hold_reasons().0, reason, "the reason shows at once, before the next step");
    r.set_team_hold(true);
    for _ in 0..3 {
        now += HL_MS;
        let v = fl.high_level(&t, &sources(now), now);
        assert_eq!(fl.team_mode(), TeamMode::Hold, "an own detection: the team must follow");
        assert_eq!(fl.hold_reasons().0, reason);
        assert_eq!(v, r.update(&t, &measurements(&nb), p.high_level_dt_s()).vel_mps, "the controller's team hold");
    }
    before_lift(&mut fl);
    raise(&mut fl, false);
    quiet_steps_resume(&mut fl, &mut r, &p, &t, now);
    assert!(fl.hold_reasons().is_clear());
}

#[test]
fn the_operators_hold_is_broadcast_flown_as_the_team_hold_and_lifted_after_fs_resume() {
    own_hold_is_flown_as_the_team_hold(Flight::set_operator_hold, HoldReasons::OPERATOR, |_| {});
}

#[test]
fn a_uav_whose_tube_is_blocked_close_ahead_holds_as_for_no_route_until_it_is_cleared() {
    own_hold_is_flown_as_the_team_hold(Flight::set_blocked, HoldReasons::NO_ROUTE, |fl| {
        // The team's no-route flag does not lift it: only the UAV's own switch or a clear
        // tube does.
        fl.set_no_route(false);
        assert_eq!(fl.hold_reasons().0, HoldReasons::NO_ROUTE);
    });
}

#[test]
fn a_stale_neighbours_hold_flag_is_not_followed() {
    // FS_NBR_ACT = 0: a stale neighbour is dropped from the springs, and its last hold flag
    // with it (its position is what makes the flag current).
    let (p, t) = (params(0.0), tube());
    let mut fl = Flight::start(&p, Some(&t), &sources(0), 0).unwrap();
    let now = 50 * HL_MS;
    let mut src = sources(now);
    src.neighbours[2] = Some(Stamped { value: uav_pos(2), stamp_ms: now - 600 }); // > FS_NBR_TMO
    src.neighbour_hold.set(2, true);
    fl.high_level(&t, &src, now);
    assert_eq!(fl.team_mode(), TeamMode::Transport);
    assert!(fl.hold_reasons().is_clear());
    assert_eq!(fl.last_command().map(|c| c.status.neighbours_dropped), Some(1));
}

#[test]
fn a_stale_neighbour_is_an_own_detection_and_the_team_hold_flies_without_it() {
    // FS_NBR_ACT = 1: broadcast Hold (the team must hold) and fly the team hold with the
    // fresh neighbours' springs, not a blind zero command.
    let (p, t) = (params(1.0), tube());
    let mut fl = Flight::start(&p, Some(&t), &sources(0), 0).unwrap();
    let mut r = reference(&p);
    r.set_team_hold(true);
    let now = HL_MS;
    let mut src = sources(now);
    src.neighbours[1] = None;
    let v = fl.high_level(&t, &src, now);
    assert_eq!(fl.team_mode(), TeamMode::Hold);
    assert_eq!(fl.hold_reasons().0, HoldReasons::NEIGHBOUR_STALE);
    let nb = [Some(uav_pos(0)), None, Some(uav_pos(2))];
    assert_eq!(v, r.update(&t, &measurements(&nb), p.high_level_dt_s()).vel_mps);
    // The low level flies that command (not zero).
    fl.low_level(&src, now);
    assert_eq!(fl.velocity_command_mps(), v);
}

#[test]
fn stale_own_state_holds_with_zero_command_and_the_velocity_loops_failsafe() {
    let (p, t) = (params(1.0), tube());
    let mut fl = Flight::start(&p, Some(&t), &sources(0), 0).unwrap();
    let mut now = 0;
    fl.high_level(&t, &sources(now), now);
    for _ in 0..10 {
        fl.low_level(&sources(now), now);
    }
    // The own state stops: its stamp stays at `last` while the clock runs on.
    let last = now;
    let mut saw_hold = false;
    for _ in 0..20 {
        now += 2;
        let mut src = sources(now);
        src.own = sources(last).own;
        if fl.high_level_due() {
            let v = fl.high_level(&t, &src, now);
            if now - last > p.timeout_ms(Param::FsOwnTmo) {
                assert_eq!(v, Vec3::zeros());
                assert_eq!(fl.team_mode(), TeamMode::Hold);
                assert_eq!(fl.hold_reasons().0 & HoldReasons::OWN_STALE, HoldReasons::OWN_STALE);
                saw_hold = true;
            }
        }
        let sp = fl.low_level(&src, now);
        assert!(sp.q_ned.iter().all(|c| c.is_finite()) && (0.0..=1.0).contains(&sp.thrust));
    }
    assert!(saw_hold, "own state older than FS_OWN_TMO must hold");
    // Fresh again: team hold for FS_RESUME, then transport.
    let modes: Vec<TeamMode> = (0..6)
        .map(|_| {
            now += HL_MS;
            fl.high_level(&t, &sources(now), now);
            fl.team_mode()
        })
        .collect();
    assert_eq!(modes, [TeamMode::TeamHold; 4].into_iter().chain([TeamMode::Transport; 2]).collect::<Vec<_>>());
}

pub(crate) mod wire {
    //! The same logic through the companion's MAVLink interface: a relayed `HEARTBEAT` in
    //! hold from a team member's companion, and the lockstep clock without own state.
    use crate::companion::{Companion, Io, Mode};
    use crate::frames::ned_from_enu;
    use crate::{CompanionTube, Param, AUTOPILOT_COMPONENT_ID, COMPANION_COMPONENT_ID};
    use mavlink::dialects::common::*;
    use mavlink::{MAVLinkV2MessageRaw, MavHeader, MessageData};

    /// A link that keeps what the companion sends.
    pub(crate) struct TestIo(pub(crate) Vec<u8>);
    impl Io for TestIo {
        fn now_ms(&self) -> u32 {
            0
        }
        fn cycles(&self) -> u32 {
            0
        }
        fn send(&mut self, frame: &[u8]) {
            self.0.extend_from_slice(frame);
        }
    }

    /// `d` as one MAVLink 2 frame from (`sys`, `comp`).
    pub(crate) fn frame<D: MessageData>(sys: u8, comp: u8, d: &D) -> Vec<u8> {
        let mut raw = MAVLinkV2MessageRaw::new();
        raw.serialize_message_data(MavHeader { system_id: u32::from(sys), component_id: comp, sequence: 0 }, d);
        raw.raw_bytes().to_vec()
    }

    /// `LOCAL_POSITION_NED` at `t` of the ENU position `p`, at rest.
    pub(crate) fn lpn(t: u32, p: &crate::Vec3) -> LOCAL_POSITION_NED_DATA {
        let [x, y, z] = ned_from_enu(p);
        LOCAL_POSITION_NED_DATA { time_boot_ms: t, x, y, z, vx: 0.0, vy: 0.0, vz: 0.0 }
    }

    fn set(c: &mut Companion<'_>, io: &mut TestIo, p: Param, v: f32) {
        let d = PARAM_SET_DATA { param_value: v, target_system: 0, target_component: 0, param_id: p.info().name.into(), param_type: MavParamType::MAV_PARAM_TYPE_REAL32 };
        c.on_bytes(&frame(255, 190, &d), io);
    }

    /// One lockstep tick of UAV 0 (system 1) at `t`: team data when `hl`, then the own state
    /// (or, `stalled`, the autopilot's `SYSTEM_TIME` at `t` before and after the team data: the
    /// period opened and closed without an own state); `extra` frames first.
    fn tick(c: &mut Companion<'_>, io: &mut TestIo, t: u32, hl: bool, stalled: bool, extra: &[u8]) {
        let mut b = extra.to_vec();
        if stalled {
            b.extend(frame(1, AUTOPILOT_COMPONENT_ID, &SYSTEM_TIME_DATA { time_unix_usec: 0, time_boot_ms: t }));
        }
        if hl {
            b.extend(frame(1, 100, &lpn(t, &super::load_pos())));
            for j in 1..3u8 {
                b.extend(frame(1 + j, AUTOPILOT_COMPONENT_ID, &lpn(t, &super::uav_pos(usize::from(j)))));
            }
        }
        if stalled {
            b.extend(frame(1, AUTOPILOT_COMPONENT_ID, &SYSTEM_TIME_DATA { time_unix_usec: 0, time_boot_ms: t }));
        } else {
            b.extend(frame(1, AUTOPILOT_COMPONENT_ID, &lpn(t, &super::uav_pos(0))));
        }
        c.on_bytes(&b, io);
    }

    /// The board's link driver counts what it loses below the framer (a UART overrun, a
    /// dropped Ethernet frame); `SYS_STATUS` reports them, across later chunks of bytes.
    #[test]
    fn overruns_from_the_link_driver_survive_later_chunks() {
        let mut storage = Box::new(CompanionTube::placeholder());
        let mut c = Companion::new(&mut storage);
        let mut io = TestIo(Vec::new());
        c.add_overruns(2);
        c.on_bytes(&frame(1, AUTOPILOT_COMPONENT_ID, &SYSTEM_TIME_DATA { time_unix_usec: 0, time_boot_ms: 1 }), &mut io);
        c.add_overruns(1);
        c.on_bytes(&[0x00, 0x01], &mut io);
        let link = c.link_counters();
        assert_eq!((link.overruns, link.bytes_discarded), (3, 2));
    }

    #[test]
    fn relayed_hold_heartbeat_and_stalled_own_feed_through_the_wire() {
        let mut storage = Box::new(CompanionTube::placeholder());
        let mut c = Companion::new(&mut storage);
        let mut io = TestIo(Vec::new());
        for (p, v) in [(Param::Lockstep, 1.0), (Param::FsOwnTmo, 0.02), (Param::FsResume, 0.1)] {
            set(&mut c, &mut io, p, v);
        }
        // The tube: 3 waypoints along +x (north in NED is x: the mission's x is north).
        let count = MISSION_COUNT_DATA { count: 3, target_system: 1, target_component: COMPANION_COMPONENT_ID };
        c.on_bytes(&frame(255, 190, &count), &mut io);
        for seq in 0..3u16 {
            let item = MISSION_ITEM_INT_DATA {
                seq,
                x: 0,
                y: i32::from(seq) * 200_000,
                param1: 3.5,
                param2: 3.5,
                command: MavCmd::MAV_CMD_NAV_WAYPOINT,
                frame: MavFrame::MAV_FRAME_LOCAL_NED,
                target_system: 1,
                target_component: COMPANION_COMPONENT_ID,
                ..Default::default()
            };
            c.on_bytes(&frame(255, 190, &item), &mut io);
        }
        assert_eq!(c.mode(), Mode::Ready);
        tick(&mut c, &mut io, 0, true, false, &[]);
        let start = COMMAND_LONG_DATA { command: MavCmd::MAV_CMD_MISSION_START, target_system: 1, target_component: COMPANION_COMPONENT_ID, ..Default::default() };
        c.on_bytes(&frame(255, 190, &start), &mut io);
        assert_eq!(c.mode(), Mode::Transport);
        let mut t = 0;
        let mut run = |c: &mut Companion<'_>, io: &mut TestIo, ticks: u32, stalled: bool, extra: &[u8]| {
            for _ in 0..ticks {
                tick(c, io, t, (t / 2) % 10 == 0, stalled, extra);
                t += 2;
            }
        };
        run(&mut c, &mut io, 20, false, &[]);
        assert_eq!(c.mode(), Mode::Transport);
        // UAV 2's companion (system 3, component 191) announces Hold: UAV 0 follows.
        let hold = frame(3, COMPANION_COMPONENT_ID, &HEARTBEAT_DATA { custom_mode: Mode::Hold as u32, ..Default::default() });
        run(&mut c, &mut io, 20, false, &hold);
        assert_eq!(c.mode(), Mode::TeamHold);
        assert!(c.hold_reasons().is_clear());
        // A heartbeat from the autopilot of system 3 (component 1) is not a companion's: ignored.
        let moving = frame(3, COMPANION_COMPONENT_ID, &HEARTBEAT_DATA { custom_mode: Mode::TeamHold as u32, ..Default::default() });
        run(&mut c, &mut io, 1, false, &moving);
        run(&mut c, &mut io, 60, false, &frame(3, AUTOPILOT_COMPONENT_ID, &HEARTBEAT_DATA { custom_mode: Mode::Hold as u32, ..Default::default() }));
        assert_eq!(c.mode(), Mode::Transport, "released FS_RESUME after UAV 2 left Hold");
        // The own feed stalls (SYSTEM_TIME ticks the clock): own state stale, Hold, announced
        // by a HEARTBEAT at every high-level step.
        let sent_before = heartbeats(&io.0);
        run(&mut c, &mut io, 60, true, &[]);
        assert_eq!(c.mode(), Mode::Hold);
        assert_eq!(c.hold_reasons().0 & crate::HoldReasons::OWN_STALE, crate::HoldReasons::OWN_STALE);
        let hold_beats = heartbeats(&io.0).iter().skip(sent_before.len()).filter(|m| *m & 0xFF == Mode::Hold as u32).count();
        assert!(hold_beats >= 4, "{hold_beats} HEARTBEATs in hold over 6 high-level steps");
        // Back: team hold, then transport.
        run(&mut c, &mut io, 20, false, &[]);
        assert_eq!(c.mode(), Mode::TeamHold);
        run(&mut c, &mut io, 60, false, &[]);
        assert_eq!(c.mode(), Mode::Transport);
    }

    /// `custom_mode` of every HEARTBEAT in the companion's output.
    fn heartbeats(out: &[u8]) -> Vec<u32> {
        let mut f = crate::Framer::new();
        let mut modes = Vec::new();
        for &b in out {
            f.push(b);
            while let Some(fr) = f.next_frame() {
                if fr.message_id == HEARTBEAT_DATA::ID {
                    modes.push(HEARTBEAT_DATA::deser(mavlink::MavlinkVersion::V2, fr.payload).unwrap().custom_mode);
                }
            }
        }
        modes
    }
}

// Calibration aboard and the pre-flight check at start (issue 15).

/// The default parameters (the experiment: 3 UAVs, 3.06 kg) with every source fresh at
/// t = 0: UAVs on a 1.125 m circle 3 m above the load (3.2 m cables, lean cos 0.936).
fn setup(load_kg: f32, uav1_z: f32) -> (Params, Box<CompanionTube>, Sources) {
    let mut p = Params::new();
    p.set(Param::LoadKg, load_kg).unwrap();
    let mut tube = Box::new(CompanionTube::placeholder());
    tube.rebuild(&[vt_tube::Waypoint::new(0.0, 0.0, 3.5, 3.5), vt_tube::Waypoint::new(20.0, 0.0, 3.5, 3.5)]).unwrap();
    let load = Vec3::new(2.0, 0.0, 3.0);
    let at = |i: usize| {
        let a = i as f32 * 2.0944;
        load + Vec3::new(1.125 * libm::cosf(a), 1.125 * libm::sinf(a), if i == 1 { uav1_z } else { 3.0 })
    };
    let stamped = |pos_m| Stamped { value: State { pos_m, vel_mps: Vec3::zeros(), sample_ms: 0 }, stamp_ms: 0 };
    let mut src = Sources::new();
    src.own = Some(stamped(at(0)));
    src.load = Some(stamped(load));
    for j in 1..3 {
        src.neighbours[j] = Some(Stamped { value: at(j), stamp_ms: 0 });
    }
    (p, tube, src)
}

#[test]
fn a_plausible_take_off_calibrates_and_starts() {
    let (p, tube, src) = setup(3.06, 3.0);
    let fl = Flight::start(&p, Some(&tube), &src, 0).unwrap();
    assert!(fl.hold_reasons().is_clear());
}

#[test]
fn an_overweight_declared_load_is_refused_with_the_numbers() {
    // Three 1.47 kg / 30 N UAVs at 30 deg tilt, rated at 27 N (`VT_THR_RES` 10 %), hold about
    // 13 N each along a cable leaning 20.6 deg: 36.6 N of vertical force for 58.9 N (6 kg).
    let (p, tube, src) = setup(6.0, 3.0);
    match Flight::start(&p, Some(&tube), &src, 0) {
        Err(StartError::Infeasible(FeasibilityError::Infeasible { needed_n, available_n, margin, min_margin })) => {
            assert!((needed_n - 58.86).abs() < 1e-3, "{needed_n}");
            assert!((available_n - 36.57).abs() < 0.1, "{available_n}");
            assert!((margin - (available_n / needed_n - 1.0)).abs() < 1e-7);
            assert_eq!(min_margin, 0.01);
        }
        other => panic!("{other:?}"),
    }
    // 3.70 kg (36.3 N) is within the capacity, but not with 1 % to spare: still refused.
    let (p, tube, src) = setup(3.70, 3.0);
    assert!(matches!(Flight::start(&p, Some(&tube), &src, 0), Err(StartError::Infeasible(_))));
    // With the requirement lowered to 0 %, it starts.
    let (mut p, tube, src) = setup(3.70, 3.0);
    p.set(Param::MarginMin, 0.0).unwrap();
    assert!(Flight::start(&p, Some(&tube), &src, 0).is_ok());
    // Without the control reserve (`VT_THR_RES` 0, the rotors at their full 30 N) 4.58 kg
    // (44.9 N) is within the 45.1 N capacity, but not with 1 % to spare.
    let (mut p, tube, src) = setup(4.58, 3.0);
    p.set(Param::ThrRes, 0.0).unwrap();
    match Flight::start(&p, Some(&tube), &src, 0) {
        Err(StartError::Infeasible(FeasibilityError::Infeasible { available_n, .. })) => assert!((available_n - 45.1).abs() < 0.1, "{available_n}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_declared_wind_above_the_capacity_is_refused_with_the_numbers() {
    use vt_dissipative::wind::{self, WindError};
    let (mut p, tube, src) = setup(3.06, 3.0);
    // The law's capacity for this team at its measured take-off lean.
    let takeoff = [src.own.unwrap().value.pos_m, src.neighbours[1].unwrap().value, src.neighbours[2].unwrap().value];
    let cal = vt_dissipative::calibrate(0, &takeoff, &src.load.unwrap().value.pos_m, &p.calibration()).unwrap();
    let cap = wind::capacity(&p.wind(cal.cos_lean)).unwrap();
    // The experiment airframe (1.47 kg, 30 N, 30 deg) with 1 kg of load each: a few m/s.
    assert!((3.0..15.0).contains(&cap.steady_wind_max_mps), "{cap:?}");
    // Nothing declared: no wind check, whatever the weather.
    assert!(Flight::start(&p, Some(&tube), &src, 0).is_ok());
    p.set(Param::WindGust, 1.0).unwrap();
    // Just inside (steady + gust below the capacity) starts; just outside is refused.
    p.set(Param::WindDecl, cap.steady_wind_max_mps - 1.0 - 0.05).unwrap();
    assert!(Flight::start(&p, Some(&tube), &src, 0).is_ok());
    p.set(Param::WindDecl, cap.steady_wind_max_mps - 1.0 + 0.05).unwrap();
    let err = Flight::start(&p, Some(&tube), &src, 0).unwrap_err();
    match err {
        StartError::Wind(WindError::TooStrong { wind_mps, capacity_mps, limit }) => {
            assert!((wind_mps - (cap.steady_wind_max_mps + 0.05)).abs() < 1e-4, "{wind_mps}");
            assert_eq!(capacity_mps, cap.steady_wind_max_mps);
            assert_eq!(limit, cap.limit);
        }
        other => panic!("{other:?}"),
    }
    // The operator reads the numbers in STATUSTEXT; the GCS gets DENIED (companion.rs).
    let (head, detail) = err.lines();
    assert_eq!(head.as_str(), "start refused: wind above the team's capacity");
    let detail = detail.unwrap();
    assert!(detail.as_str().starts_with("wind ") && detail.as_str().contains("m/s > cap "), "{}", detail.as_str());
    assert_eq!(err.code(), 8);
    // A stronger airframe holds the same wind.
    p.set(Param::TiltMax, 0.7).unwrap();
    p.set(Param::ThrustMax, 45.0).unwrap();
    assert!(Flight::start(&p, Some(&tube), &src, 0).is_ok());
}

#[test]
fn an_implausible_take_off_is_refused_by_the_calibration() {
    // UAV 1 below the load.
    let (p, tube, src) = setup(3.06, -0.5);
    assert_eq!(Flight::start(&p, Some(&tube), &src, 0).err(), Some(StartError::Calibration(CalibrationError::NotAboveLoad { index: 1 })));
    // A cable longer than VT_CABLE_LMAX.
    let (mut p, tube, src) = setup(3.06, 3.0);
    p.set(Param::CableLMax, 2.0).unwrap();
    assert!(matches!(
        Flight::start(&p, Some(&tube), &src, 0),
        Err(StartError::Calibration(CalibrationError::LengthOutOfRange { max_m, .. })) if max_m == 2.0
    ));
    // A cable too soft for the load: the stretch exceeds the distance.
    let (mut p, tube, src) = setup(3.06, 3.0);
    p.set(Param::CableK, 1.0).unwrap();
    assert!(matches!(Flight::start(&p, Some(&tube), &src, 0), Err(StartError::Calibration(CalibrationError::StretchExceedsDistance { .. }))));
    // The refusal codes are distinct (HEARTBEAT.custom_mode bits 16..23).
    assert_eq!(StartError::Calibration(CalibrationError::NonFiniteLoad).code(), 6);
}

#[test]
fn the_start_calibrates_from_the_take_off_survey_not_the_last_sample() {
    // Every source's samples alternate +-d around the true position; the last one is off by +d.
    // With the survey the flight is the reference built on the true positions, bit for bit up to
    // the mean's rounding; from the last sample alone (window 1) it is not.
    let (p, t) = (params(1.0), tube());
    let d = Vec3::new(0.3, -0.2, 0.25);
    let surveyed = |window: u32| {
        let mut s = sources(0);
        s.survey.reset(window);
        for k in 0..100 {
            let e = if k % 2 == 0 { -d } else { d };
            s.survey.push_own(&(uav_pos(0) + e));
            s.survey.push_load(&(load_pos() + e));
            for j in 1..3 {
                s.survey.push_member(j, &(uav_pos(j) + e));
            }
        }
        s
    };
    let nb = [Some(uav_pos(0)), Some(uav_pos(1)), Some(uav_pos(2))];
    let mut r = reference(&p);
    let expect = r.update(&t, &measurements(&nb), p.high_level_dt_s()).vel_mps;
    let mut fl = Flight::start(&p, Some(&t), &surveyed(100), 0).unwrap();
    let v = fl.high_level(&t, &sources(0), 0);
    assert!((v - expect).norm() < 1e-4, "survey: {v:?} vs {expect:?}");
    let mut last = Flight::start(&p, Some(&t), &surveyed(1), 0).unwrap();
    let w = last.high_level(&t, &sources(0), 0);
    assert!((w - expect).norm() > 1e-2, "one sample should be off: {w:?} vs {expect:?}");
}

/// A ground start (`VT_START = 1`): no armed law yet, the take-off holds the own horizontal
/// position and climbs towards the nominal cable's taut height less `VT_SLACK`; with a team
/// member never heard at the end of the tension build-up the arming refuses (stale data) and
/// it lands at once with the load on the ground; every command stays finite.
#[test]
fn a_ground_start_climbs_in_place_and_refuses_an_incomplete_team_at_its_arming() {
    let mut p = params(0.0);
    p.set(Param::Start, 1.0).unwrap();
    p.set(Param::TkoS, 1.0).unwrap();
    let t = tube();
    // The UAVs hover 1 m above a load resting on the ground.
    let ground = Vec3::new(5.0, 0.0, 0.3);
    let mut src = sources(0);
    let low = |j: usize| Vec3::new(uav_pos(j).x, uav_pos(j).y, 1.3);
    let st = |pos: Vec3, now: u32| Stamped { value: State { pos_m: pos, vel_mps: Vec3::zeros(), sample_ms: now }, stamp_ms: now };
    src.own = Some(st(low(0), 0));
    src.load = Some(st(ground, 0));
    src.neighbours[1] = Some(Stamped { value: low(1), stamp_ms: 0 });
    src.neighbours[2] = Some(Stamped { value: low(2), stamp_ms: 0 });
    let mut fl = Flight::start(&p, Some(&t), &src, 0).unwrap();
    assert_eq!(fl.phase(), Phase::Takeoff);
    let slack = p.get(Param::SlackM);
    assert!((fl.load_altitude_ref_m().unwrap() - (0.3 - slack)).abs() < 1e-6);
    let v = fl.high_level(&t, &src, 0);
    assert!(v.z > 0.0 && v.xy().norm() < 1e-6, "climb in place: {v:?}");
    assert!(fl.last_command().is_none(), "no armed law before the tension build-up");
    // Run through take-off and tension with member 2 silent from now on.
    let mut now = 0;
    while fl.phase() != Phase::Released && now < 60_000 {
        now += HL_MS;
        src.own = Some(st(low(0), now));
        src.load = Some(st(ground, now));
        src.neighbours[1] = Some(Stamped { value: low(1), stamp_ms: now });
        let v = fl.high_level(&t, &src, now);
        assert!(finite3(&v), "finite command at {now} ms");
        let sp = fl.low_level(&src, now);
        assert!(sp.thrust.is_finite() && sp.q_ned.iter().all(|c| c.is_finite()));
    }
    assert_eq!(fl.phase(), Phase::Released, "refused at the arming: it lands at once");
    assert_eq!(fl.refusal(), Some(&StartError::StaleData));
    assert_eq!(fl.take_refusal(), Some(StartError::StaleData));
    assert_eq!(fl.take_refusal(), None, "reported once");
}

/// A ground start's data at `now`: the own UAV at `place(0)`, members 1 and 2 at theirs, the
/// load resting at `load`, every sample fresh and at rest.
fn feed_ground_team(src: &mut Sources, place: impl Fn(usize) -> Vec3, load: Vec3, now: u32) {
    let st = |pos: Vec3| Stamped { value: State { pos_m: pos, vel_mps: Vec3::zeros(), sample_ms: now }, stamp_ms: now };
    src.own = Some(st(place(0)));
    src.load = Some(st(load));
    for j in 1..3 {
        src.neighbours[j] = Some(Stamped { value: place(j), stamp_ms: now });
    }
}

/// A member released before the arming (its heartbeat's phase: it refused, or was blown off its
/// place) ends the start for the team: this UAV lands at the step it sees that, descending at
/// `LAND_SPEED_MPS`, instead of holding `LIFT_HOLD_ABORT_S` (3 s) in the wind that blew the
/// member off; it reports no refusal of its own. The same member released after the arming
/// only leaves the armed law (`a_released_neighbour_leaves_the_armed_law_without_a_hold`).
#[test]
fn a_member_released_before_the_arming_lands_the_team_at_once() {
    use vt_dissipative::landing::LAND_SPEED_MPS;
    let mut p = params(0.0);
    p.set(Param::Start, 1.0).unwrap();
    let t = tube();
    let ground = Vec3::new(5.0, 0.0, 0.3);
    let low = |j: usize| Vec3::new(uav_pos(j).x, uav_pos(j).y, 1.3);
    let mut src = sources(0);
    let feed = |src: &mut Sources, now: u32| feed_ground_team(src, low, ground, now);
    feed(&mut src, 0);
    let mut fl = Flight::start(&p, Some(&t), &src, 0).unwrap();
    let mut now = 0;
    for _ in 0..5 {
        now += HL_MS;
        feed(&mut src, now);
        let v = fl.high_level(&t, &src, now);
        assert!(v.z > 0.0, "climbing: {v:?}");
    }
    assert_eq!(fl.phase(), Phase::Takeoff);
    src.neighbour_released.set(2, true);
    now += HL_MS;
    feed(&mut src, now);
    let v = fl.high_level(&t, &src, now);
    assert_eq!(fl.phase(), Phase::Released, "lands at the step it sees the member released");
    assert!((v.z + LAND_SPEED_MPS).abs() < 1e-6, "descending: {v:?}");
    assert_eq!(fl.refusal(), None, "the member's refusal, not its own");
}

/// Issue 29, a ground start in a wind the UAV cannot hold on its own: blown more than
/// `STATION_DRIFT_ABORT_M` off its place during the take-off, it refuses (code 10, with the
/// drift) and lands at once where it is, descending at `LAND_SPEED_MPS`; once its altitude has
/// stayed below `LANDED_Z_M` for `LANDED_HOLD_S` its rotors idle (thrust 0, level).
#[test]
fn a_ground_start_blown_off_its_place_refuses_and_lands_where_it_is() {
    use vt_dissipative::landing::{LANDED_HOLD_S, LAND_SPEED_MPS, STATION_DRIFT_ABORT_M};
    let mut p = params(0.0);
    p.set(Param::Start, 1.0).unwrap();
    let t = tube();
    let ground = Vec3::new(5.0, 0.0, 0.3);
    let at = |j: usize, dx: f32, z: f32| Vec3::new(uav_pos(j).x + dx, uav_pos(j).y, z);
    let mut src = sources(0);
    let feed = |src: &mut Sources, dx: f32, z: f32, now: u32| feed_ground_team(src, |j| at(j, dx, z), ground, now);
    feed(&mut src, 0.0, 1.3, 0);
    let mut fl = Flight::start(&p, Some(&t), &src, 0).unwrap();
    // Blown downwind at 2 m/s: still in take-off at 0.9 m, refused past 1 m.
    let mut now = 0;
    let mut dx = 0.0;
    while fl.refusal().is_none() {
        now += HL_MS;
        dx += 2.0 * HL_MS as f32 / 1000.0;
        feed(&mut src, dx, 1.3, now);
        fl.high_level(&t, &src, now);
        assert!(dx < STATION_DRIFT_ABORT_M + 0.1, "not refused at {dx} m");
        if dx <= STATION_DRIFT_ABORT_M - 0.05 {
            assert_eq!(fl.phase(), Phase::Takeoff);
        }
    }
    let Some(StartError::Station { drift_m }) = fl.take_refusal() else { panic!("{:?}", fl.refusal()) };
    assert!(drift_m > STATION_DRIFT_ABORT_M && drift_m < STATION_DRIFT_ABORT_M + 0.1);
    assert_eq!(StartError::Station { drift_m }.code(), 10);
    assert_eq!(StartError::Station { drift_m: 1.234 }.lines().1.unwrap().as_str(), "drifted 1.23m > 1.00m");
    assert_eq!(fl.phase(), Phase::Released);
    // The landing holds where the UAV was when it came down here, and descends.
    let released_x = at(0, dx, 1.3).x;
    feed(&mut src, dx + 0.5, 1.0, now + HL_MS);
    let v = fl.high_level(&t, &src, now + HL_MS);
    assert!((v.z + LAND_SPEED_MPS).abs() < 1e-6 && v.x < 0.0 && v.y.abs() < 1e-6, "{v:?} back towards x = {released_x}");
    assert!(fl.low_level(&src, now + HL_MS).thrust > 0.0, "flying until down");
    // On the ground: idle once the detector has held.
    now += HL_MS;
    let mut idle_at = None;
    for k in 1..200u32 {
        now += HL_MS;
        feed(&mut src, dx, 0.02, now);
        fl.high_level(&t, &src, now);
        let sp = fl.low_level(&src, now);
        assert!(sp.q_ned.iter().all(|c| c.is_finite()));
        if sp.thrust == 0.0 {
            idle_at = Some(k);
            break;
        }
    }
    let k = idle_at.expect("rotors idle on the ground");
    assert!(k as f32 * HL_MS as f32 / 1000.0 >= LANDED_HOLD_S - 1e-3, "not before the detector's hold: {k}");
}

/// Issue 29, an air start: in transport from the start at `VT_LOAD_ZREF`; the load carried back
/// more than 2 m along the tube (a headwind the team cannot hold) starts the set-down within one
/// watch period (`TRANSPORT_WATCH_S`), and the load altitude reference then only goes down, to
/// `VT_LOAD_GZ`, before the slack; every command finite.
#[test]
fn an_air_start_sets_the_load_down_when_it_is_carried_back() {
    let mut p = params(0.0);
    p.set(Param::LoadGz, 0.3).unwrap();
    let t = tube();
    let src0 = sources(0);
    let mut fl = Flight::start(&p, Some(&t), &src0, 0).unwrap();
    assert_eq!((fl.phase(), fl.load_altitude_ref_m()), (Phase::Transport, Some(p.get(Param::LoadZRef))));
    let st = |pos: Vec3, now: u32| Stamped { value: State { pos_m: pos, vel_mps: Vec3::zeros(), sample_ms: now }, stamp_ms: now };
    let mut now = 0;
    let at = |fl: &mut Flight, back_m: f32, now: u32| {
        let shift = Vec3::new(-back_m, 0.0, 0.0);
        let mut src = sources(now);
        src.own = Some(st(uav_pos(0) + shift, now));
        src.load = Some(st(load_pos() + shift, now));
        for j in 1..3 {
            src.neighbours[j] = Some(Stamped { value: uav_pos(j) + shift, stamp_ms: now });
        }
        let v = fl.high_level(&t, &src, now);
        assert!(finite3(&v), "finite command at {now} ms");
    };
    // Held in place for a second, then carried back 1.9 m: still transport.
    for back in [0.0, 1.9] {
        for _ in 0..50 {
            now += HL_MS;
            at(&mut fl, back, now);
        }
        assert_eq!(fl.phase(), Phase::Transport, "carried back {back} m");
    }
    // 2.1 m back: the set-down within one watch period.
    let watch_steps = (TRANSPORT_WATCH_S * 1000.0) as u32 / HL_MS;
    for _ in 0..watch_steps {
        now += HL_MS;
        at(&mut fl, 2.1, now);
    }
    assert_eq!(fl.phase(), Phase::Descent);
    let mut last = fl.load_altitude_ref_m().unwrap();
    while fl.phase() == Phase::Descent && now < 120_000 {
        now += HL_MS;
        at(&mut fl, 2.1, now);
        let z = fl.load_altitude_ref_m().unwrap();
        assert!(z <= last, "the reference only goes down");
        last = z;
    }
    assert_eq!(fl.phase(), Phase::Slack);
    assert!((last - 0.3).abs() < 1e-6, "down to VT_LOAD_GZ: {last}");
}
