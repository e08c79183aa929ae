//! Two quadrotors integrated together (issue 26: the simulator's speed): the integration step
//! of [`Quadrotor::substep`] on two vehicles at once, one per lane of a two-wide `f64` vector.
//!
//! The scalar step spends a third of its instructions moving the components of nalgebra's
//! small vectors in and out of SIMD registers; two vehicles side by side fill both halves of
//! every register (SSE2's `mulpd`, `addpd`, `sqrtpd`) with nothing to shuffle. Each lane does
//! the scalar step's operations in the scalar step's order (nalgebra's: a matrix-vector product
//! is `(r_i0 v_0 + r_i1 v_1) + r_i2 v_2`, a 3-vector dot `(a_0 b_0 + a_1 b_1) + a_2 b_2`, a
//! 4-vector dot `(a_0 b_0 + a_2 b_2) + (a_1 b_1 + a_3 b_3)`, `Iterator::sum` folds from `-0.0`),
//! so each vehicle's state is the scalar step's bit for bit (test
//! `a_pair_steps_as_two_quadrotors_bit_for_bit`). What is rare or branchy per vehicle (the
//! autopilot, its IMU, the mixer, the drag bound, the exponential map's trigonometric branch)
//! runs lane by lane through the scalar code.

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use super::{mixer, AttitudeTarget, Quadrotor, GRAVITY_MPS2, SERIES_HALF_ANGLE_RAD};
use crate::cable::{all_finite, cable_force, taut, CableForce, CableParams};

/// One `f64` per vehicle of the pair (`wide`'s two-lane vector: SSE2 on x86-64, NEON on
/// aarch64, each lane an IEEE operation as the scalar one).
type F2 = wide::f64x2;

/// Builds a pair from its two lanes.
#[inline(always)]
fn f2(a: f64, b: f64) -> F2 {
    F2::new([a, b])
}

/// Lane `k` (0 or 1) of `v`.
#[inline(always)]
fn lane_of(v: F2, k: usize) -> f64 {
    let [a, b] = v.to_array();
    if k == 0 { a } else { b }
}

/// A 3-vector per vehicle.
#[derive(Debug, Clone, Copy)]
struct V2x3 {
    x: F2,
    y: F2,
    z: F2,
}

impl V2x3 {
    #[inline(always)]
    fn of(a: &Vector3<f64>, b: &Vector3<f64>) -> Self {
        Self { x: f2(a.x, b.x), y: f2(a.y, b.y), z: f2(a.z, b.z) }
    }
    #[inline(always)]
    fn lane(&self, k: usize) -> Vector3<f64> {
        let pick = |v: F2| lane_of(v, k);
        Vector3::new(pick(self.x), pick(self.y), pick(self.z))
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
    /// `self * s` (nalgebra's vector times scalar).
    #[inline(always)]
    fn scale(self, s: F2) -> Self {
        Self { x: self.x * s, y: self.y * s, z: self.z * s }
    }
    /// Component-wise product.
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Self { x: self.x * o.x, y: self.y * o.y, z: self.z * o.z }
    }
    /// nalgebra's 3-vector dot: `(x x' + y y') + z z'`.
    #[inline(always)]
    fn dot(self, o: Self) -> F2 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    /// nalgebra's cross product.
    #[inline(always)]
    fn cross(self, b: Self) -> Self {
        Self { x: self.y * b.z - self.z * b.y, y: self.z * b.x - self.x * b.z, z: self.x * b.y - self.y * b.x }
    }
}

/// A rotation matrix per vehicle, `r[i][j]` row `i`, column `j`.
#[derive(Debug, Clone, Copy)]
struct M2x3 {
    r: [[F2; 3]; 3],
}

