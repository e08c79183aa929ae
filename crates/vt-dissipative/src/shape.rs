//! A formation shaped to the tube ahead (extension to the paper, issues 27 and 29;
//! docs/design.md, "A formation shaped to the tube").
//!
//! The paper's springs hold the take-off ring (eq:2-7). In a passage narrower than the ring the
//! tube keeping (eq:2-14) squeezes it sideways only: the UAVs at the ring's front and back, whose
//! neighbours lie beside them, are pushed together, and the springs push the ring back out
//! against the boundary. Here the rest lengths are instead those of a *stadium* (two half
//! circles joined by straight sides) whose half-width `b` fits the narrowest section ahead and
//! whose half-length is the ring's radius `r`: each node keeps its place along the perimeter (its
//! take-off angle from the tube's direction, as a fraction of the perimeter), so the pairs that
//! the squeezed ring puts side by side at its front and back lie along the sides instead. No node
//! lies farther from the centre than on the ring, so no cable leans more than the capacity-aware
//! formation chose for it (a longer stadium, of the ring's perimeter, sank heavy loads: measured,
//! docs/design.md). With room for the ring the shape *is* the ring. A take-off that is not a
//! ring (two rings, a packed patch: [`Layout::Packed`]) is squeezed across the tube to the same
//! half-width and stretched along it instead, so its inner nodes stay inside ([`packed_point`]).
//! The stretch keeps [`PACKED_LIFT_RESERVE`] of lift.
//!
//! The rest lengths change only at discrete steps of `b` ([`QUANTA`]), each a bounded jump of the
//! spring energy (eq:2-8) as the capacity-aware formation's scale steps are; between steps
//! Prop. 1 holds unchanged. Every UAV derives the same shape from shared data (the tube, the
//! load's section, the take-off formation), so each spring's rest length is the same at both ends.

use crate::{ControlError, Vec2, Vec3};
use core::f32::consts::{FRAC_PI_2, PI, TAU};
use vt_tube::{Tube, TubeSample};

/// Steps of the stadium's half-width between the narrowest shape and the ring: `b = r q / QUANTA`.
pub const QUANTA: i32 = 32;

/// The narrowest stadium for any team, quanta of the ring's radius (below it the formation
/// would be nearly a line, every node on the two straight sides).
pub const MIN_QUANTUM: i32 = 10;

/// Settings of the tube-shaped formation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShapeParams {
    /// Room kept between the formation's nodes and the tube barrier's safety radius, m.
    pub margin_m: f32,
    /// How far past the formation's front the tube's width is looked at, m.
    pub ahead_m: f32,
}

impl Default for ShapeParams {
    /// 0.5 m of margin, 6 m ahead (measured on the paper mission with bodies; docs/design.md).
    fn default() -> Self {
        Self { margin_m: 0.5, ahead_m: 6.0 }
    }
}

impl ShapeParams {
    /// Checks that both settings are finite and non-negative.
    ///
    /// # Errors
    /// [`ControlError::InvalidParameter`] naming the field.
    pub fn validate(&self) -> Result<(), ControlError> {
        if !(self.margin_m.is_finite() && self.margin_m >= 0.0) {
            return Err(ControlError::InvalidParameter("shape.margin_m"));
        }
        if !(self.ahead_m.is_finite() && self.ahead_m >= 0.0) {
            return Err(ControlError::InvalidParameter("shape.ahead_m"));
        }
        Ok(())
    }
}

/// The point at angle `theta_rad` (from `+x`, counter-clockwise) of the stadium of half-width
/// `b_m` and half-length `r_m` (long axis along `+x`, centred on the origin), m: the point at the
/// fraction `theta / 2 pi` of its perimeter `2 pi b + 4 (r - b)`, walked from the front `(r, 0)`.
/// With `b >= r` it is the circle's `r (cos theta, sin theta)`. Non-finite or non-positive sizes
/// give the origin. Out of line: the rest lengths and the separation check call it (flash).
#[inline(never)]
pub fn stadium_point(theta_rad: f32, r_m: f32, b_m: f32) -> Vec2 {
    if !(r_m.is_finite() && r_m > 0.0 && b_m.is_finite() && b_m > 0.0 && theta_rad.is_finite()) {
        return Vec2::zeros();
    }
    let b = vt_fpu::min(b_m, r_m);
    // Half the straight side, and the perimeter's length per radian of `theta`.
    let c = r_m - b;
    let per_rad = b + c * (2.0 / PI);
    // Whole turns off (the angles given are within a turn or two), into [0, 2 pi).
    let turns = theta_rad * (1.0 / TAU);
    let whole = if turns >= 0.0 { turns as i32 } else { turns as i32 - 1 };
    let th = vt_fpu::max(theta_rad - whole as f32 * TAU, 0.0);
    let cap = FRAC_PI_2 * b;
    let side = 2.0 * c;
    let mut u = th * per_rad;
    let on_cap = |centre_x: f32, from_rad: f32, u: f32| on_circle(centre_x, b, from_rad + u / b);
    if u <= cap {
        return on_cap(c, 0.0, u);
    }
    u -= cap;
    if u <= side {
        return Vec2::new(c - u, b);
    }
    u -= side;
    if u <= 2.0 * cap {
        return on_cap(-c, FRAC_PI_2, u);
    }
    u -= 2.0 * cap;
    if u <= side {
        return Vec2::new(u - c, -b);
    }
    u -= side;
    on_cap(c, -FRAC_PI_2, u)
}

