//! The take-off formation as the tube-shaped formation needs it (`crate::shape`; docs/design.md,
//! "A formation shaped to the tube"): the stadium's rest lengths, its separated half-length, and
//! the ring's drift before the first look.

use super::RestLengths;
use crate::capacity::FormationScale;
use crate::separation::STADIUM_GUARD_M;
use crate::shape::{separated_half_length_m, Layout, ShapeParams, StadiumLimits, StadiumTeam, PACKED_LIFT_RESERVE, PASSAGE_SPEED_FRACTION, QUANTA, RING_SPREAD};
use crate::Vec2;

/// The take-off formation as the tube-shaped formation needs it (shape.rs). Kept small: it
/// lives in every companion's `Flight`, which the mission's start builds on the stack.
#[derive(Debug, Clone)]
pub(super) struct TubeShape<const N: usize> {
    pub(super) params: ShapeParams,
    /// The UAV nodes at take-off (eq:2-4), world, m.
    pub(super) nodes_m: [Vec2; N],
    /// The load node at take-off, world, m.
    pub(super) load_node_m: Vec2,
    /// The tray centre's node at take-off, world, m.
    pub(super) centre_m: Vec2,
    /// The ring's node radius, the largest node distance from the centre, m.
    pub(super) radius_m: f32,
    /// Each UAV's taut cable length at take-off, mm (the separation check; 0 without one).
    pub(super) lengths_mm: [u16; N],
    /// Distance every pair of UAVs keeps where they fly, m (0: the stadium as long as the ring).
    pub(super) separation_m: f32,
    /// Least `sum_i cos theta_i` a lengthened stadium keeps (shape.rs, [`StadiumLimits`]).
    pub(super) min_cos_sum: f32,
    /// The stadium's half-length flown, m (node space, before the capacity-aware scale).
    pub(super) half_length_m: f32,
    /// The tube's direction at the load at the first look: node angles are taken from it.
    pub(super) frame: Option<Vec2>,
    /// How far the formation has turned about the load since take-off, `(cos, sin)` averaged
    /// over [`DRIFT_AVERAGE_S`] while the team holds before the first look ((1, 0): not at all).
    pub(super) drift: Vec2,
    /// The quantum flown.
    pub(super) quantum: i32,
    /// The quantum the window's narrowest section asks for (with the quanta's hysteresis): with
    /// a separation floor the team flies the passage speed from it, as soon as a passage enters
    /// the look-ahead, however gradually the shape itself narrows ([`QUANTA`]: not slowed).
    pub(super) speed_quantum: i32,
}

/// Averaging time of the formation's drift before the first look, s (`TubeShape`): long
/// enough that every UAV's estimate from its own view of the nodes agrees (noise averaged
/// over 50 high-level steps at 50 Hz), short against the climb's turn (several degrees in 10 s).
pub const DRIFT_AVERAGE_S: f32 = 1.0;

impl<const N: usize> TubeShape<N> {
    /// The fraction of `v_max` the formation flies at now: [`PASSAGE_SPEED_FRACTION`] while the
    /// stadium keeps a separation floor (bodies declared) and is narrower than the ring, else 1.
    pub(super) fn speed_fraction(&self) -> f32 {
        if self.speed_quantum < QUANTA && self.separation_m > 0.0 {
            PASSAGE_SPEED_FRACTION
        } else {
            1.0
        }
    }