impl M2x3 {
    #[inline(always)]
    fn of(a: &nalgebra::Matrix3<f64>, b: &nalgebra::Matrix3<f64>) -> Self {
        let e = |i: usize, j: usize| f2(a[(i, j)], b[(i, j)]);
        Self { r: [[e(0, 0), e(0, 1), e(0, 2)], [e(1, 0), e(1, 1), e(1, 2)], [e(2, 0), e(2, 1), e(2, 2)]] }
    }
    /// `R v` as nalgebra's gemv: `(r_i0 v_0 + r_i1 v_1) + r_i2 v_2`.
    #[inline(always)]
    fn mul(&self, v: V2x3) -> V2x3 {
        let [a, b, c] = self.r;
        let row = |r: [F2; 3]| r[0] * v.x + r[1] * v.y + r[2] * v.z;
        V2x3 { x: row(a), y: row(b), z: row(c) }
    }
    /// `R^T v`, the same product on the transpose.
    #[inline(always)]
    fn tr_mul(&self, v: V2x3) -> V2x3 {
        let [a, b, c] = self.r;
        V2x3 { x: a[0] * v.x + b[0] * v.y + c[0] * v.z, y: a[1] * v.x + b[1] * v.y + c[1] * v.z, z: a[2] * v.x + b[2] * v.y + c[2] * v.z }
    }
    /// nalgebra's `UnitQuaternion::to_rotation_matrix` of `(w, i, j, k)`.
    #[inline(always)]
    fn from_quaternion(w: F2, i: F2, j: F2, k: F2) -> Self {
        let two = F2::splat(2.0);
        let (ww, ii, jj, kk) = (w * w, i * i, j * j, k * k);
        let (ij, wk, wj, ik, jk, wi) = (i * j * two, w * k * two, w * j * two, i * k * two, j * k * two, w * i * two);
        Self {
            r: [
                [ww + ii - jj - kk, ij - wk, wj + ik],
                [wk + ij, ww - ii + jj - kk, jk - wi],
                [ik - wj, wi + jk, ww - ii - jj + kk],
            ],
        }
    }
    /// Lane `k` as a matrix.
    #[inline(always)]
    fn lane(&self, k: usize) -> nalgebra::Matrix3<f64> {
        let p = |v: F2| lane_of(v, k);
        let [a, b, c] = self.r;
        nalgebra::Matrix3::new(p(a[0]), p(a[1]), p(a[2]), p(b[0]), p(b[1]), p(b[2]), p(c[0]), p(c[1]), p(c[2]))
    }
}

/// [`mixer::Mixer::wrench`] of two vehicles: the collective `((T1 + T2) + T3) + T4` and the
/// three torques, each a sum folded from `-0.0` as `Iterator::sum` does (the collective's
/// weights 1: `1 T` is `T` exactly).
#[inline(always)]
fn wrench(t: &[F2; 4], d: F2, km: F2) -> (F2, V2x3) {
    let fold = |signs: [f64; 4]| t.iter().zip(signs).fold(F2::splat(-0.0), |acc, (tk, s)| acc + F2::splat(s) * *tk);
    let torque = V2x3 { x: d * fold(mixer::ROLL_SIGN), y: d * fold(mixer::PITCH_SIGN), z: km * fold(mixer::YAW_SIGN) };
    (fold([1.0; 4]), torque)
}

/// The state of two vehicles at the start of a step, in lanes.
struct Gathered {
    rot: M2x3,
    omega: V2x3,
    vel: V2x3,
    pos: V2x3,
}

impl Gathered {
    #[inline(always)]
    fn of(a: &Quadrotor, b: &Quadrotor) -> Self {
        Self { rot: M2x3::of(&a.rot, &b.rot), omega: V2x3::of(&a.body_rates_rps, &b.body_rates_rps), vel: V2x3::of(&a.vel_mps, &b.vel_mps), pos: V2x3::of(&a.pos_m, &b.pos_m) }
    }
}

/// [`Quadrotor::step_on_cable`] of two vehicles at once: each vehicle's cable force from its
/// attachment point at the start of the step ([`cable_force`], in the lanes when both cables
/// are taut and everything is finite, else vehicle by vehicle), then one step of `h` (s, at
/// most [`super::MAX_SUBSTEP_S`], > 0) under it. Per vehicle exactly the scalar path.
pub(super) fn step_pair_on_cables(qs: [&mut Quadrotor; 2], cables: [&CableParams; 2], load: (&Vector3<f64>, &Vector3<f64>), targets: [&AttitudeTarget; 2], wind: [Vector3<f64>; 2], h: f64) -> [CableForce; 2] {
    let [a, b] = qs;
    let g = Gathered::of(a, b);
    // Attachment point and its velocity: `p + R r_a`, `v + R (omega x r_a)`.
    let r_a = V2x3::of(&a.params.attach_point_body_m, &b.params.attach_point_body_m);
    let hook = g.pos.add(g.rot.mul(r_a));
    let hook_v = g.vel.add(g.rot.mul(g.omega.cross(r_a)));
    let forces = cable_forces(hook, hook_v, load, cables);
    let f_ext = [&forces[0].on_uav_n, &forces[1].on_uav_n].map(|f| super::sanitise(*f, super::EXT_FORCE_LIMIT_N));
    let wind = wind.map(|w| super::sanitise(w, super::WIND_LIMIT_MPS));
    a.loops_and_motors(targets[0], h);
    b.loops_and_motors(targets[1], h);
    integrate_pair([a, b], &g, [&f_ext[0], &f_ext[1]], [&wind[0], &wind[1]], h);
    forces
}

