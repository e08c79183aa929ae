//! The landing after the release (issue 29: a team that refused, set its load down or delivered
//! it lands in place instead of hovering in a wind it may not hold), and the take-off's station
//! watch that sends a ground start there at once (docs/design.md, "Landing").

use crate::dwell::Dwell;
use crate::separation::SEPARATION_AUTHORITY;
use crate::Vec2;
use vt_tube::sat;

/// Before its arming a ground-start UAV abandons the start when it has drifted this far from
/// the place it holds, m (issue 29: a wind beyond what a UAV can hold on its own blows it away
/// during the hover whose observer was to measure that wind; at the nominal disturbances the
/// hover drifts 0.30-0.36 m, at twice them up to 0.62 m: docs/design.md, "Landing").
pub const STATION_DRIFT_ABORT_M: f32 = 1.0;

/// Descent speed of the landing after the release, m/s (PX4 `MPC_LAND_SPEED`'s default).
pub const LAND_SPEED_MPS: f32 = 0.7;

/// A landing UAV counts as down below this altitude, m (the local frame's origin is on the
/// ground, as PX4's and ArduPilot's are at arming) ...
pub const LANDED_Z_M: f32 = 0.15;

/// ... held this long, s: an up-down timer, so that position noise neither lands a UAV in the
/// air nor keeps a landed one spinning (PX4's land detector also waits, `LNDMC_TRIG_TIME`).
pub const LANDED_HOLD_S: f32 = 0.5;

/// Holding a horizontal place: `(hold - own) gain_per_s`, its speed capped at `v_max_mps`
/// (m/s, ENU). What a ground start flies before its arming and the landing after the release;
/// non-finite input gives non-finite output (each caller maps it to its safe command).
#[inline]
pub fn hold_velocity_xy_mps(own_xy_m: [f32; 2], hold_xy_m: [f32; 2], gain_per_s: f32, v_max_mps: f32) -> [f32; 2] {
    let (vx, vy) = ((hold_xy_m[0] - own_xy_m[0]) * gain_per_s, (hold_xy_m[1] - own_xy_m[1]) * gain_per_s);
    let speed = vt_fpu::sqrt(vx * vx + vy * vy);
    if speed > v_max_mps && speed > 0.0 {
        let k = v_max_mps / speed;
        return [vx * k, vy * k];
    }
    [vx, vy]
}

/// The landing after the release: the own horizontal place held ([`hold_velocity_xy_mps`]), a
/// descent at [`LAND_SPEED_MPS`], m/s (ENU). Non-finite input gives a descent without
/// horizontal correction.
pub fn landing_velocity_mps(own_xy_m: [f32; 2], hold_xy_m: [f32; 2], gain_per_s: f32, v_max_mps: f32) -> [f32; 3] {
    let [vx, vy] = hold_velocity_xy_mps(own_xy_m, hold_xy_m, gain_per_s, v_max_mps);
    if !(vx.is_finite() && vy.is_finite()) {
        return [0.0, 0.0, -LAND_SPEED_MPS];
    }
    [vx, vy, -LAND_SPEED_MPS]
}

/// Tangent of the largest tilt of a UAV landing on its own after the release (60 deg), once
/// carried [`FREE_TILT_DRIFT_M`] off its landing place: free of its load it has no cable to
/// swing and its rotors to spare (50 N for a 2 kg airframe: 39 N at 60 deg holding its weight),
/// and at the transport's 45 deg (`MPC_TILTMAX_AIR`) a UAV released in a 9 m/s wind with severe
/// turbulence was carried 4.5 m/s downwind with its demand cut at the cone (docs/design.md,
/// "The landing after the release tilts to 60 deg").
pub const FREE_TILT_MAX_TAN: f32 = 1.732_050_8;

/// Height above the ground under which the landing keeps the configured tilt cone, m: the
/// touchdown is not flown leaning further than the transport.
pub const FREE_TILT_MIN_HEIGHT_M: f32 = 1.0;