/// A take-off whose nodes all lie at least this fraction of the outermost node's distance from
/// the tray centre is a ring (the paper's take-off, measured with its errors): its nodes go on
/// the stadium's perimeter. Any other layout (two rings, a packed patch) is [`Layout::Packed`]:
/// squeezed across the tube and stretched along it, its inner nodes kept inside
/// (docs/design.md, "The shaped formation of a packed team").
pub const RING_SPREAD: f32 = 0.9;

/// The lift a packed layout's stretch keeps beyond the load's own need, a fraction of it: the
/// length search stops before `sum cos theta` falls under `(1 + this) W / f` (a ring's keeps
/// none, as before). The stretch leans every node's cable along the tube, inner ones too, and on
/// the 20 N clamp a patch stretched to the load's bare need sank in the passages (19.6 kg:
/// 0 of 20 seeds flown, 17 of 20 with this reserve; 2 % let its pairs close, 0 of 5;
/// docs/design.md, "The shaped formation of a packed team").
pub const PACKED_LIFT_RESERVE: f32 = 0.005;

/// How the take-off nodes are placed on the shape of half-width `b` and half-length `a` (both m,
/// node space, about the tray centre, in the stadium's frame).
#[derive(Debug, Clone, Copy)]
pub enum Layout<'a> {
    /// Every node on the stadium's perimeter at its take-off angle ([`stadium_point`]).
    Ring,
    /// Every node at its take-off offset, along the tube times `a / r`, across it times
    /// `min(1, b / across)` ([`packed_point`]).
    Packed {
        /// The take-off nodes, world, m.
        nodes_m: &'a [Vec2],
        /// The tray centre at take-off, world, m.
        centre_m: Vec2,
        /// The stadium's frame: the tube's direction at the first look (unit).
        frame: Vec2,
        /// The layout's outer radius `r`, m.
        radius_m: f32,
        /// The layout's largest offset across the frame, m.
        across_m: f32,
    },
}

impl Layout<'_> {
    /// Whether the shape of half-width `b_m` is narrower than the layout of outer radius `r_m`
    /// (both m): the ring's radius, or the packed layout's own extent across the tube.
    pub fn narrower(&self, r_m: f32, b_m: f32) -> bool {
        match *self {
            Self::Ring => b_m < r_m,
            Self::Packed { across_m, .. } => b_m < across_m,
        }
    }

    /// Take-off node `p` (world, m) on the shape of half-length `a_m` and half-width `b_m`:
    /// about the tray centre in the stadium's frame, m. `angle_rad` is the node's take-off angle
    /// in that frame (the ring's place on the perimeter). Out of line (flash).
    #[inline(never)]
    pub fn place(&self, p: &Vec2, angle_rad: f32, a_m: f32, b_m: f32) -> Vec2 {
        match *self {
            Self::Ring => stadium_point(angle_rad, a_m, b_m),
            Self::Packed { centre_m, frame, radius_m, across_m, .. } => {
                let o = p - centre_m;
                packed_point(Vec2::new(o.dot(&frame), o.x * frame.y - o.y * frame.x), radius_m, across_m, a_m, b_m)
            }
        }
    }
}

/// A packed layout's node `o` (about the tray centre in the stadium's frame, m) on the shape of
/// half-length `a_m` and half-width `b_m`: `(o_x a / r, o_y min(1, b / across))` (`r_m` the
/// layout's outer radius, `across_m` its largest offset across the frame): squeezed across the
/// tube to the shape's half-width, stretched along it as the stadium lengthens, so an inner node
/// stays inner and the layout's order is kept. With `b >= across` and `a = r` it is `o` itself.
/// Non-finite or non-positive sizes give the origin, as [`stadium_point`]'s.
pub fn packed_point(o: Vec2, r_m: f32, across_m: f32, a_m: f32, b_m: f32) -> Vec2 {
    let squeeze = if across_m > b_m { b_m / across_m } else { 1.0 };
    let p = Vec2::new(o.x * (a_m / r_m), o.y * squeeze);
    // A non-finite size makes the sum non-finite (a zero radius too); a non-positive one fails the rest.
    if vt_fpu::is_finite(p.x + p.y + r_m) && r_m > 0.0 && a_m > 0.0 && b_m > 0.0 {
        p
    } else {
        Vec2::zeros()
    }
}