/// [`cable_force`] of two cables from hooks at `hook` (m) moving at `hook_v` (m/s) to the load
/// at `load` (position m, velocity m/s): in the lanes when both are on the taut, finite path,
/// else cable by cable through the scalar function (the same inputs, so the same bits).
#[inline(always)]
fn cable_forces(hook: V2x3, hook_v: V2x3, load: (&Vector3<f64>, &Vector3<f64>), cables: [&CableParams; 2]) -> [CableForce; 2] {
    let (lp, lv) = load;
    let [ca, cb] = cables;
    let scalar = || [0, 1].map(|k| cable_force(hook.lane(k), hook_v.lane(k), *lp, *lv, cables[k]));
    let inputs_ok = (0..2).all(|k| all_finite(&hook.lane(k)) & all_finite(&hook_v.lane(k))) & all_finite(lp) & all_finite(lv) & ca.usable() & cb.usable();
    if !inputs_ok {
        return scalar();
    }
    let d = hook.sub(V2x3::of(lp, lp));
    let len = d.dot(d).sqrt();
    let rest = f2(ca.rest_length_m, cb.rest_length_m);
    let ([la, lb], [ra, rb]) = (len.to_array(), rest.to_array());
    if !(la.is_finite() && lb.is_finite() && taut(la, ra) && taut(lb, rb)) {
        return scalar();
    }
    // One division for the three components, as `cable_force`.
    let u = d.scale(F2::splat(1.0) / len);
    let rate = u.dot(hook_v.sub(V2x3::of(lv, lv)));
    let raw = f2(ca.stiffness_n_per_m, cb.stiffness_n_per_m) * (len - rest) + f2(ca.damping_ns_per_m, cb.damping_ns_per_m) * rate;
    // The clamp of `cable_force` lane by lane (f64's max/min, NaN rules included).
    let [wa, wb] = raw.to_array();
    let tension = f2(wa.max(0.0).min(ca.f_max_n.max(0.0)), wb.max(0.0).min(cb.f_max_n.max(0.0)));
    let on_load = u.scale(tension);
    let out = [0, 1].map(|k| {
        let (t, f) = (lane_of(tension, k), on_load.lane(k));
        (t.is_finite() & all_finite(&f)).then(|| CableForce { tension_n: t, on_uav_n: -f, on_load_n: f, length_m: lane_of(len, k) })
    });
    match out {
        [Some(fa), Some(fb)] => [fa, fb],
        _ => scalar(),
    }
}