/// Drift off the landing place at which the cone reaches [`FREE_TILT_MAX_TAN`], m; it widens
/// from the configured one at half of it. Held near its place, the free UAV keeps the
/// configured cone: there the cone's saturation bounds its velocity loop's swings behind PX4's
/// stock gains in moderate turbulence (at 60 deg throughout, a landing team's pairs came within
/// 0.17 m, and 55 of 100 runs at 2x brought bodies into contact against 23). 2 m left a UAV
/// 0.37 m out of the tube at 3x; 1.5 m keeps the 2x landings' pairs as they were.
pub const FREE_TILT_DRIFT_M: f32 = 1.5;

/// The tilt cone's tangent of the landing after the release at `height_m` above the ground and
/// `drift_m` off its landing place: `configured_tan` up to `FREE_TILT_DRIFT_M / 2`, widening
/// linearly to [`FREE_TILT_MAX_TAN`] at [`FREE_TILT_DRIFT_M`], from [`FREE_TILT_MIN_HEIGHT_M`]
/// up only; never narrower than `configured_tan`, and `configured_tan` for a non-finite input.
#[must_use]
pub fn landing_tilt_max_tan(height_m: f32, drift_m: f32, configured_tan: f32) -> f32 {
    let half = 0.5 * FREE_TILT_DRIFT_M;
    if !(height_m >= FREE_TILT_MIN_HEIGHT_M && drift_m > half && FREE_TILT_MAX_TAN > configured_tan) {
        return configured_tan;
    }
    let k = vt_fpu::min((drift_m - half) / half, 1.0);
    configured_tan + (FREE_TILT_MAX_TAN - configured_tan) * k
}

/// Horizontal spacing the landing makes between UAVs before they reach the ground, m: two
/// 0.445 m airframes (the paper's, docs/plant.md) with 0.3 m between them. In flight a
/// formation may stack UAVs with unequal cables above one another (the 25-UAV team flew pairs
/// 0.9 m apart in 3-D but 0.3 m apart horizontally); landing in place would put them on one spot.
pub const LAND_SPACING_M: f32 = 1.2;

/// Speed at which the landing place moves away from a neighbour per metre it lacks, 1/s.
pub const LAND_SPREAD_GAIN_PER_S: f32 = 1.0;

/// The landing's spread (m/s, horizontal ENU): away from every neighbour closer than
/// [`LAND_SPACING_M`] horizontally, [`LAND_SPREAD_GAIN_PER_S`] per metre missing
/// ([`pairwise_pushes_mps`]).
pub fn landing_spread_mps(own_xy_m: [f32; 2], neighbours_xy_m: impl IntoIterator<Item = [f32; 2]>) -> [f32; 2] {
    let [v] = pairwise_pushes_mps(own_xy_m, neighbours_xy_m, [LAND_SPACING_M], [LAND_SPREAD_GAIN_PER_S]);
    v
}

/// For each `k`: away from every neighbour closer than `range_m[k]` horizontally,
/// `gain_per_s[k]` per metre missing, summed (m/s, horizontal ENU; pairwise antisymmetric, so a
/// pair parts symmetrically). A neighbour on the same spot (within 0.1 mm) or not finite gives
/// no push (no direction to take). Several ranges in one pass over the neighbours: the
/// landing's spread and its guard's push (flash, on the MCU).
pub fn pairwise_pushes_mps<const K: usize>(own_xy_m: [f32; 2], neighbours_xy_m: impl IntoIterator<Item = [f32; 2]>, range_m: [f32; K], gain_per_s: [f32; K]) -> [[f32; 2]; K] {
    let mut v = [[0.0f32; 2]; K];
    for [x, y] in neighbours_xy_m {
        let (dx, dy) = (own_xy_m[0] - x, own_xy_m[1] - y);
        let d = vt_fpu::sqrt(dx * dx + dy * dy);
        for ((v, &r), &g) in v.iter_mut().zip(&range_m).zip(&gain_per_s) {
            if d.is_finite() && d > 1e-4 && d < r {
                let k = g * (r - d) / d;
                v[0] += k * dx;
                v[1] += k * dy;
            }
        }
    }
    v
}