/// Steps of the stadium's half-length between the ring's radius and its longest, `2 r - b`
/// ([`separated_half_length_m`]).
pub const LENGTH_STEPS: i32 = 8;

/// The passage speed (extension, issue 27; docs/design.md, "The passage speed"): the fraction of
/// `v_max` the formation flies at while the stadium is narrower than the ring *and* keeps a
/// separation floor (bodies declared). There the stadium holds the pairs at the floor exactly,
/// where the UAVs fly, so a pair's clearance above it is the team's tracking error, which grows
/// with its speed (a velocity loop behind an attitude autopilot trails a moving command by
/// about `v tau`). Measured on the paper's team with 0.445 m bodies and the 0.2 m floor: nominal
/// disturbances from the ground 183 -> 200 of 200; the stock PX4 gains' world 30 -> 122 of 200.
pub const PASSAGE_SPEED_FRACTION: f32 = 2.0 / 3.0;

/// The team as the stadium's separation check needs it: each node's take-off angle about the
/// tray centre (from the tube's direction, rad), its taut cable length (mm), the load node about
/// the centre (stadium frame, m) and the tray height `H` (m).
#[derive(Debug, Clone, Copy)]
pub struct StadiumTeam<'a> {
    /// Take-off angle of each node about the tray centre, rad.
    pub angles_rad: &'a [f32],
    /// Taut cable length of each UAV, mm (kept in two bytes a UAV: the MCU's stack).
    pub lengths_mm: &'a [u16],
    /// The load node about the tray centre in the stadium's frame, m.
    pub load_m: Vec2,
    /// Tray height above the load `H`, m.
    pub tray_height_m: f32,
    /// How the nodes go on the shape (the ring's perimeter, or a packed layout's squeeze).
    pub layout: Layout<'a>,
}

/// What bounds the stadium's length (capacity-aware formation, capacity.rs): the distance every
/// pair of UAVs keeps where they fly at the smallest scale the law may fly, and the team's
/// vertical capacity at the scale it flies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StadiumLimits {
    /// Separation floor, m (the capacity-aware formation's `separation_m`); 0: the stadium is
    /// as long as the ring.
    pub separation_m: f32,
    /// The scale the floor is checked at (`lambda_min`).
    pub separation_scale: f32,
    /// Least `sum_i cos theta_i` the stadium keeps as it lengthens (the flight gives the load's
    /// own `W / f`, `CapacityParams::weight_cos_sum`); 0: no declared load.
    pub min_cos_sum: f32,
    /// The scale the capacity is checked at (`lambda*`).
    pub capacity_scale: f32,
}

impl<'a> StadiumTeam<'a> {
    /// Node `k`'s offset from the load node on the stadium of half-length `a_m` and half-width
    /// `b_m` (node space, m).
    fn offset(&self, k: usize, a_m: f32, b_m: f32, squeeze: f32) -> Option<Vec2> {
        let th = *self.angles_rad.get(k)?;
        let p = match self.layout {
            Layout::Ring => stadium_point(th, a_m, b_m),
            Layout::Packed { nodes_m, .. } => self.layout.place(nodes_m.get(k)?, th, a_m, b_m),
        };
        Some(Vec2::new(p.x, p.y * squeeze) - self.load_m)
    }

    /// The smallest distance between two UAVs (m, 3-D) where they fly at scale `lambda`: UAV
    /// `i` at `P_i = L_i (lambda d_i, H) / sqrt(lambda^2 |d_i|^2 + H^2)` about the load, `d_i`
    /// its node's offset from the load node (as the capacity-aware formation's separation floor
    /// measures it: the tray projection puts a UAV below its node), with the nodes on the
    /// stadium of half-length `a_m` and half-width `b_m`; infinity for fewer than two UAVs.
    pub fn min_distance_m(&self, a_m: f32, b_m: f32, lambda: f32) -> f32 {
        self.squeezed_min_distance_m(a_m, b_m, lambda, 1.0)
    }

    /// [`Self::min_distance_m`] with the stadium squeezed sideways: every node's lateral offset
    /// times `squeeze` (1: the stadium itself, bit for bit). A tube narrower than the
    /// narrowest stadium squeezes the formation this way (the tube keeping, eq:2-14, acts
    /// sideways).
    pub fn squeezed_min_distance_m(&self, a_m: f32, b_m: f32, lambda: f32, squeeze: f32) -> f32 {
        let mut best2 = f32::INFINITY;
        let n = self.angles_rad.len().min(self.lengths_mm.len());
        for i in 0..n {
            let Some(pi) = self.position(i, a_m, b_m, lambda, squeeze) else { break };
            for j in i + 1..n {
                let Some(pj) = self.position(j, a_m, b_m, lambda, squeeze) else { break };
                best2 = vt_fpu::min(best2, (pi - pj).norm_squared());
            }
        }
        vt_fpu::sqrt(best2)
    }