/// One integration step of `h` (s) for two vehicles gathered in `g`, with sanitised inputs and
/// the rotors already moved ([`Quadrotor::loops_and_motors`]): per vehicle exactly
/// [`Quadrotor::integrate`] (module doc).
#[inline(always)]
fn integrate_pair(qs: [&mut Quadrotor; 2], g: &Gathered, f_ext: [&Vector3<f64>; 2], wind: [&Vector3<f64>; 2], h: f64) {
    let [a, b] = qs;
    let (rot, omega) = (g.rot, g.omega);
    let t = [0, 1, 2, 3].map(|k| f2(a.rotor_thrusts_n.get(k).copied().unwrap_or(0.0), b.rotor_thrusts_n.get(k).copied().unwrap_or(0.0)));
    let (thrust_n, mut torque_b) = wrench(&t, f2(a.mixer.rotor_offset_m, b.mixer.rotor_offset_m), f2(a.mixer.yaw_moment_coeff_m, b.mixer.yaw_moment_coeff_m));

    // Drag (RotorPy): body quadratic + rotor H-force, on the body-frame airspeed.
    let vel = g.vel;
    let v_air_b = rot.tr_mul(vel.sub(V2x3::of(wind[0], wind[1])));
    let v_air = v_air_b.dot(v_air_b).sqrt();
    let cd = V2x3::of(&a.params.body_drag_n_per_mps2, &b.params.body_drag_n_per_mps2);
    let mut drag_b = cd.mul(v_air_b).scale(-v_air);
    let gain_per_root = f2(a.h_force_per_sqrt_n, b.h_force_per_sqrt_n);
    for (k, tk) in t.iter().enumerate() {
        let hub = |q: &Quadrotor| q.rotor_hubs_m.get(k).copied().unwrap_or([0.0, 0.0]);
        let ([ax, ay], [bx, by]) = (hub(a), hub(b));
        let (rx, ry) = (f2(ax, bx), f2(ay, by));
        let gain = tk.max(F2::splat(0.0)).sqrt() * gain_per_root;
        let hx = (v_air_b.x - omega.z * ry) * gain;
        let hy = (v_air_b.y + omega.z * rx) * gain;
        drag_b.x += hx;
        drag_b.y += hy;
        torque_b.z += rx * hy - ry * hx;
    }
    // The drag bound of the scalar step, lane by lane (it binds only in extreme airspeeds).
    let drag_sq = drag_b.dot(drag_b);
    let hh = F2::splat(h);
    let bound = f2(a.params.mass_kg, b.params.mass_kg) * v_air;
    let lhs = drag_sq * hh * hh;
    let rhs = bound * bound;
    let (lhs, rhs, d2s, bds) = (lhs.to_array(), rhs.to_array(), drag_sq.to_array(), bound.to_array());
    // Per lane: `Some(s)` where the bound binds (`drag_b *= s`), `None` where it keeps its bits.
    let mut scale = [None; 2];
    for ((((s, l), r), d2), bd) in scale.iter_mut().zip(lhs).zip(rhs).zip(d2s).zip(bds) {
        if l > r && d2 > 0.0 {
            *s = Some(bd / (d2.sqrt() * h));
        }
    }
    if scale != [None, None] {
        let [sa, sb] = scale;
        let cut = |v: F2| {
            let [x, y] = v.to_array();
            f2(sa.map_or(x, |s| x * s), sb.map_or(y, |s| y * s))
        };
        drag_b = V2x3 { x: cut(drag_b.x), y: cut(drag_b.y), z: cut(drag_b.z) };
    }

    // Cable force at the attachment point: force at the CoM plus the torque r_a x F.
    let f_ext = V2x3::of(f_ext[0], f_ext[1]);
    let f_ext_b = rot.tr_mul(f_ext);
    let r_a = V2x3::of(&a.params.attach_point_body_m, &b.params.attach_point_body_m);
    torque_b = torque_b.add(r_a.cross(f_ext_b));

    // Translation: semi-implicit Euler.
    let force_w = rot.mul(V2x3 { x: drag_b.x, y: drag_b.y, z: drag_b.z + thrust_n }).add(f_ext);
    let inv_mass = f2(a.inv_mass, b.inv_mass);
    let accel = V2x3 { x: force_w.x * inv_mass, y: force_w.y * inv_mass, z: force_w.z * inv_mass - F2::splat(GRAVITY_MPS2) };
    let vel = vel.add(accel.scale(hh));
    let pos = g.pos.add(vel.scale(hh));

    // Rotation: world angular momentum, then the exponential map with the midpoint rates.
    let ang_mom = V2x3::of(&a.ang_mom_world, &b.ang_mom_world).add(rot.mul(torque_b).scale(hh));
    let inv_i = V2x3::of(&a.inv_inertia, &b.inv_inertia);
    let bm = V2x3::of(&a.params.inertia_kgm2, &b.params.inertia_kgm2).mul(omega).add(torque_b.scale(hh));
    let phi = inv_i.mul(bm).scale(F2::splat(0.5 * h));
    let phi_b = phi.cross(bm);
    let b_mid = bm.sub(phi_b).add(phi.cross(phi_b).scale(F2::splat(0.5)));
    let omega_mid = inv_i.mul(b_mid);
    let (w, i, j, k) = exp_step_pair([&a.attitude, &b.attitude], omega_mid, h);
    let rot = M2x3::from_quaternion(w, i, j, k);
    let rates = inv_i.mul(rot.tr_mul(ang_mom));

    for (lane, q) in [a, b].into_iter().enumerate() {
        let p = |v: F2| lane_of(v, lane);
        q.vel_mps = vel.lane(lane);
        q.pos_m = pos.lane(lane);
        q.ang_mom_world = ang_mom.lane(lane);
        q.attitude = UnitQuaternion::new_unchecked(Quaternion::new(p(w), p(i), p(j), p(k)));
        q.rot = rot.lane(lane);
        q.body_rates_rps = rates.lane(lane);
    }
}

