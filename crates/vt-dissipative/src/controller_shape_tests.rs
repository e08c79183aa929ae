//! Tests of the formation shaped to the tube (`controller/tube_shape.rs`, shape.rs): the
//! stadium's rest lengths, its separation floor, the width a planner must give it, its frame
//! and its passage speed (kept apart from `controller_tests.rs` by concept).

use super::*;
use crate::shape::StadiumTeam;

/// With bodies, the stadium lengthens until every pair of UAVs keeps the separation floor where
/// they fly (below their nodes, on their cables: shape.rs), and no further than the capacity
/// allows; the springs still agree at both ends, and the ring comes back bit for bit.
#[test]
fn a_separated_stadium_keeps_the_floor_where_the_uavs_fly() {
    let n = 10;
    let t = tube();
    let (uavs, load) = takeoff(n, 4.0);
    let f = Formation::<N>::from_takeoff(&uavs, &load, &params().tray).unwrap();
    let lengths: Vec<u16> = uavs.iter().map(|u| ((u - load).norm() * 1e3).round() as u16).collect();
    let narrow = t.locate(Vec2::new(27.0, 0.5), 0).unwrap();
    let wide = t.locate(Vec2::new(4.0, 0.0), 0).unwrap();
    // The take-off ring keeps 1.42 m between neighbours where they fly; a 1.3 m floor.
    let sep = ShapeSeparation { takeoff_m: &uavs, load_m: load, separation_m: 1.3, min_cos_sum: 0.0 };
    let mut ctl = team(n, &uavs, &load);
    let ring: Vec<_> = ctl.iter().map(|c| c.rest).collect();
    let mut short = team(n, &uavs, &load);
    for (c, s) in ctl.iter_mut().zip(short.iter_mut()) {
        c.set_shape(ShapeParams::default(), &f, Some(sep)).unwrap();
        s.set_shape(ShapeParams::default(), &f, None).unwrap();
        c.shape_to_tube(&t, &narrow);
        s.shape_to_tube(&t, &narrow);
        assert!(c.shape_fraction() < 0.6 && c.shape_fraction() == s.shape_fraction());
    }
    let shape = ctl[0].shape.as_ref().unwrap();
    let (r, a) = (shape.radius_m, shape.half_length_m);
    let b = r * shape.quantum as f32 / QUANTA as f32;
    assert!(a > r && a <= 2.0 * r - b + 1e-4, "lengthened within 2r - b: {a} (r {r}, b {b})");
    // Where the UAVs fly, the floor holds at the chosen length and not at the ring's radius.
    let frame = shape.frame.unwrap();
    let normal = Vec2::new(-frame.y, frame.x);
    let angles: Vec<f32> = shape.nodes_m.iter().take(n).map(|p| {
        let o = p - shape.centre_m;
        vt_fpu::atan2(o.dot(&normal), o.dot(&frame))
    }).collect();
    let o = shape.load_node_m - shape.centre_m;
    let st = StadiumTeam { angles_rad: &angles, lengths_mm: &lengths, load_m: Vec2::new(o.dot(&frame), o.dot(&normal)), tray_height_m: params().tray.height_above_load_m, layout: crate::shape::Layout::Ring };
    assert!(st.min_distance_m(r, b, 1.0) < 1.3, "the short stadium breaks the floor: {}", st.min_distance_m(r, b, 1.0));
    assert!(st.min_distance_m(a, b, 1.0) >= 1.3, "{}", st.min_distance_m(a, b, 1.0));
    // Longer front to back than the short stadium; the springs agree at both ends.
    let (front, back) = (0, n / 2);
    assert!(ctl[front].rest.own_m[back] > short[front].rest.own_m[back] + 0.1);
    for i in 0..n {
        for j in 0..n {
            assert_eq!(ctl[i].rest.own_m[j], ctl[j].rest.own_m[i], "spring {i}-{j}");
        }
        assert_eq!(ctl[i].rest.center_m, ctl[0].rest.center_m);
    }
    for (c, rg) in ctl.iter_mut().zip(ring.iter()) {
        c.shape_to_tube(&t, &wide);
        assert_eq!((c.rest.own_m, c.rest.center_m, c.rest.own_load_m), (rg.own_m, rg.center_m, rg.own_load_m), "the ring, bit for bit");
    }
    // A capacity need that the ring itself barely meets: no step longer than the ring.
    let tight = ShapeSeparation { min_cos_sum: st.cos_sum(r, b, 1.0), ..sep };
    let mut c = team(n, &uavs, &load).remove(0);
    c.set_shape(ShapeParams::default(), &f, Some(tight)).unwrap();
    c.shape_to_tube(&t, &narrow);
    assert_eq!(c.shape.as_ref().unwrap().half_length_m, r, "capacity first");
    // Bad lengths or floors are refused.
    for bad in [ShapeSeparation { separation_m: f32::NAN, ..sep }, ShapeSeparation { takeoff_m: &uavs[..3], ..sep }, ShapeSeparation { load_m: uavs[0], ..sep }, ShapeSeparation { min_cos_sum: -1.0, ..sep }] {
        assert!(team(n, &uavs, &load).remove(0).set_shape(ShapeParams::default(), &f, Some(bad)).is_err());
    }
}