/// The land detector: an up-down timer ([`Dwell`]) on the own altitude (`LANDED_Z_M`,
/// `LANDED_HOLD_S`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LandDetector {
    below: Dwell,
    landed: bool,
}

impl LandDetector {
    /// One look at the own altitude `z_m` after `dt_s`; true once landed (it stays landed).
    pub fn step(&mut self, z_m: f32, dt_s: f32) -> bool {
        // `!(z >= LANDED_Z_M)` would land on a NaN altitude: only a measured low altitude counts.
        self.landed |= self.below.step(z_m < LANDED_Z_M, dt_s) >= LANDED_HOLD_S;
        self.landed
    }

    /// True once landed.
    pub fn landed(&self) -> bool {
        self.landed
    }
}

/// The landing place kept `keep_m` inside the tube: within `half_width_m - keep_m` of the
/// section's midpoint (the tube's cross-section disc, eq:1-7; `keep_m` the barrier's safety
/// radius, which a body raises), moved straight towards the midpoint when beyond; `place_m`
/// unchanged otherwise and for non-finite input. The spread above has no sense of the tube: a
/// team set down in a passage would otherwise land some of its UAVs outside it (measured,
/// docs/design.md "Landing").
pub fn place_inside_tube(place_m: [f32; 2], midpoint_m: [f32; 2], half_width_m: f32, keep_m: f32) -> [f32; 2] {
    let (dx, dy) = (place_m[0] - midpoint_m[0], place_m[1] - midpoint_m[1]);
    let dist = vt_fpu::sqrt(dx * dx + dy * dy);
    let room = vt_fpu::max(half_width_m - keep_m, 0.0);
    if !(dist > room && dist.is_finite() && room.is_finite()) {
        return place_m;
    }
    let k = room / dist;
    [midpoint_m[0] + dx * k, midpoint_m[1] + dy * k]
}

/// How far beyond the separation floor (`2 r_u + c`) the landing's guard starts parting two
/// UAVs, m, and ...
pub const LAND_SEPARATION_BAND_M: f32 = 0.7;

/// ... how fast per metre inside that range, 1/s ([`pairwise_pushes_mps`]: at the floor itself
/// 1.4 m/s, about the transport's speed limit). Linear, not the transport's barrier: a
/// barrier's pole 0.3 m beyond the formation's spacing made the landing's commands chatter
/// between +-`v_max` (docs/design.md, "The landing keeps the tube and its neighbours").
pub const LAND_SEPARATION_GAIN_PER_S: f32 = 2.0;

/// The widest band beyond `r_safe` in which the ground start's hover keeps the tube, m
/// (docs/design.md, "The hover keeps the tube"): the barrier of eq:2-14/15 with its pole at
/// `r_safe` and its activation radius `r_safe` + [`hover_keeping_band_m`], at most this. The
/// transport's `r_active` (1.5 m on the paper's tube) carried UAVs near a wall up to a metre off
/// the places the take-off gave them, and the station watch then refused the start.
pub const HOVER_KEEPING_BAND_M: f32 = 0.3;

/// The hover's keeping band for a UAV at `own_xy_m`, m: [`HOVER_KEEPING_BAND_M`], narrowed to
/// half the room its closest neighbour (horizontally; non-finite ones ignored) has above the
/// separation floor `separation_m`, and 0 at or below it. The barrier's stiffness holds a UAV
/// within its band of where the wall's pole pushes it from, so two UAVs that move towards each
/// other by their bands close by at most the room the pair had: the keeping alone never brings
/// a pair under the floor (two UAVs at the poles of a narrow tube settle at half the room each).
#[must_use]
pub fn hover_keeping_band_m(own_xy_m: [f32; 2], neighbours_xy_m: impl IntoIterator<Item = [f32; 2]>, separation_m: f32) -> f32 {
    let mut nearest_sq = f32::INFINITY;
    for [x, y] in neighbours_xy_m {
        let (dx, dy) = (own_xy_m[0] - x, own_xy_m[1] - y);
        let d_sq = dx * dx + dy * dy;
        // `d_sq < nearest_sq` is false for a NaN: a non-finite neighbour is ignored.
        if d_sq < nearest_sq {
            nearest_sq = d_sq;
        }
    }
    let room = 0.5 * (vt_fpu::sqrt(nearest_sq) - separation_m);
    // NaN (a NaN floor) gives no band: `!(room > 0)`.
    if room > 0.0 { vt_fpu::min(room, HOVER_KEEPING_BAND_M) } else { 0.0 }
}