    /// UAV `k` where it flies about the load at scale `lambda`, m (module docs of capacity.rs).
    #[inline(never)]
    fn position(&self, k: usize, a_m: f32, b_m: f32, lambda: f32, squeeze: f32) -> Option<Vec3> {
        let d = self.offset(k, a_m, b_m, squeeze)?;
        let len_m = f32::from(*self.lengths_mm.get(k)?) * 1e-3;
        Some(crate::capacity::uav_rel(d, len_m, lambda, self.tray_height_m))
    }

    /// `sum_i cos theta_i` with the nodes on the stadium at scale `lambda` (the team's vertical
    /// capacity over one UAV's, capacity.rs: `cos theta = H / sqrt(H^2 + lambda^2 |d|^2)`).
    pub fn cos_sum(&self, a_m: f32, b_m: f32, lambda: f32) -> f32 {
        (0..self.angles_rad.len()).filter_map(|k| self.offset(k, a_m, b_m, 1.0)).fold(0.0, |s, d| s + crate::capacity::lean_cos(vt_fpu::norm(&d), lambda, self.tray_height_m))
    }
}

/// The stadium's half-length for half-width `b_m` (both m, node space): the ring's radius
/// `r_m` when the shape is not narrower than the layout ([`Layout::narrower`]) or every pair of UAVs keeps the separation floor where they fly
/// ([`StadiumTeam::min_distance_m`] at `limits.separation_scale`), else the shortest of
/// [`LENGTH_STEPS`] equal steps up to `2 r - b` (it lengthens by at most what it narrows) that
/// keeps it. A node farther from the centre than on the ring leans its cable more, so no step
/// is taken that brings the team's vertical capacity below `limits.min_cos_sum`
/// ([`StadiumTeam::cos_sum`] at `limits.capacity_scale`): the last step before that one, or
/// the longest, when the floor is not reached (docs/design.md, "A formation shaped to the
/// tube").
pub fn separated_half_length_m(team: &StadiumTeam<'_>, limits: &StadiumLimits, r_m: f32, b_m: f32) -> f32 {
    if !(limits.separation_m > 0.0 && team.layout.narrower(r_m, b_m) && b_m > 0.0) {
        return r_m;
    }
    let step = (r_m - b_m) * (1.0 / LENGTH_STEPS as f32);
    let mut a = r_m;
    for k in 0..=LENGTH_STEPS {
        let next = r_m + step * k as f32;
        if k > 0 && team.cos_sum(next, b_m, limits.capacity_scale) < limits.min_cos_sum {
            return a;
        }
        a = next;
        if team.min_distance_m(a, b_m, limits.separation_scale) >= limits.separation_m {
            return a;
        }
    }
    a
}

/// The point of the circle of radius `b_m` about `(centre_x_m, 0)` at angle `a_rad`, m.
#[inline(never)]
fn on_circle(centre_x_m: f32, b_m: f32, a_rad: f32) -> Vec2 {
    let (sin, cos) = vt_fpu::sin_cos(a_rad).unwrap_or((0.0, 1.0));
    Vec2::new(centre_x_m + b_m * cos, b_m * sin)
}

/// The samples of `tube` over arc lengths `[from_m, to_m]` (clamped to the tube, at least one)
/// and the index of the first; `None` for a non-finite window. Both section scans below use it.
fn window<const S: usize>(tube: &Tube<S>, from_m: f32, to_m: f32) -> Option<(usize, &[TubeSample])> {
    let ds = tube.ds_m();
    let (lo, hi) = (from_m / ds, to_m / ds);
    if !(lo.is_finite() && hi.is_finite() && ds > 0.0) {
        return None;
    }
    let last = S.saturating_sub(1);
    let k0 = (lo.max(0.0) as usize).min(last);
    let k1 = (libm::ceilf(hi.max(0.0)) as usize).min(last);
    tube.samples().get(k0..=k1.max(k0)).map(|w| (k0, w))
}

/// The narrowest half-width `(w_L + w_R) / 2` of `tube` over arc lengths
/// `[s_m - behind_m, s_m + ahead_m]` (clamped to the tube), m; `None` for a non-finite window.
pub fn narrowest_half_width_m<const S: usize>(tube: &Tube<S>, s_m: f32, behind_m: f32, ahead_m: f32) -> Option<f32> {
    window(tube, s_m - behind_m, s_m + ahead_m).map(|(_, w)| w.iter().fold(f32::INFINITY, |m, s| vt_fpu::min(m, 0.5 * (s.w_left_m + s.w_right_m))))
}