/// The separated stadium reaches further than the ring: it stays narrow until the passage has
/// left its half-length behind the load, not the ring's radius (docs/design.md, "The shape
/// narrows as the passage comes"; the rear pair leaving a passage met there).
#[test]
fn a_separated_stadium_widens_only_once_the_passage_is_behind_its_length() {
    let n = 10;
    // A 5 m waist with abrupt ends.
    let t: Tube<256> = Tube::from_waypoints(&[
        Waypoint::new(0.0, 0.0, 6.0, 6.0),
        Waypoint::new(24.0, 0.0, 5.0, 5.0),
        Waypoint::new(25.0, 0.0, 2.2, 2.2),
        Waypoint::new(30.0, 0.0, 2.2, 2.2),
        Waypoint::new(31.0, 0.0, 5.0, 5.0),
        Waypoint::new(60.0, 0.0, 6.0, 6.0),
    ])
    .unwrap();
    let (uavs, load) = takeoff(n, 4.0);
    let f = Formation::<N>::from_takeoff(&uavs, &load, &params().tray).unwrap();
    let sep = ShapeSeparation { takeoff_m: &uavs, load_m: load, separation_m: 1.3, min_cos_sum: 0.0 };
    let mut c = team(n, &uavs, &load).remove(0);
    c.set_shape(ShapeParams::default(), &f, Some(sep)).unwrap();
    // A first look with the waist in the look-ahead: the team slows at once (the passage speed
    // follows the window's narrowest section), while the shape has narrowed only part of the way.
    c.shape_to_tube(&t, &t.locate(Vec2::new(16.5, 0.0), 0).unwrap());
    {
        let s = c.shape.as_ref().unwrap();
        assert_eq!((s.quantum, s.speed_fraction()), (QUANTA, crate::shape::PASSAGE_SPEED_FRACTION), "slowed, still the ring");
        assert!(s.speed_quantum < QUANTA);
    }
    // Into the waist, a look every 0.2 m.
    let mut x = 20.0f32;
    while x <= 30.0 {
        c.shape_to_tube(&t, &t.locate(Vec2::new(x, 0.0), 0).unwrap());
        x += 0.2;
    }
    let (r, a, q_waist) = {
        let s = c.shape.as_ref().unwrap();
        (s.radius_m, s.half_length_m, s.quantum)
    };
    assert!(a > r + 0.5, "a long stadium at the waist: {a} against the ring's {r}");
    // The waist just inside the stadium's half-length behind the load, beyond the ring's radius.
    let behind = a - 0.1;
    while x <= 30.0 + behind {
        c.shape_to_tube(&t, &t.locate(Vec2::new(x, 0.0), 0).unwrap());
        x += 0.2;
    }
    let held = c.shape.as_ref().unwrap().quantum;
    assert!(held <= q_waist + 1, "held narrow while the rear is in the waist: {held} against {q_waist}");
    // Reaching only the ring's radius, the tube there would already have widened it.
    let sec = t.locate(Vec2::new(x, 0.0), 0).unwrap();
    let ring_reach = crate::shape::ramped_half_width_m(&t, sec.s_m, r, r, ShapeParams::default().ahead_m, crate::shape::RAMP_LEAD_M, crate::shape::RAMP_BEHIND_M).unwrap();
    let q_ring_reach = crate::shape::quantum(ring_reach - c.params.r_safe_m - ShapeParams::default().margin_m, r, crate::shape::min_quantum(n));
    assert!(q_ring_reach >= held + 2, "the ring's reach would widen: {q_ring_reach} against {held}");
}