    /// How the take-off nodes go on the shape in `frame` (shape.rs, [`Layout`]): on the
    /// stadium's perimeter when every node lies at least [`RING_SPREAD`] of the outer radius
    /// from the centre (the ring), else packed (two rings, a patch: squeezed across, inner nodes
    /// kept inside). Out of line (flash).
    #[inline(never)]
    pub(super) fn layout(&self, frame: Vec2, n: usize) -> Layout<'_> {
        let nodes = self.nodes_m.get(..n).unwrap_or(&[]);
        let (mut inner_m, mut across_m) = (f32::INFINITY, 0.0f32);
        for p in nodes {
            let o = p - self.centre_m;
            inner_m = vt_fpu::min(inner_m, vt_fpu::norm(&o));
            across_m = vt_fpu::max(across_m, (o.x * frame.y - o.y * frame.x).abs());
        }
        if inner_m >= RING_SPREAD * self.radius_m {
            Layout::Ring
        } else {
            Layout::Packed { nodes_m: nodes, centre_m: self.centre_m, frame, radius_m: self.radius_m, across_m }
        }
    }

    /// UAV `id`'s rest lengths (and the tray centre's) written into `rest`, times `scale` (the
    /// capacity-aware formation's): at quantum [`QUANTA`] the take-off ones (eq:2-7, computed
    /// as `Formation::rest_length_m` does, so bit for bit), else the nodes placed from `frame`
    /// on the shape of half-width `r q / QUANTA` and the half-length flown: a ring's at their
    /// take-off angles on the stadium, a packed layout's squeezed across and stretched along
    /// (shape.rs, [`Layout`]).
    #[inline(never)]
    pub(super) fn write_rest_lengths(&self, id: usize, q: i32, frame: Vec2, n: usize, scale: f32, rest: &mut RestLengths<N>) {
        let b = self.radius_m * q as f32 / QUANTA as f32;
        let a = self.half_length_m;
        let ring = q >= QUANTA;
        let layout = self.layout(frame, n);
        // A node's place: the take-off node itself (the ring), or its point on the shape about the centre.
        let place = |p: &Vec2| if ring { *p } else { layout.place(p, self.angle_rad(p, frame), a, b) };
        let (centre, load) = if ring { (self.centre_m, self.load_node_m) } else { (Vec2::zeros(), self.in_frame(&self.load_node_m, frame)) };
        let own = self.nodes_m.get(id).map_or(centre, place);
        for ((o, c), node) in rest.own_m.iter_mut().zip(rest.center_m.iter_mut()).zip(self.nodes_m.iter()).take(n) {
            let e = place(node);
            *o = vt_fpu::norm(&(own - e)) * scale;
            *c = vt_fpu::norm(&(centre - e)) * scale;
        }
        rest.own_load_m = vt_fpu::norm(&(own - load)) * scale;
        rest.own_center_m = vt_fpu::norm(&(own - centre)) * scale;
    }

    /// Before the first look: the formation's turn about the load since take-off, from the
    /// nodes seen now against the take-off ones (the load's node as the pivot), averaged into
    /// `drift` over [`DRIFT_AVERAGE_S`]. A ground start's lift and climb turn the ring
    /// (nothing in the springs holds its rotation); the stadium then starts from the turned ring.
    #[cold]
    #[inline(never)]
    pub(super) fn track_drift(&mut self, nodes: &[Option<Vec2>; N], load_xy: &Vec2, n: usize, dt_s: f32) {
        if self.frame.is_some() || !(dt_s.is_finite() && dt_s > 0.0) {
            return;
        }
        let (mut cos_sum, mut sin_sum) = (0.0f32, 0.0f32);
        for (q, t) in nodes.iter().zip(self.nodes_m.iter()).take(n) {
            if let Some(q) = q {
                let (a, b) = (t - self.load_node_m, q - load_xy);
                cos_sum += a.dot(&b);
                sin_sum += a.x * b.y - a.y * b.x;
            }
        }
        let now = Vec2::new(cos_sum, sin_sum);
        let norm = vt_fpu::norm(&now);
        if !(norm.is_finite() && norm > 0.0) {
            return;
        }
        let k = vt_fpu::min(dt_s / DRIFT_AVERAGE_S, 1.0);
        let next = self.drift + (now / norm - self.drift) * k;
        if next.iter().all(|x| x.is_finite()) {
            self.drift = next;
        }
    }

    /// The stadium's frame at the first look: the tube's direction `tangent` turned back by the
    /// formation's drift since take-off, so that every node keeps the place on the stadium its
    /// angle in the turned ring gives it (the tangent itself without a drift).
    pub(super) fn turned_frame(&self, tangent: &Vec2) -> Vec2 {
        let norm = vt_fpu::norm(&self.drift);
        if self.drift == Vec2::new(1.0, 0.0) || !(norm.is_finite() && norm > 0.0) {
            return *tangent;
        }
        let (c, s) = (self.drift.x / norm, self.drift.y / norm);
        Vec2::new(c * tangent.x + s * tangent.y, c * tangent.y - s * tangent.x)
    }

    /// A take-off node `p` about the tray centre in the stadium's frame (`frame` the tube's
    /// direction at the first look), m.
    fn in_frame(&self, p: &Vec2, frame: Vec2) -> Vec2 {
        let o = p - self.centre_m;
        Vec2::new(o.dot(&frame), o.dot(&Vec2::new(-frame.y, frame.x)))
    }

    /// A take-off node's angle about the tray centre from `frame`, rad: its place on the stadium.
    fn angle_rad(&self, p: &Vec2, frame: Vec2) -> f32 {
        let o = self.in_frame(p, frame);
        vt_fpu::atan2(o.y, o.x)
    }

    /// The half-length of the stadium of quantum `q` flown (shape.rs, [`separated_half_length_m`]):
    /// the ring's radius, or longer where the pairs of UAVs would otherwise come closer than
    /// the separation floor plus [`STADIUM_GUARD_M`] where they fly (the tray's projection puts
    /// a UAV below its node, `L / sqrt(d^2 + H^2)` of its node's offset), never spending the
    /// capacity the load needs.
    #[inline(never)]
    pub(super) fn half_length_for(&self, q: i32, frame: Vec2, n: usize, tray_height_m: f32, scale: &FormationScale) -> f32 {
        if q >= QUANTA || self.separation_m <= 0.0 {
            return self.radius_m;
        }
        let mut angles = [0.0f32; N];
        let (team, mut limits) = self.stadium_team(&mut angles, frame, n, tray_height_m, scale);
        // The stadium flown lengthens for a wider floor than the capacity-aware formation's, as far
        // as the load's capacity lets it (`min_cos_sum`); the planner's need below keeps the
        // formation's own floor (docs/design.md, "The stadium flown keeps a wider floor").
        limits.separation_m += STADIUM_GUARD_M;
        separated_half_length_m(&team, &limits, self.radius_m, self.radius_m * q as f32 / QUANTA as f32)
    }

    /// The narrowest tube the formation keeps its separation floor in, in quanta of the ring's
    /// radius (the planner's need, [`super::DissipativeController::shaped_need_half_width_m`]):
    /// down from the ring, the last stadium whose pairs keep the floor where they fly at the
    /// scale the capacity-aware formation aims for (`lambda*`), at the half-length
    /// [`Self::half_length_for`] gives it (a narrow stadium may not reach the floor before the
    /// capacity stops its lengthening; that length is chosen at the smallest scale the law may
    /// fly, a contraction for an overload, which a plan need not be sized for). When every
    /// stadium keeps it, the narrowest one (`floor_q`) squeezed sideways in steps of a quantum,
    /// as far as its pairs keep the floor plus [`super::SQUEEZE_GUARD_M`]. [`QUANTA`] without a
    /// floor.
    pub(super) fn floor_width_quanta(&self, floor_q: i32, frame: Vec2, n: usize, tray_height_m: f32, scale: &FormationScale) -> f32 {
        if self.separation_m <= 0.0 {
            return QUANTA as f32;
        }
        let mut angles = [0.0f32; N];
        let (team, limits) = self.stadium_team(&mut angles, frame, n, tray_height_m, scale);
        let stadium = |q: i32| {
            let b = self.radius_m * q as f32 / QUANTA as f32;
            (separated_half_length_m(&team, &limits, self.radius_m, b), b)
        };
        let mut held = QUANTA;
        for q in (floor_q..QUANTA).rev() {
            let (a, b) = stadium(q);
            if team.min_distance_m(a, b, limits.capacity_scale) < limits.separation_m {
                return held as f32;
            }
            held = q;
        }
        let (a, b) = stadium(floor_q);
        let mut width = floor_q as f32;
        for q in (1..floor_q).rev() {
            if team.squeezed_min_distance_m(a, b, limits.capacity_scale, q as f32 / floor_q as f32) < limits.separation_m + super::SQUEEZE_GUARD_M {
                break;
            }
            width = q as f32;
        }
        width
    }

    /// The closest pair of UAVs where they fly at `lambda*`, m, the stadium of quantum `q` at the
    /// half-length the planner's need gives it (the formation's own floor; the stadium flown,
    /// [`Self::half_length_for`], is at least as long) and squeezed sideways by `squeeze` (the
    /// tests' view of [`Self::floor_width_quanta`]).
    #[cfg(test)]
    pub(super) fn flown_min_distance_m(&self, q: i32, squeeze: f32, frame: Vec2, n: usize, tray_height_m: f32, scale: &FormationScale) -> f32 {
        let mut angles = [0.0f32; N];
        let (team, limits) = self.stadium_team(&mut angles, frame, n, tray_height_m, scale);
        let b = self.radius_m * q as f32 / QUANTA as f32;
        let a = separated_half_length_m(&team, &limits, self.radius_m, b);
        team.squeezed_min_distance_m(a, b, limits.capacity_scale, squeeze)
    }

    /// The team and its limits as the stadium's separation check needs them (shape.rs), the
    /// node angles from `frame` written into `angles`.
    fn stadium_team<'a>(&'a self, angles: &'a mut [f32; N], frame: Vec2, n: usize, tray_height_m: f32, scale: &FormationScale) -> (StadiumTeam<'a>, StadiumLimits) {
        for (a, p) in angles.iter_mut().zip(self.nodes_m.iter()).take(n) {
            *a = self.angle_rad(p, frame);
        }
        let team = StadiumTeam {
            angles_rad: angles.get(..n).unwrap_or(&[]),
            lengths_mm: self.lengths_mm.get(..n).unwrap_or(&[]),
            load_m: self.in_frame(&self.load_node_m, frame),
            tray_height_m,
            layout: self.layout(frame, n),
        };
        // The floor at the smallest scale the capacity-aware formation may fly, the capacity at
        // the scale it aims for (capacity.rs).
        // A packed layout's stretch keeps a reserve of lift (shape.rs, [`PACKED_LIFT_RESERVE`]).
        let reserve = if matches!(team.layout, Layout::Packed { .. }) { 1.0 + PACKED_LIFT_RESERVE } else { 1.0 };
        let limits = StadiumLimits { separation_m: self.separation_m, separation_scale: scale.scale_min(), min_cos_sum: self.min_cos_sum * reserve, capacity_scale: scale.scale_target() };
        (team, limits)
    }
}