/// [`super::exp_step`] of two attitudes by the rates `omega` (rad/s, FLU), as `(w, i, j, k)`:
/// the series branch in lanes when both take it, the scalar function otherwise.
#[inline(always)]
fn exp_step_pair(q: [&UnitQuaternion<f64>; 2], omega: V2x3, h: f64) -> (F2, F2, F2, F2) {
    let v = omega.scale(F2::splat(0.5 * h));
    let a2 = v.dot(v);
    let series = SERIES_HALF_ANGLE_RAD * SERIES_HALF_ANGLE_RAD;
    let [qa, qb] = q;
    let [a2a, a2b] = a2.to_array();
    if !(a2a < series && a2b < series) {
        let ea = super::exp_step(qa, &omega.lane(0), h);
        let eb = super::exp_step(qb, &omega.lane(1), h);
        return (f2(ea.w, eb.w), f2(ea.i, eb.i), f2(ea.j, eb.j), f2(ea.k, eb.k));
    }
    let one = F2::splat(1.0);
    let a4 = a2 * a2;
    let c = one - a2 * F2::splat(0.5) + a4 * F2::splat(1.0 / 24.0);
    let sinc = one - a2 * F2::splat(1.0 / 6.0) + a4 * F2::splat(1.0 / 120.0);
    let (r0, r1, r2, r3) = (v.x * sinc, v.y * sinc, v.z * sinc, c);
    let (q0, q1, q2, q3) = (f2(qa.i, qb.i), f2(qa.j, qb.j), f2(qa.k, qb.k), f2(qa.w, qb.w));
    // nalgebra's quaternion product, coordinates (i, j, k, w) = [0], [1], [2], [3].
    let w = q3 * r3 - q0 * r0 - q1 * r1 - q2 * r2;
    let i = q3 * r0 + q0 * r3 + q1 * r2 - q2 * r1;
    let j = q3 * r1 - q0 * r2 + q1 * r3 + q2 * r0;
    let k = q3 * r2 + q0 * r1 - q1 * r0 + q2 * r3;
    // `renormalised`: the 4-vector dot of (i, j, k, w), then one Newton step.
    let n2 = (i * i + k * k) + (j * j + w * w);
    let s = F2::splat(1.5) - F2::splat(0.5) * n2;
    (w * s, i * s, j * s, k * s)
}