/// Issue 28: the half-width a planner must give the shaped formation. In a tube of that width
/// the look flies a stadium that keeps the floor where the UAVs fly; in any narrower one the
/// stadium it would fly does not (or it is the narrowest, which no tube narrower can shape
/// further). Without a floor, or without a shape, nothing is asked beyond the planner's own.
#[test]
fn the_planner_is_asked_for_the_width_the_separated_stadium_keeps_its_floor_in() {
    use crate::shape::{min_quantum, quantum};
    let n = 10;
    let (uavs, load) = takeoff(n, 4.0);
    let f = Formation::<N>::from_takeoff(&uavs, &load, &params().tray).unwrap();
    let tangent = Vec2::new(1.0, 0.0);
    let mut plain = team(n, &uavs, &load).remove(0);
    assert_eq!(plain.shaped_need_half_width_m(&tangent), None, "no shape");
    plain.set_shape(ShapeParams::default(), &f, None).unwrap();
    assert_eq!(plain.shaped_need_half_width_m(&tangent), None, "no floor");
    for floor in [1.3_f32, 1.6, 2.0] {
        let sep = ShapeSeparation { takeoff_m: &uavs, load_m: load, separation_m: floor, min_cos_sum: 0.0 };
        let mut c = team(n, &uavs, &load).remove(0);
        c.set_shape(ShapeParams::default(), &f, Some(sep)).unwrap();
        let need = c.shaped_need_half_width_m(&tangent).unwrap();
        let shape = c.shape.as_ref().unwrap();
        let ring = shape.radius_m * c.rest_scale;
        let room = |w: f32| w - c.params.r_safe_m - shape.params.margin_m;
        let h = c.params.tray.height_above_load_m;
        // At the need (plus rounding) the quantum flown keeps the floor, and so does every wider
        // stadium (the ring itself is what a need of its whole width leaves: it has no other).
        let q_need = quantum(room(need + 1e-4), ring, min_quantum(n));
        for q in q_need..QUANTA {
            assert!(shape.flown_min_distance_m(q, 1.0, tangent, n, h, &c.scale) >= shape.separation_m, "floor {floor}: quantum {q} at or above the need's {q_need}");
        }
        // Just below it, the quantum flown breaks the floor, unless the need is the narrowest shape.
        let q_below = quantum(room(need - 1e-3), ring, min_quantum(n));
        if q_below < q_need {
            assert!(shape.flown_min_distance_m(q_below, 1.0, tangent, n, h, &c.scale) < shape.separation_m, "floor {floor}: quantum {q_below} below the need");
        } else {
            assert_eq!(q_need, min_quantum(n), "floor {floor}");
        }
        assert!(need > c.params.r_safe_m + shape.params.margin_m && need <= c.params.r_safe_m + shape.params.margin_m + ring + 1e-4, "floor {floor}: {need}");
        // A higher floor never asks for less.
        if floor > 1.3 {
            let low = ShapeSeparation { separation_m: 1.3, ..sep };
            let mut d = team(n, &uavs, &load).remove(0);
            d.set_shape(ShapeParams::default(), &f, Some(low)).unwrap();
            assert!(need >= d.shaped_need_half_width_m(&tangent).unwrap(), "floor {floor}");
        }
    }
    // Three UAVs: the stadium narrows only to 28 of 32 and keeps the floor there; a tube
    // narrower squeezes it sideways, which their pairs take down to the floor plus the guard.
    let (uavs3, load3) = takeoff(3, 4.0);
    let f3 = Formation::<N>::from_takeoff(&uavs3, &load3, &params().tray).unwrap();
    let sep = ShapeSeparation { takeoff_m: &uavs3, load_m: load3, separation_m: 1.3, min_cos_sum: 0.0 };
    let mut c = team(3, &uavs3, &load3).remove(0);
    c.set_shape(ShapeParams::default(), &f3, Some(sep)).unwrap();
    let need = c.shaped_need_half_width_m(&tangent).unwrap();
    let shape = c.shape.as_ref().unwrap();
    let (ring, base, h) = (shape.radius_m * c.rest_scale, c.params.r_safe_m + shape.params.margin_m, c.params.tray.height_above_load_m);
    let fq = min_quantum(3);
    assert!(need < base + ring * fq as f32 / QUANTA as f32 - 0.1, "squeezed below the narrowest stadium: {need}");
    let k = (need - base) / ring * QUANTA as f32 / fq as f32;
    let guarded = shape.separation_m + SQUEEZE_GUARD_M;
    assert!(shape.flown_min_distance_m(fq, k + 1e-4, tangent, 3, h, &c.scale) >= guarded, "at the need: {k}");
    assert!(shape.flown_min_distance_m(fq, k - 1.0 / fq as f32, tangent, 3, h, &c.scale) < guarded, "a step narrower: {k}");
    // A floor no stadium keeps (the ring itself breaks it) asks for the ring's whole width.
    let sep = ShapeSeparation { takeoff_m: &uavs, load_m: load, separation_m: 5.0, min_cos_sum: 0.0 };
    let mut c = team(n, &uavs, &load).remove(0);
    c.set_shape(ShapeParams::default(), &f, Some(sep)).unwrap();
    let shape = c.shape.as_ref().unwrap();
    let full = c.params.r_safe_m + shape.params.margin_m + shape.radius_m * c.rest_scale;
    assert_eq!(c.shaped_need_half_width_m(&tangent), Some(full));
    assert_eq!(c.shaped_need_half_width_m(&Vec2::new(f32::NAN, 0.0)), None, "a degenerate frame asks nothing");
}