/// The landing's guard (extension; docs/design.md, "The landing keeps the tube and its
/// neighbours"): the held place's velocity `hold_mps` plus the push from neighbours
/// (`separation_mps`, [`pairwise_pushes_mps`] within [`LAND_SEPARATION_BAND_M`] of the
/// separation floor) limited to `v_max_mps`, saturated at `v_max_mps`; then the paper's tube
/// keeping at the UAV's own position (`keeping_mps`, eq:2-14/eq:2-15) added with up to
/// [`SEPARATION_AUTHORITY`] times `v_max_mps` and saturated again. The tube has the last word,
/// as the separation barrier has it in transport: a landing UAV the wind carries towards a
/// neighbour or the boundary is turned back, not held by its place's 1/s alone; pushed from a
/// neighbour towards the boundary, it keeps the tube (m/s, horizontal ENU). Non-finite terms
/// are dropped: `hold_mps` alone (saturated) then.
#[must_use]
pub fn guarded_landing_velocity(hold_mps: Vec2, keeping_mps: Vec2, separation_mps: Vec2, v_max_mps: f32) -> Vec2 {
    if !(vt_fpu::all_finite(&keeping_mps) && vt_fpu::all_finite(&separation_mps)) {
        return sat(hold_mps, v_max_mps);
    }
    let v = sat(hold_mps + sat(separation_mps, v_max_mps), v_max_mps);
    sat(v + sat(keeping_mps, SEPARATION_AUTHORITY * v_max_mps), v_max_mps)
}

#[cfg(test)]
mod tests {

    /// The landing's guard: nothing added away from the boundary and the neighbours; a
    /// neighbour's push turns the hold; the tube has the last word; the command stays within
    /// `v_max`; non-finite terms are dropped.
    #[test]
    fn the_landing_guard_turns_from_neighbours_and_keeps_the_tube() {
        use super::{guarded_landing_velocity, landing_spread_mps, pairwise_pushes_mps};
        use crate::Vec2;
        let v_max = 1.5;
        let z = Vec2::zeros();
        let hold = Vec2::new(0.6, -0.2);
        assert_eq!(guarded_landing_velocity(hold, z, z, v_max), hold, "nothing near");
        assert_eq!(guarded_landing_velocity(Vec2::new(3.0, 0.0), z, z, v_max), Vec2::new(v_max, 0.0), "the hold saturated");
        // A neighbour at +y pushes towards -y, harder than the hold's upwind correction.
        let v = guarded_landing_velocity(Vec2::new(-v_max, 0.0), z, Vec2::new(0.0, -50.0), v_max);
        assert!(v.y < -0.5 * v_max && v.x < 0.0, "turned away, still upwind: {v:?}");
        // Pushed by a neighbour towards the boundary (+y) while deep in the tube barrier (-y).
        let v = guarded_landing_velocity(z, Vec2::new(0.0, -1.0e4), Vec2::new(0.0, 1.0e3), v_max);
        assert!(v.y < 0.0, "the tube keeps it: {v:?}");
        for k in [Vec2::new(0.3, -7.0), Vec2::new(-40.0, 2.0), z] {
            for sep in [Vec2::new(9.0, 9.0), Vec2::new(-0.1, 0.4), z] {
                let v = guarded_landing_velocity(Vec2::new(1.1, 1.4), k, sep, v_max);
                assert!(v.norm() <= v_max * (1.0 + 1e-6), "{k:?} {sep:?}: {v:?}");
            }
        }
        for bad in [Vec2::new(f32::NAN, 0.0), Vec2::new(0.0, f32::INFINITY)] {
            assert_eq!(guarded_landing_velocity(hold, bad, z, v_max), hold);
            assert_eq!(guarded_landing_velocity(hold, z, bad, v_max), hold);
        }
        // The pairwise push: symmetric, zero beyond its range, linear inside it.
        let (a, b) = ([0.0, 0.0], [1.0, 0.0]);
        let ([pa, sa], [pb, _]) = (pairwise_pushes_mps(a, [b], [1.5, 1.2], [2.0, 1.0]), pairwise_pushes_mps(b, [a], [1.5, 1.2], [2.0, 1.0]));
        assert!((pa[0] + 1.0).abs() < 1e-6 && pa[1] == 0.0 && pa[0] == -pb[0], "{pa:?} {pb:?}");
        assert_eq!(sa, landing_spread_mps(a, [b]), "the spread is the second range");
        assert_eq!(pairwise_pushes_mps(a, [[1.5, 0.0], [f32::NAN, 0.0], [0.0, 0.0]], [1.5], [2.0]), [[0.0, 0.0]]);
    }