/// How far past the formation's front a narrow section counts in full when the shape keeps a
/// separation floor, m ([`ramped_half_width_m`]; docs/design.md, "The shape narrows as the
/// passage comes").
pub const RAMP_LEAD_M: f32 = 1.0;

/// How far behind the formation's back a narrow section is still felt, fading, when the shape
/// keeps a separation floor, m ([`ramped_half_width_m`]).
pub const RAMP_BEHIND_M: f32 = 4.0;

/// The half-width the tube-shaped formation is sized to at arc length `s_m` when the narrow
/// sections are weighed by where they lie, m; `None` for a non-finite window (docs/design.md,
/// "The shape narrows as the passage comes"). A section within the formation's reach
/// (`reach_m` behind the load to `reach_m + lead_m` ahead; `reach_m` the longer of the ring's
/// radius and the stadium's half-length flown) counts in full, as in
/// [`narrowest_half_width_m`]. Beyond it, out to `reach_m + ahead_m` ahead and
/// `reach_m + behind_m` behind, its half-width is widened by `ring_m` times the fraction of the
/// way to the window's edge: a passage entering the window asks for a shape a little narrower
/// than the ring, and the full narrowing arrives as the load comes to it, a quantum or two a
/// look instead of every rest length at one look; after it the shape widens only once the
/// passage has left the formation's reach, fading over `behind_m`. It depends on the tube, the
/// load's place and the shape flown, which every UAV shares, so every UAV derives the same; and a
/// re-planned tube gives its answer at once (no memory to lag behind it). With `reach_m =
/// ring_m`, `lead_m >= ahead_m` and `behind_m = 0` it is [`narrowest_half_width_m`] bit for bit.
#[allow(clippy::too_many_arguments)]
pub fn ramped_half_width_m<const S: usize>(tube: &Tube<S>, s_m: f32, ring_m: f32, reach_m: f32, ahead_m: f32, lead_m: f32, behind_m: f32) -> Option<f32> {
    let (k0, samples) = window(tube, s_m - (reach_m + behind_m), s_m + (reach_m + ahead_m))?;
    let ds = tube.ds_m();
    // Distances from the load at which a section starts to fade, and the fades' lengths (a
    // fade of no length: the window's edge).
    let (near_ahead, fade_ahead) = (reach_m + lead_m, ahead_m - lead_m);
    let (near_behind, fade_behind) = (reach_m, behind_m);
    let mut narrowest = f32::INFINITY;
    for (k, sample) in (k0..).zip(samples.iter()) {
        let d = k as f32 * ds - s_m;
        let fade = if d > near_ahead && fade_ahead > 0.0 {
            (d - near_ahead) / fade_ahead
        } else if d < -near_behind && fade_behind > 0.0 {
            (-near_behind - d) / fade_behind
        } else {
            0.0
        };
        narrowest = vt_fpu::min(narrowest, 0.5 * (sample.w_left_m + sample.w_right_m) + ring_m * fade);
    }
    Some(narrowest)
}

/// The narrowest quantum for a ring of `n` nodes: the stadium's sides stay at least the ring's
/// neighbour spacing `2 r sin(pi / n)` apart (`b >= r sin(pi / n)`), so a small team is not
/// folded flat (two rows of two are closer across than neighbours on their ring); at least
/// [`MIN_QUANTUM`].
pub fn min_quantum(n: usize) -> i32 {
    if n < 2 {
        return QUANTA;
    }
    let sin = vt_fpu::sin_cos(PI / n as f32).map_or(1.0, |sc| sc.0);
    (libm::ceilf(sin * QUANTA as f32) as i32).clamp(MIN_QUANTUM, QUANTA)
}

/// The shape's quantum for a formation of node radius `ring_m` given lateral `room_m` for its
/// nodes: `floor(QUANTA room / ring)` within `[narrowest, QUANTA]` (`QUANTA`: the ring;
/// `narrowest` at least [`MIN_QUANTUM`]).
pub fn quantum(room_m: f32, ring_m: f32, narrowest: i32) -> i32 {
    let lo = narrowest.clamp(MIN_QUANTUM, QUANTA);
    let q = room_m / ring_m * QUANTA as f32;
    if q.is_nan() || !(ring_m > 0.0) {
        return QUANTA;
    }
    (libm::floorf(q) as i32).clamp(lo, QUANTA)
}