/// The stadium flown lengthens until its pairs keep the floor plus [`STADIUM_GUARD_M`] where
/// they fly, or to its longest (`2 r - b`), never past the load's capacity; it is never shorter
/// than the stadium the planner's need is computed on, and its closest pair never closer
/// (docs/design.md, "The stadium flown keeps a wider floor").
#[test]
fn the_stadium_flown_keeps_a_wider_floor_than_the_planner_asks_for() {
    use crate::separation::STADIUM_GUARD_M;
    use crate::shape::{min_quantum, separated_half_length_m, StadiumLimits};
    let n = 10;
    let (uavs, load) = takeoff(n, 4.0);
    let f = Formation::<N>::from_takeoff(&uavs, &load, &params().tray).unwrap();
    let lengths: Vec<u16> = uavs.iter().map(|u| ((u - load).norm() * 1e3).round() as u16).collect();
    let frame = Vec2::new(1.0, 0.0);
    let h = params().tray.height_above_load_m;
    let sep = ShapeSeparation { takeoff_m: &uavs, load_m: load, separation_m: 1.3, min_cos_sum: 0.0 };
    let mut c = team(n, &uavs, &load).remove(0);
    c.set_shape(ShapeParams::default(), &f, Some(sep)).unwrap();
    let shape = c.shape.as_ref().unwrap();
    let r = shape.radius_m;
    // The node angles about the tray centre in the frame (x along the tube, as `angle_rad`).
    let angles: Vec<f32> = shape.nodes_m.iter().take(n).map(|p| {
        let o = p - shape.centre_m;
        vt_fpu::atan2(o.y, o.x)
    }).collect();
    let st = StadiumTeam { angles_rad: &angles, lengths_mm: &lengths, load_m: shape.load_node_m - shape.centre_m, tray_height_m: h, layout: crate::shape::Layout::Ring };
    let limits = StadiumLimits { separation_m: 1.3, separation_scale: c.scale.scale_min(), min_cos_sum: 0.0, capacity_scale: c.scale.scale_target() };
    let mut wider = 0;
    for q in min_quantum(n)..QUANTA {
        let b = r * q as f32 / QUANTA as f32;
        let need = separated_half_length_m(&st, &limits, r, b);
        let flown = shape.half_length_for(q, frame, n, h, &c.scale);
        assert!(flown >= need, "quantum {q}: {flown} shorter than {need}");
        let (d_need, d_flown) = (st.min_distance_m(need, b, 1.0), st.min_distance_m(flown, b, 1.0));
        assert!((d_need - shape.flown_min_distance_m(q, 1.0, frame, n, h, &c.scale)).abs() < 1e-5, "quantum {q}: the need's stadium as the shape sees it");
        assert!(d_flown >= d_need, "quantum {q}: closest pair {d_flown} < {d_need}");
        assert!(d_flown >= 1.3 + STADIUM_GUARD_M || (flown - (2.0 * r - b)).abs() < 1e-3, "quantum {q}: {d_flown} short of the wider floor at {flown} (longest {})", 2.0 * r - b);
        wider += i32::from(flown > need);
    }
    assert!(wider > 0, "the wider floor lengthens some stadium");
    // The load's capacity first: a need the ring itself barely meets leaves the ring's length.
    let b = r * min_quantum(n) as f32 / QUANTA as f32;
    let tight = ShapeSeparation { min_cos_sum: st.cos_sum(r, b, c.scale.scale_target()), ..sep };
    let mut t = team(n, &uavs, &load).remove(0);
    t.set_shape(ShapeParams::default(), &f, Some(tight)).unwrap();
    assert_eq!(t.shape.as_ref().unwrap().half_length_for(min_quantum(n), frame, n, h, &t.scale), r, "capacity first");
}