    /// The landing keeps the configured cone near its place, below 1 m (the touchdown) and for
    /// a non-finite input; carried off its place it widens from 0.75 m of drift to 60 deg at
    /// 1.5 m, and it never narrows a wider configured cone.
    #[test]
    fn the_landing_leans_further_only_when_carried_off_above_the_touchdown() {
        use super::{landing_tilt_max_tan, FREE_TILT_DRIFT_M, FREE_TILT_MAX_TAN, FREE_TILT_MIN_HEIGHT_M};
        assert!((FREE_TILT_MAX_TAN - 3f32.sqrt()).abs() < 1e-6);
        let tan45 = 1.0;
        let d = FREE_TILT_DRIFT_M;
        assert_eq!(landing_tilt_max_tan(5.9, 0.25 * d, tan45), tan45, "held near its place");
        assert_eq!(landing_tilt_max_tan(5.9, 0.5 * d, tan45), tan45);
        let mid = landing_tilt_max_tan(5.9, 0.75 * d, tan45);
        assert!((mid - 0.5 * (1.0 + FREE_TILT_MAX_TAN)).abs() < 1e-6, "{mid}");
        assert_eq!(landing_tilt_max_tan(5.9, FREE_TILT_DRIFT_M, tan45), FREE_TILT_MAX_TAN);
        assert_eq!(landing_tilt_max_tan(FREE_TILT_MIN_HEIGHT_M, 9.0, tan45), FREE_TILT_MAX_TAN);
        assert_eq!(landing_tilt_max_tan(0.99, 9.0, tan45), tan45, "the touchdown");
        for (h, d) in [(f32::NAN, 9.0), (5.9, f32::NAN), (f32::INFINITY, f32::INFINITY)] {
            let t = landing_tilt_max_tan(h, d, tan45);
            assert!(t == tan45 || t == FREE_TILT_MAX_TAN, "{h} {d}: {t}");
            assert!(t.is_finite());
        }
        assert_eq!(landing_tilt_max_tan(5.9, 9.0, 3.0), 3.0, "a wider configured cone stays");
    }

    #[test]
    fn the_landing_place_stays_inside_the_tube() {
        let m = [10.0, 2.0];
        assert_eq!(place_inside_tube([10.5, 2.5], m, 2.0, 0.5), [10.5, 2.5], "inside: unchanged");
        let p = place_inside_tube([10.0, 4.4], m, 2.0, 0.5);
        assert!((p[0] - 10.0).abs() < 1e-6 && (p[1] - 3.5).abs() < 1e-6, "{p:?}");
        let q = place_inside_tube([13.0, 6.0], m, 2.0, 0.5);
        assert!(((q[0] - 10.0).hypot(q[1] - 2.0) - 1.5).abs() < 1e-5, "onto the kept circle: {q:?}");
        assert_eq!(place_inside_tube([10.0, 9.0], m, 0.3, 0.5), m, "a section narrower than the keep: its midpoint");
        assert_eq!(place_inside_tube([f32::NAN, 1.0], m, 2.0, 0.5)[1], 1.0, "non-finite: unchanged");
        assert_eq!(place_inside_tube([10.0, 4.4], m, f32::NAN, 0.5), [10.0, 4.4]);
    }
    use super::*;