/// The quantum to fly given the one flown (`held`) and the one the tube asks for now (`asked`):
/// narrower at once, wider only by two quanta or back to the ring, so that a section at a
/// quantum's edge does not switch the shape back and forth.
pub fn next_quantum(held: i32, asked: i32) -> i32 {
    if asked < held || asked >= held + 2 || asked == QUANTA {
        asked
    } else {
        held
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vt_tube::Waypoint;

    #[test]
    fn the_ring_is_the_widest_stadium() {
        for k in 0..24 {
            let th = k as f32 * 0.3 - 2.0;
            let p = stadium_point(th, 2.5, 2.5);
            assert!((p - Vec2::new(2.5 * th.cos(), 2.5 * th.sin())).norm() < 1e-5, "{th}: {p:?}");
            assert_eq!(stadium_point(th, 2.5, 7.0), p, "b beyond r is the ring");
        }
    }

    /// Points lie on the stadium, and equal angles are equal arc lengths: the perimeter
    /// `2 pi b + 4 (r - b)` walked at a uniform pace, never farther out than the ring.
    #[test]
    fn points_walk_the_stadium_at_a_uniform_pace() {
        let (r, b) = (3.0_f32, 1.2_f32);
        let c = r - b;
        let perimeter = TAU * b + 4.0 * c;
        let k = 2000;
        let pts: Vec<Vec2> = (0..=k).map(|i| stadium_point(TAU * i as f32 / k as f32, r, b)).collect();
        let mut length = 0.0;
        for w in pts.windows(2) {
            let step = (w[1] - w[0]).norm();
            assert!((step - perimeter / k as f32).abs() < 1e-3, "uniform pace: {step}");
            length += step;
        }
        assert!((length - perimeter).abs() < 1e-2, "perimeter {length}");
        for p in &pts {
            let on_side = p.x.abs() <= c + 1e-4 && (p.y.abs() - b).abs() < 1e-4;
            let on_cap = p.x.abs() >= c - 1e-4 && ((p - Vec2::new(c * p.x.signum(), 0.0)).norm() - b).abs() < 1e-4;
            assert!(on_side || on_cap, "{p:?} off the stadium");
            assert!(p.y.abs() <= b + 1e-5 && p.norm() <= r + 1e-5, "within the half-width and the ring: {p:?}");
        }
        assert!((pts[0] - Vec2::new(r, 0.0)).norm() < 1e-5, "the front");
        // Symmetric front-back and left-right.
        let p = stadium_point(0.4, r, b);
        assert!((stadium_point(-0.4, r, b) - Vec2::new(p.x, -p.y)).norm() < 1e-5);
        assert!((stadium_point(PI - 0.4, r, b) - Vec2::new(-p.x, p.y)).norm() < 1e-5);
    }

    /// Nodes equally spaced on a ring stay equally spaced along the narrowed stadium: each
    /// neighbour at least the chord of its arc on the half circles, and no two nodes closer
    /// than that across the stadium at the team's narrowest quantum.
    #[test]
    fn narrowing_keeps_neighbours_apart() {
        let r = 3.0_f32;
        for n in [3usize, 4, 5, 7, 10, 20, 30] {
            for q in min_quantum(n)..=QUANTA {
                let b = r * q as f32 / QUANTA as f32;
                let arc = (TAU * b + 4.0 * (r - b)) / n as f32;
                let chord = 2.0 * b * (arc / (2.0 * b)).min(FRAC_PI_2).sin();
                let pts: Vec<Vec2> = (0..n).map(|i| stadium_point(TAU * i as f32 / n as f32 + 0.1, r, b)).collect();
                for i in 0..n {
                    let gap = (pts[(i + 1) % n] - pts[i]).norm();
                    assert!(gap >= chord - 1e-4, "n {n} q {q}: gap {gap} < {chord}");
                    for j in 0..n {
                        if j != i {
                            assert!((pts[j] - pts[i]).norm() >= chord.min(2.0 * b) - 1e-4, "n {n} q {q}: {i}-{j}");
                        }
                    }
                }
            }
        }
    }

    /// The separated length: the ring's radius when no floor is asked or the ring's radius
    /// keeps it; otherwise the shortest step that keeps it, within `[r, 2 r - b]`, never past
    /// the capacity's need; the longest when nothing keeps it.
    #[test]
    fn the_stadium_lengthens_to_the_first_length_that_keeps_the_floor() {
        let n = 10;
        let angles: Vec<f32> = (0..n).map(|k| TAU * k as f32 / n as f32 + 0.3).collect();
        let lengths = [8300u16, 7000, 8600, 8800, 8300, 8500, 8400, 7700, 8300, 7300]; // the paper's cables
        let team = StadiumTeam { angles_rad: &angles, lengths_mm: &lengths, load_m: Vec2::new(0.1, -0.05), tray_height_m: 10.0, layout: Layout::Ring };
        let (r, b) = (3.0f32, 3.0 * 17.0 / 32.0);
        let lim = |sep: f32, cos: f32| StadiumLimits { separation_m: sep, separation_scale: 0.77, min_cos_sum: cos, capacity_scale: 0.8 };
        assert_eq!(separated_half_length_m(&team, &lim(0.0, 0.0), r, b), r, "no floor");
        assert_eq!(separated_half_length_m(&team, &lim(1.09, 0.0), r, r), r, "the ring");
        let step = (r - b) / LENGTH_STEPS as f32;
        for sep in [0.5f32, 0.9, 1.0, 1.05, 1.09, 1.12, 5.0] {
            let a = separated_half_length_m(&team, &lim(sep, 0.0), r, b);
            assert!(a >= r && a <= 2.0 * r - b + 1e-4, "{sep}: {a}");
            let k = libm::roundf((a - r) / step) as i32;
            assert!(((r + step * k as f32) - a).abs() < 1e-5, "a step: {a}");
            let kept = team.min_distance_m(a, b, 0.77) >= sep;
            assert!(kept || k == LENGTH_STEPS, "{sep}: {a} neither keeps it nor is the longest");
            for shorter in 0..k {
                assert!(team.min_distance_m(r + step * shorter as f32, b, 0.77) < sep, "{sep}: step {shorter} kept it already");
            }
        }
        // Capacity first: a need met by the ring's radius and one step only.
        let need = team.cos_sum(r + step, b, 0.8);
        assert!(team.cos_sum(r + 2.0 * step, b, 0.8) < need, "longer leans more");
        assert_eq!(separated_half_length_m(&team, &lim(5.0, need), r, b), r + step);
        assert_eq!(separated_half_length_m(&team, &lim(5.0, team.cos_sum(r, b, 0.8) + 1.0), r, b), r);
        // Two UAVs at the same place where they fly: zero; one UAV: no pair.
        assert!(team.min_distance_m(r, b, 0.77).is_finite());
        let one = StadiumTeam { angles_rad: &angles[..1], ..team };
        assert_eq!(one.min_distance_m(r, b, 1.0), f32::INFINITY);
    }

    /// A packed layout's node on the shape: itself while the shape is as wide and as long as the
    /// layout; squeezed across it within the half-width, stretched along it, every node's order
    /// along each axis kept (an inner node stays inner); degenerate sizes give the origin.
    #[test]
    fn a_packed_layout_is_squeezed_across_and_stretched_along() {
        let (r, across) = (2.9f32, 1.8f32);
        let nodes = [Vec2::new(2.9, 0.0), Vec2::new(1.1, 0.0), Vec2::new(-1.9, 1.8), Vec2::new(0.0, -1.7), Vec2::new(-2.0, -1.7)];
        for o in nodes {
            assert_eq!(packed_point(o, r, across, r, across), o, "the layout itself");
            assert_eq!(packed_point(o, r, across, r, 5.0), o, "room beyond its width");
        }
        let (a, b) = (3.6f32, 1.2f32);
        let placed: Vec<Vec2> = nodes.iter().map(|o| packed_point(*o, r, across, a, b)).collect();
        for (i, (o, p)) in nodes.iter().zip(&placed).enumerate() {
            assert!(p.y.abs() <= b + 1e-6 && p.x.abs() <= a + 1e-6, "{i}: {p:?} within the shape");
            for (q, s) in nodes.iter().zip(&placed) {
                assert_eq!(o.x < q.x, p.x < s.x, "order along");
                assert_eq!(o.y < q.y, p.y < s.y, "order across");
            }
        }
        assert!(placed[1].norm() < placed[0].norm(), "the inner node stays inner");
        for (r, a, b) in [(0.0, a, b), (r, f32::NAN, b), (r, a, -1.0), (f32::INFINITY, a, b), (r, f32::INFINITY, b)] {
            assert_eq!(packed_point(nodes[2], r, across, a, b), Vec2::zeros(), "{r} {a} {b}");
        }
        assert_eq!(packed_point(Vec2::new(f32::NAN, 0.0), 2.9, across, a, b), Vec2::zeros());
    }

    #[test]
    fn degenerate_inputs_give_the_origin() {
        for (th, r, b) in [(f32::NAN, 1.0, 1.0), (0.0, 0.0, 1.0), (0.0, 1.0, -1.0), (0.0, f32::INFINITY, 1.0)] {
            assert_eq!(stadium_point(th, r, b), Vec2::zeros());
        }
    }

    #[test]
    fn quanta_narrow_at_once_and_widen_with_hysteresis() {
        assert_eq!(quantum(10.0, 3.0, MIN_QUANTUM), QUANTA);
        assert_eq!(quantum(1.5, 3.0, MIN_QUANTUM), 16);
        assert_eq!(quantum(0.1, 3.0, MIN_QUANTUM), MIN_QUANTUM);
        assert_eq!(quantum(0.1, 3.0, 23), 23);
        assert_eq!(quantum(f32::NAN, 3.0, MIN_QUANTUM), QUANTA);
        assert_eq!(quantum(1.0, 0.0, MIN_QUANTUM), QUANTA);
        // Small teams fold less: 3, 4 and 5 nodes keep sin(pi / n) of the ring's radius.
        assert_eq!((min_quantum(3), min_quantum(4), min_quantum(5)), (28, 23, 19));
        assert_eq!((min_quantum(10), min_quantum(30), min_quantum(1)), (MIN_QUANTUM, MIN_QUANTUM, QUANTA));
        assert_eq!(next_quantum(20, 19), 19);
        assert_eq!(next_quantum(20, 21), 20);
        assert_eq!(next_quantum(20, 22), 22);
        assert_eq!(next_quantum(31, QUANTA), QUANTA);
    }

    #[test]
    fn the_narrowest_section_in_the_window() {
        let w = |x: f32, h: f32| Waypoint::new(x, 0.0, h, h);
        let tube: Tube<256> = Tube::from_waypoints(&[w(0.0, 5.0), w(10.0, 5.0), w(15.0, 2.0), w(20.0, 5.0), w(40.0, 5.0)]).unwrap();
        let far = narrowest_half_width_m(&tube, 2.0, 1.0, 3.0).unwrap();
        let near = narrowest_half_width_m(&tube, 10.0, 1.0, 6.0).unwrap();
        assert!(far > 4.9, "{far}");
        assert!((near - 2.0).abs() < 0.1, "{near}");
        assert!(narrowest_half_width_m(&tube, f32::NAN, 1.0, 3.0).is_none());
        assert!(narrowest_half_width_m(&tube, 1e6, 1.0, 3.0).unwrap() > 4.9, "clamped to the tube's end");
    }

    /// The ramp: a passage far ahead asks for a little, the whole narrowing arrives as the load
    /// comes to it (a few quanta a look instead of all at once), the widening behind fades, and
    /// with no fade it is the narrowest section bit for bit.
    #[test]
    fn a_passage_is_weighed_by_where_it_lies() {
        let w = |x: f32, h: f32| Waypoint::new(x, 0.0, h, h);
        let tube: Tube<256> = Tube::from_waypoints(&[w(0.0, 5.0), w(12.0, 5.0), w(13.0, 2.0), w(17.0, 2.0), w(18.0, 5.0), w(40.0, 5.0)]).unwrap();
        let (ring, ahead, r_safe, margin) = (3.0f32, 6.0f32, 0.645f32, 0.5f32);
        let q_of = |half_width: f32| quantum(half_width - r_safe - margin, ring, min_quantum(10));
        // The load walks the tube at the passage speed's 1 m/s, a look every 0.2 m.
        let (mut held_step, mut held_ramp) = (QUANTA, QUANTA);
        let (mut jump_step, mut jump_ramp) = (0, 0);
        let mut s = 0.0f32;
        while s < 35.0 {
            let step = narrowest_half_width_m(&tube, s, ring, ring + ahead).unwrap();
            let ramp = ramped_half_width_m(&tube, s, ring, ring, ahead, RAMP_LEAD_M, RAMP_BEHIND_M).unwrap();
            assert_eq!(ramped_half_width_m(&tube, s, ring, ring, ahead, ahead, 0.0).unwrap().to_bits(), step.to_bits(), "no fade: the window's narrowest at s = {s}");
            // Never narrower than the narrowest section of its own window, which reaches
            // further behind than the step's.
            let widest_window = narrowest_half_width_m(&tube, s, ring + RAMP_BEHIND_M, ring + ahead).unwrap();
            assert!(ramp >= widest_window, "{ramp} < {widest_window} at s = {s}");
            // With the passage (13-17 m) within the formation's reach the whole narrowing applies.
            if s + ring >= 13.0 && s - ring <= 17.0 {
                assert!((ramp - step).abs() < 1e-6, "in reach at s = {s}: {ramp} against {step}");
            }
            let (q_step, q_ramp) = (next_quantum(held_step, q_of(step)), next_quantum(held_ramp, q_of(ramp)));
            jump_step = jump_step.max((q_step - held_step).abs());
            jump_ramp = jump_ramp.max((q_ramp - held_ramp).abs());
            (held_step, held_ramp) = (q_step, q_ramp);
            s += 0.2;
        }
        assert!(jump_step >= 10, "the window's narrowest jumps: {jump_step} quanta at one look");
        assert!(jump_ramp <= 3, "the ramp moves a few quanta a look: {jump_ramp}");
        assert_eq!((held_step, held_ramp), (QUANTA, QUANTA), "both back to the ring");
        assert!(ramped_half_width_m(&tube, f32::NAN, ring, ring, ahead, RAMP_LEAD_M, RAMP_BEHIND_M).is_none());
        assert!(ramped_half_width_m(&tube, 1e6, ring, ring, ahead, RAMP_LEAD_M, RAMP_BEHIND_M).unwrap() > 4.9, "clamped to the tube's end");
    }
}