/// Every UAV derives the same stadium: each spring's rest length is the same at both ends,
/// the tray centre's are the same in every replica; the wide tube leaves the ring bit for bit,
/// and without `set_shape` a look changes nothing.
#[test]
fn shaped_rest_lengths_agree_at_both_ends() {
    let n = 10;
    let t = tube();
    let (uavs, load) = takeoff(n, 4.0);
    let f = Formation::<N>::from_takeoff(&uavs, &load, &params().tray).unwrap();
    let mut ctl = team(n, &uavs, &load);
    let ring: Vec<_> = ctl.iter().map(|c| c.rest).collect();
    let mut plain = ctl[0].clone();
    for c in ctl.iter_mut() {
        c.set_shape(ShapeParams::default(), &f, None).unwrap();
    }
    let wide = t.locate(Vec2::new(4.0, 0.0), 0).unwrap();
    let narrow = t.locate(Vec2::new(27.0, 0.5), 0).unwrap();
    for (c, r) in ctl.iter_mut().zip(ring.iter()) {
        c.shape_to_tube(&t, &wide);
        assert_eq!(c.shape_fraction(), 1.0);
        assert_eq!(c.rest.own_m, r.own_m, "the ring, bit for bit");
        c.shape_to_tube(&t, &narrow);
        assert!(c.shape_fraction() < 0.6, "{}", c.shape_fraction());
    }
    for i in 0..n {
        for j in 0..n {
            assert_eq!(ctl[i].rest.own_m[j], ctl[j].rest.own_m[i], "spring {i}-{j}");
        }
        assert_eq!(ctl[i].rest.center_m, ctl[0].rest.center_m);
        assert_eq!(ctl[i].rest.own_center_m, ctl[0].rest.center_m[i]);
    }
    // Narrower, no longer: left-right rest lengths shrink, no node farther from the centre
    // than on the ring (no cable leans more than the capacity-aware formation chose).
    let (front, back, left, right) = (0, n / 2, n / 4, 3 * n / 4);
    assert!(ctl[front].rest.own_m[back] <= ring[front].own_m[back] + 1e-4);
    assert!(ctl[left].rest.own_m[right] < ring[left].own_m[right] - 1.0);
    for j in 0..n {
        assert!(ctl[0].rest.center_m[j] <= ring[0].center_m[j] + 1e-4, "node {j}");
    }
    // Back where the ring fits: the take-off rest lengths again, bit for bit.
    for (c, r) in ctl.iter_mut().zip(ring.iter()) {
        c.shape_to_tube(&t, &wide);
        assert_eq!(c.shape_fraction(), 1.0);
        assert_eq!((c.rest.own_m, c.rest.center_m, c.rest.own_load_m, c.rest.own_center_m), (r.own_m, r.center_m, r.own_load_m, r.own_center_m));
    }
    plain.shape_to_tube(&t, &narrow);
    assert_eq!(plain.rest.own_m, ring[0].own_m, "no shape without set_shape");
    assert_eq!(plain.shape_fraction(), 1.0);
}