    #[test]
    fn the_detector_lands_on_the_ground_and_not_in_noise_above_it() {
        // On the ground with 15 cm position noise (three times the nominal): most samples below.
        let mut down = LandDetector::default();
        let on_ground = [0.05f32, -0.1, 0.2, 0.0, 0.12, -0.05, 0.3, 0.1];
        let mut k = 0;
        while !down.step(on_ground[k % on_ground.len()], 0.02) {
            k += 1;
            assert!(k < 200, "a UAV on the ground must count as landed");
        }
        assert!(k as f32 * 0.02 >= LANDED_HOLD_S - 0.02, "not before the hold time: {k}");
        // At 0.5 m with the same noise one sample in eight dips below: never landed.
        let mut air = LandDetector::default();
        let above = [0.5f32, 0.6, 0.1, 0.45, 0.55, 0.4, 0.65, 0.5];
        for k in 0..5000 {
            assert!(!air.step(above[k % above.len()], 0.02), "landed in the air at step {k}");
        }
        // NaN never counts as low; once landed it stays landed.
        let mut nan = LandDetector::default();
        assert!(!(0..100).any(|_| nan.step(f32::NAN, 0.02)));
        assert!(down.step(5.0, 0.02) && down.landed());
    }

    #[test]
    fn the_spread_parts_close_neighbours_symmetrically_and_leaves_spaced_ones() {
        let a = [0.0f32, 0.0];
        let b = [0.3f32, 0.0];
        let va = landing_spread_mps(a, [b]);
        let vb = landing_spread_mps(b, [a]);
        assert!((va[0] + 0.9).abs() < 1e-6 && va[1] == 0.0, "{va:?}");
        assert_eq!([va[0] + vb[0], va[1] + vb[1]], [0.0, 0.0], "antisymmetric");
        assert_eq!(landing_spread_mps(a, [[LAND_SPACING_M, 0.0], [0.0, -1.5]]), [0.0, 0.0]);
        assert_eq!(landing_spread_mps(a, [[0.0, 0.0], [f32::NAN, 0.0]]), [0.0, 0.0]);
    }

    #[test]
    fn the_landing_descends_and_holds_its_place_within_the_speed_limit() {
        let v = landing_velocity_mps([0.0, 0.0], [0.3, -0.4], 1.0, 1.5);
        assert_eq!(v, [0.3, -0.4, -LAND_SPEED_MPS]);
        let far = landing_velocity_mps([0.0, 0.0], [30.0, 40.0], 1.0, 1.5);
        assert!(((far[0] * far[0] + far[1] * far[1]).sqrt() - 1.5).abs() < 1e-5 && far[2] == -LAND_SPEED_MPS);
        assert_eq!(landing_velocity_mps([f32::NAN, 0.0], [0.0, 0.0], 1.0, 1.5), [0.0, 0.0, -LAND_SPEED_MPS]);
    }

    #[test]
    fn the_hover_s_keeping_band_leaves_each_uav_half_the_pair_s_room() {
        use super::{hover_keeping_band_m, HOVER_KEEPING_BAND_M};
        let own = [0.0f32, 0.0];
        assert_eq!(hover_keeping_band_m(own, [], 1.09), HOVER_KEEPING_BAND_M, "alone: the widest band");
        assert_eq!(hover_keeping_band_m(own, [[3.0, 0.0]], 1.09), HOVER_KEEPING_BAND_M, "room to spare");
        assert!((hover_keeping_band_m(own, [[0.0, 1.29], [3.0, 0.0]], 1.09) - 0.1).abs() < 1e-6, "half the closest pair's room");
        assert_eq!(hover_keeping_band_m(own, [[1.0, 0.0]], 1.09), 0.0, "at or under the floor: no band");
        assert_eq!(hover_keeping_band_m(own, [[f32::NAN, 0.0], [3.0, 0.0]], 1.09), HOVER_KEEPING_BAND_M, "a NaN neighbour ignored");
        assert_eq!(hover_keeping_band_m(own, [[3.0, 0.0]], f32::NAN), 0.0, "no floor, no band");
    }