#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::panic, clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::quadrotor::{imu::Imu, QuadParams};

    /// Every bit of a vehicle's state that the step changes.
    fn bits(q: &Quadrotor) -> Vec<u64> {
        let mut v: Vec<f64> = Vec::new();
        v.extend(q.pos_m.iter().chain(q.vel_mps.iter()).chain(q.ang_mom_world.iter()).chain(q.body_rates_rps.iter()));
        v.extend(q.attitude.coords.iter().chain(q.rot.iter()));
        v.extend(q.rotor_thrusts_n.iter().chain(q.rotor_cmd_n.iter()));
        let ap = q.autopilot();
        v.extend(ap.rate_setpoint_rps().iter());
        v.extend(ap.target().attitude.coords.iter());
        v.into_iter().map(f64::to_bits).collect()
    }

    fn force_bits(f: &CableForce) -> Vec<u64> {
        [f.tension_n, f.length_m].iter().chain(f.on_uav_n.iter()).chain(f.on_load_n.iter()).map(|x| x.to_bits()).collect()
    }

    /// A small linear-congruential generator: the test's inputs, the same on every run.
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self, lo: f64, hi: f64) -> f64 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
        }
    }

    /// Two different airframes (one flying on an IMU) stepped as a pair and one by one from
    /// the same states under the same changing inputs: taut and slack cables, winds up to the
    /// drag bound, body rates that take the exponential map's trigonometric branch, a
    /// non-finite load; every state and force bit for bit.
    #[test]
    fn a_pair_steps_as_two_quadrotors_bit_for_bit() {
        let mut rng = Lcg(7);
        let mut a = Quadrotor::new(QuadParams::paper(), Vector3::new(0.0, 0.0, 8.0), Vector3::zeros()).unwrap();
        let mut b = Quadrotor::new(QuadParams::sized(1.47, 30.0), Vector3::new(1.5, -0.5, 8.2), Vector3::new(0.3, 0.0, 0.0)).unwrap();
        a.trim_hover(Vector3::new(0.0, 0.0, -18.0));
        b.trim_hover(Vector3::new(2.0, 1.0, -10.0));
        b.set_imu(Some(Imu::new(3, 1, 1.0)));
        let (mut sa, mut sb) = (a.clone(), b.clone());
        let mut cables = [CableParams { rest_length_m: 7.9, stiffness_n_per_m: 500.0, damping_ns_per_m: 30.0, f_max_n: f64::INFINITY }; 2];
        cables[1].f_max_n = 20.0;
        let h = 0.0005;
        let mut targets = [AttitudeTarget { attitude: UnitQuaternion::identity(), thrust_norm: 0.4 }; 2];
        let mut branches = (0, 0, 0);
        for step in 0..20_000 {
            if step % 4 == 0 {
                for t in &mut targets {
                    let axis = Vector3::new(rng.next(-1.0, 1.0), rng.next(-1.0, 1.0), rng.next(-0.2, 0.2));
                    t.attitude = UnitQuaternion::from_scaled_axis(axis * 0.5);
                    t.thrust_norm = rng.next(0.2, 0.7);
                }
            }
            if step % 3000 == 1500 {
                // A spin: the exponential map's trigonometric branch on one vehicle, then both.
                a.set_body_rates_rps(Vector3::new(0.0, 0.0, 80.0));
                sa.set_body_rates_rps(Vector3::new(0.0, 0.0, 80.0));
                if step % 6000 == 4500 {
                    b.set_body_rates_rps(Vector3::new(70.0, 0.0, 0.0));
                    sb.set_body_rates_rps(Vector3::new(70.0, 0.0, 0.0));
                }
                branches.0 += 1;
            }
            // The load: hanging below (taut), risen (slack on one cable), or not finite.
            let mut load = Vector3::new(rng.next(-0.5, 2.0), rng.next(-0.5, 0.5), rng.next(-0.2, 0.3));
            if step % 500 < 50 {
                load.z = 6.0;
                branches.1 += 1;
            }
            if step % 7000 == 6999 {
                load.x = f64::NAN;
            }
            let load_v = Vector3::new(rng.next(-1.0, 1.0), rng.next(-1.0, 1.0), rng.next(-0.5, 0.5));
            if step % 5000 == 2500 {
                // Faster than any wind: the drag bound binds (on one vehicle, then on both).
                a.vel_mps = Vector3::new(6.0e5, 0.0, 0.0);
                sa.vel_mps = a.vel_mps;
                if step % 10_000 == 2500 {
                    b.vel_mps = Vector3::new(0.0, -7.0e5, 0.0);
                    sb.vel_mps = b.vel_mps;
                }
            }
            if step % 5000 == 2501 {
                for q in [&mut a, &mut b, &mut sa, &mut sb] {
                    q.vel_mps = Vector3::zeros();
                    q.pos_m = Vector3::new(0.0, 0.0, 8.0);
                }
            }
            let gale = step % 5000 < 20;
            if gale {
                branches.2 += 1;
            }
            let wind = |k: f64| if gale { Vector3::new(95.0, -20.0 * k, 0.0) } else { Vector3::new(rng_free(step, k), 0.5, 0.0) };
            let winds = [wind(1.0), wind(-1.0)];
            let [fa, fb] = Quadrotor::step_pair_on_cables([&mut a, &mut b], [&cables[0], &cables[1]], &load, &load_v, [&targets[0], &targets[1]], winds, h);
            let ga = sa.step_on_cable(&cables[0], &load, &load_v, &targets[0], winds[0], h);
            let gb = sb.step_on_cable(&cables[1], &load, &load_v, &targets[1], winds[1], h);
            assert_eq!(force_bits(&fa), force_bits(&ga), "cable A, step {step}");
            assert_eq!(force_bits(&fb), force_bits(&gb), "cable B, step {step}");
            assert_eq!(bits(&a), bits(&sa), "vehicle A, step {step}");
            assert_eq!(bits(&b), bits(&sb), "vehicle B, step {step}");
            if !(a.pos_m.iter().all(|x| x.is_finite()) && b.pos_m.iter().all(|x| x.is_finite())) {
                panic!("state left the finite range at step {step}");
            }
        }
        assert!(branches.0 > 0 && branches.1 > 0 && branches.2 > 0, "every branch exercised: {branches:?}");
    }

    /// A wind that varies with the step, deterministic.
    fn rng_free(step: usize, k: f64) -> f64 {
        3.0 * k * ((step as f64) * 0.001).sin()
    }
}