/// A ground start's lift and climb turn the ring about the load (nothing in the springs holds
/// its rotation). Averaged while the team holds before the first look, the turn rotates the
/// stadium's frame back, so each node keeps the place its angle in the turned ring gives it;
/// every UAV that sees the same nodes derives the same frame, and without a hold before the
/// first look the frame is the tube's direction, bit for bit.
#[test]
fn a_ring_turned_before_the_first_look_keeps_its_places_on_the_stadium() {
    let n = 10;
    let t = tube();
    let (uavs, load) = takeoff(n, 4.0);
    let f = Formation::<N>::from_takeoff(&uavs, &load, &params().tray).unwrap();
    let turn = 12f32.to_radians();
    let (s, c) = turn.sin_cos();
    let turned: Vec<Vec3> = uavs
        .iter()
        .map(|u| {
            let d = u - load;
            Vec3::new(load.x + c * d.x - s * d.y, load.y + s * d.x + c * d.y, u.z)
        })
        .collect();
    let mut ctl = team(n, &uavs, &load);
    let mut calm = team(n, &uavs, &load);
    for x in ctl.iter_mut().chain(calm.iter_mut()) {
        x.set_shape(ShapeParams::default(), &f, None).unwrap();
    }
    let nb = neighbours(&turned);
    for _ in 0..(5.0 * DRIFT_AVERAGE_S / DT_S) as usize {
        for (i, x) in ctl.iter_mut().enumerate() {
            x.set_team_hold(true);
            let m = Measurements { own_pos_m: turned[i], own_vel_mps: Vec3::zeros(), load_pos_m: load, load_vel_mps: Vec3::zeros(), neighbours_m: &nb, neighbours_vel_mps: &[], own_cable_force_n: None };
            x.update(&t, &m, DT_S);
        }
    }
    let sec = t.locate(Vec2::new(4.0, 0.0), 0).unwrap();
    let angle = |v: Vec2| v.y.atan2(v.x);
    for x in ctl.iter_mut() {
        x.shape_to_tube(&t, &sec);
        let frame = x.shape.as_ref().unwrap().frame.unwrap();
        // Averaged over five of its times: within e^-5 of the turn.
        assert_relative_eq!(angle(sec.tangent) - angle(frame), turn, epsilon = 0.01 * turn);

    }
    for x in &ctl {
        assert_eq!(ctl_frame(x), ctl_frame(&ctl[0]), "every UAV the same frame");
    }
    for x in calm.iter_mut() {
        x.shape_to_tube(&t, &sec);
        assert_eq!(x.shape.as_ref().unwrap().frame, Some(sec.tangent), "no hold, no turn: the tangent bit for bit");
    }
    // In the turned frame the turned ring's nodes have their take-off angles in the tangent's.
    let sh = ctl[0].shape.as_ref().unwrap();
    let frame = sh.frame.unwrap();
    for (j, u) in turned.iter().enumerate() {
        let now = params().tray.project(u, &load).0 - load.xy();
        let then = sh.nodes_m[j] - sh.load_node_m;
        let a_now = angle(now) - angle(sec.tangent);
        let a_then = angle(then) - angle(frame);
        let d = (a_now - a_then + core::f32::consts::PI).rem_euclid(core::f32::consts::TAU) - core::f32::consts::PI;
        assert!(d.abs() < 0.01 * turn, "node {j}: {d}");
    }
}