    /// The hover's guard flown kinematically (50 Hz, the commands integrated as velocities) in a
    /// straight tube: a UAV carried towards the wall at 0.2 m/s (the hover's wander, docs/design.md
    /// "The hover keeps the tube") stops short of the pole, where its hold alone crosses it; and
    /// two UAVs taking off at the poles across a narrow tube (1.5 m apart, floor 1.09 m) move
    /// inwards without closing under the floor, where a fixed 0.3 m band brought them to 0.9 m.
    #[test]
    fn the_hover_keeps_the_tube_without_pressing_a_pair_under_the_floor() {
        use super::{guarded_landing_velocity, hold_velocity_xy_mps, hover_keeping_band_m};
        use crate::keeping::keeping_velocity;
        use vt_tube::{BarrierParams, Tube, Waypoint};
        let tube = Tube::<256>::from_waypoints(&[Waypoint::new(0.0, 0.0, 1.5, 1.5), Waypoint::new(20.0, 0.0, 1.5, 1.5)]).unwrap();
        let (r_safe, separation, v_max, dt) = (0.75f32, 1.09f32, 3.0f32, 0.02f32);
        let command = |p: Vec2, place: Vec2, others: &[Vec2], band_on: bool| {
            let [hx, hy] = hold_velocity_xy_mps([p.x, p.y], [place.x, place.y], 1.0, v_max);
            let band = if band_on { hover_keeping_band_m([p.x, p.y], others.iter().map(|o| [o.x, o.y]), separation) } else { 0.0 };
            let keeping = if band > 0.0 {
                let sec = tube.locate(p, 0).unwrap();
                keeping_velocity(&sec, &p, &BarrierParams::tube(1.0, r_safe, r_safe + band)).0
            } else {
                Vec2::zeros()
            };
            guarded_landing_velocity(Vec2::new(hx, hy), keeping, Vec2::zeros(), v_max)
        };
        // One UAV 0.1 m beyond the pole, carried towards the wall.
        for guarded in [false, true] {
            let place = Vec2::new(10.0, 1.5 - r_safe - 0.1);
            let mut p = place;
            let mut closest = f32::INFINITY;
            for _ in 0..1000 {
                p += (command(p, place, &[], guarded) + Vec2::new(0.0, 0.2)) * dt;
                closest = closest.min(1.5 - p.y);
            }
            if guarded {
                assert!(closest > r_safe, "kept beyond the pole: {closest} m from the wall");
            } else {
                assert!(closest < r_safe - 0.05, "the hold alone crosses the pole: {closest} m");
            }
        }
        // Two UAVs at the poles across the tube.
        let places = [Vec2::new(10.0, 1.5 - r_safe), Vec2::new(10.0, r_safe - 1.5)];
        let mut p = places;
        let mut closest_pair = f32::INFINITY;
        for _ in 0..1000 {
            let v = [command(p[0], places[0], &[p[1]], true), command(p[1], places[1], &[p[0]], true)];
            p[0] += v[0] * dt;
            p[1] += v[1] * dt;
            closest_pair = closest_pair.min((p[0] - p[1]).norm());
            assert!(p.iter().all(|q| q.y.abs() <= 1.5 - r_safe + 1e-4), "both moved inwards: {p:?}");
        }
        assert!(closest_pair >= separation, "the pair kept its floor: {closest_pair} m");
        assert!(closest_pair < 1.5 - 0.1, "and both moved off the poles: {closest_pair} m");
    }
}