fn ctl_frame(c: &DissipativeController<N>) -> Vec2 {
    c.shape.as_ref().unwrap().frame.unwrap()
}

/// The passage speed (shape.rs, `PASSAGE_SPEED_FRACTION`): while the separated stadium (bodies
/// declared) is narrower than the ring, every command and the tray centre's replica keep to that
/// fraction of `v_max`; the stadium without a separation floor keeps the whole limit, and back
/// on the ring the command is the unshaped controller's, bit for bit.
#[test]
fn a_separated_stadium_flies_its_passage_slower() {
    let n = 10;
    let t = tube();
    let (uavs, load) = takeoff(n, 4.0);
    let f = Formation::<N>::from_takeoff(&uavs, &load, &params().tray).unwrap();
    let narrow = t.locate(Vec2::new(27.0, 0.5), 0).unwrap();
    let wide = t.locate(Vec2::new(4.0, 0.0), 0).unwrap();
    let sep = ShapeSeparation { takeoff_m: &uavs, load_m: load, separation_m: 1.3, min_cos_sum: 0.0 };
    let nb = neighbours(&uavs);
    // The team off its rest places and the load moving: commands at the limit.
    let own = uavs[0] + Vec3::new(-1.5, 0.8, 0.0);
    let m = Measurements { own_pos_m: own, own_vel_mps: Vec3::zeros(), load_pos_m: load, load_vel_mps: Vec3::new(1.4, 0.0, 0.0), neighbours_m: &nb, neighbours_vel_mps: &[], own_cable_force_n: None };
    let v_max = params().v_max_mps;
    let slow = v_max * crate::shape::PASSAGE_SPEED_FRACTION;
    let mut plain = team(n, &uavs, &load).remove(0);
    let mut separated = team(n, &uavs, &load).remove(0);
    let mut shaped = team(n, &uavs, &load).remove(0);
    separated.set_shape(ShapeParams::default(), &f, Some(sep)).unwrap();
    shaped.set_shape(ShapeParams::default(), &f, None).unwrap();
    separated.shape_to_tube(&t, &narrow);
    shaped.shape_to_tube(&t, &narrow);
    assert!(separated.shape_fraction() < 1.0 && shaped.shape_fraction() < 1.0);
    let full = plain.update(&t, &m, DT_S).vel_mps.xy().norm();
    assert!(full > slow + 0.1, "the state asks for more than the passage speed: {full} m/s");
    for _ in 0..50 {
        let c = separated.update(&t, &m, DT_S);
        assert!(c.vel_mps.xy().norm() <= slow * (1.0 + 1e-6), "{} m/s in the passage, limit {slow}", c.vel_mps.xy().norm());
    }
    let before = separated.tray_center_m();
    separated.update(&t, &m, DT_S);
    assert!((separated.tray_center_m() - before).norm() <= slow * DT_S * (1.0 + 1e-5), "the tray centre keeps the passage speed too");
    assert!(shaped.update(&t, &m, DT_S).vel_mps.xy().norm() > slow + 0.1, "without bodies the stadium keeps v_max");
    // Back on the ring: the whole limit again, bit for bit the unshaped law.
    let mut fresh = team(n, &uavs, &load).remove(0);
    let mut back = team(n, &uavs, &load).remove(0);
    back.set_shape(ShapeParams::default(), &f, Some(sep)).unwrap();
    back.shape_to_tube(&t, &narrow);
    back.shape_to_tube(&t, &wide);
    assert_eq!(back.shape_fraction(), 1.0);
    assert_eq!(back.update(&t, &m, DT_S).vel_mps, fresh.update(&t, &m, DT_S).vel_mps);
}

/// A take-off that is not a ring (two rings here) is shaped as a packed team (shape.rs,
/// `Layout::Packed`): in a passage each inner node stays well inside the place the stadium's
/// perimeter would give it, and the springs still agree at both ends. A ring measured with a
/// few centimetres of error stays a ring (`RING_SPREAD`).
#[test]
fn a_packed_team_keeps_its_inner_nodes_inside_in_a_passage() {
    use crate::shape::{stadium_point, Layout};
    let t = tube();
    let h = params().tray.height_above_load_m;
    let load = Vec3::new(4.0, 0.0, LOAD_Z_M);
    // Each UAV on its 8 m cable through its node `d` on the tray (eq:2-4).
    let on_cable = |d: Vec2| load + Vec3::new(d.x, d.y, h) * (8.0 / (d.norm_squared() + h * h).sqrt());
    let node = |r: f32, a: f32| Vec2::new(r * a.cos(), r * a.sin());
    let tau = core::f32::consts::TAU;
    let nodes: Vec<Vec2> = (0..4).map(|k| node(1.2, tau * k as f32 / 4.0 + 0.4)).chain((0..8).map(|k| node(3.0, tau * k as f32 / 8.0))).collect();
    let uavs: Vec<Vec3> = nodes.iter().map(|d| on_cable(*d)).collect();
    let n = uavs.len();
    let f = Formation::<N>::from_takeoff(&uavs, &load, &params().tray).unwrap();
    let mut ctl = team(n, &uavs, &load);
    let narrow = t.locate(Vec2::new(27.0, 0.5), 0).unwrap();
    for c in ctl.iter_mut() {
        c.set_shape(ShapeParams::default(), &f, None).unwrap();
        c.shape_to_tube(&t, &narrow);
        assert!(c.shape_fraction() < 0.6, "a passage narrows the shape: {}", c.shape_fraction());
    }
    let shape = ctl[0].shape.as_ref().unwrap();
    let frame = shape.frame.unwrap();
    assert!(matches!(shape.layout(frame, n), Layout::Packed { .. }));
    let (r, b) = (shape.radius_m, shape.radius_m * shape.quantum as f32 / QUANTA as f32);
    for (k, p) in shape.nodes_m.iter().take(4).enumerate() {
        let o = p - shape.centre_m;
        let angle = vt_fpu::atan2(o.dot(&Vec2::new(-frame.y, frame.x)), o.dot(&frame));
        let on_perimeter = stadium_point(angle, shape.half_length_m, b).norm();
        let placed = ctl[k].rest.own_center_m;
        assert!(placed < 0.6 * on_perimeter, "inner node {k}: {placed} m from the centre, {on_perimeter} m on the stadium");
        assert!(placed <= (p - shape.centre_m).norm() * shape.half_length_m / r + 1e-4, "never farther than stretched: {placed}");
    }
    for i in 0..n {
        for j in 0..n {
            assert_eq!(ctl[i].rest.own_m[j], ctl[j].rest.own_m[i], "spring {i}-{j}");
        }
    }
    // The paper's ring, each node off its radius by up to 2 %: a ring.
    let ring: Vec<Vec3> = (0..10).map(|k| on_cable(node(3.0 * (1.0 + 0.02 * ((k as f32) * 2.1).sin()), tau * k as f32 / 10.0))).collect();
    let fr = Formation::<N>::from_takeoff(&ring, &load, &params().tray).unwrap();
    let mut c = team(10, &ring, &load).remove(0);
    c.set_shape(ShapeParams::default(), &fr, None).unwrap();
    c.shape_to_tube(&t, &narrow);
    let s = c.shape.as_ref().unwrap();
    assert!(matches!(s.layout(s.frame.unwrap(), 10), Layout::Ring));
}
