//! UAV-UAV separation barrier (extension, issue 27; docs/design.md "Envelopes and
//! clearances").
//!
//! The paper keeps UAVs apart only through the springs' rest lengths, so a formation squeezed by
//! a narrow passage brings real airframes (0.83 m from rotor tip to rotor tip at 2 kg) within a
//! few centimetres of each other. The traditional virtual tube's robot-robot barrier `V_m`
//! (REFERENCE §2, `vt_tube::barrier`) is added on the UAVs' horizontal positions: pole at
//! `separation_m`, zero beyond `separation_m + SEPARATION_BAND_M`, gain `k3`. Its velocity is
//! the negative gradient of a potential that is symmetric in each pair, so adding `V_m` to the
//! storage function of Prop. 1 keeps the closed loop dissipative (as in Quan et al.'s
//! traditional virtual tube), and the potential grows without bound at the pole: no pair comes
//! closer than `separation_m` horizontally while the command is followed. Horizontal distance
//! is used because a quadrotor's downwash reaches the one below it: stacking is no separation.

use crate::springs::COINCIDENT_M;
use crate::{Vec2, Vec3};
use vt_tube::BarrierParams;

/// Width of the band beyond the pole where the separation barrier acts, m (measured choice: the
/// paper's formation of 2 kg airframes, neighbours about 1.42 m apart at rest against a pole
/// of 1.09 m, does not feel it at rest; 0.5 m pushed the whole formation out against the tube
/// in the narrow passages, 0.15-0.25 m let pairs through the pole; docs/design.md).
pub const SEPARATION_BAND_M: f32 = 0.3;

/// How far above the separation floor (`2 r_u + c`) the capacity-aware formation, and the
/// stadium shaped from it, put their pairs where the UAVs fly, m: what a team behind PX4's stock
/// gains in light turbulence closes below the formation's static geometry (measured on the
/// paper's team at the 20 N clamp in the real-aircraft world, 20 seeds at 19.2 / 19.4 kg: a
/// guard of 0.25 m kept the floor in 4 / 6 runs, 0.3 m in 17 / 17, 0.41 m in 20 / 2 with the
/// heavier load sinking; docs/design.md, "Heavy loads keep their pairs apart").
pub const FORMATION_GUARD_M: f32 = 0.3;

/// How much farther apart than the capacity-aware formation's floor (`2 r_u + c` plus
/// [`FORMATION_GUARD_M`]) the stadium flown in a passage lengthens to put its pairs, m, as far
/// as the load's capacity lets it lengthen (extension; docs/design.md, "The stadium flown keeps
/// a wider floor"). The capacity-aware ring and the planner's width keep the formation's own
/// floor: a ring floor 0.1 / 0.2 m wider sank the 19.4 kg load (3 / 20 and 2 / 20 seeds flown
/// at the 20 N clamp), a wider need would close corridors. Measured on the paper's team in the real-aircraft world: nominal 195
/// -> 198 / 200, held-out 197 -> 199 / 200, and 0.1, 0.2 and 0.3 m fly the same bits there
/// (the stadium reaches its longest, `2 r - b`, or the capacity bound).
pub const STADIUM_GUARD_M: f32 = 0.2;

/// Largest push of one pair, m/s (any value far above every speed limit: the caller
/// saturates the sum).
const PAIR_CAP_MPS: f32 = 1.0e3;

/// Cap of the separation velocity as a multiple of `v_m`: added to the saturated command
/// (at most `v_m`), a capped separation velocity still turns it away from the neighbour.
pub const SEPARATION_AUTHORITY: f32 = 2.0;

/// The separation barrier `spec` with gain `k3` (m^2/s): pole `spec.pole_m`, band
/// `spec.band_m` ([`SEPARATION_BAND_M`] or, with the formation shaped to the tube, the clearance
/// floor: [`separation_pole_band`]); `None` when the pole or the band is not positive (off: the
/// paper's controller).
pub fn separation_barrier(k3: f32, spec: &SeparationSpec) -> Option<BarrierParams> {
    let (pole, band) = (spec.pole_m, spec.band_m);
    (pole > 0.0 && band > 0.0).then(|| BarrierParams::tube(k3, pole, pole + band))
}

/// The separation barrier a team flies: its pole and band, m, and whether it measures the
/// pairs' distance in 3-D ([`separation_pole_band`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeparationSpec {
    /// Pole: the centre distance the barrier keeps, m (0: off).
    pub pole_m: f32,
    /// Band beyond the pole where it acts, m.
    pub band_m: f32,
    /// The distance is the centres' 3-D distance (the contact barrier), not the horizontal one.
    pub three_d: bool,
}

impl SeparationSpec {
    /// No separation barrier (the paper's controller).
    pub const OFF: Self = Self { pole_m: 0.0, band_m: SEPARATION_BAND_M, three_d: false };
}

/// The separation barrier flown by bodies of radius `body_r_m` kept `floor_m` apart between
/// their surfaces (m; extension, docs/design.md, "The contact barrier"):
/// - without the shaped formation, the full barrier: pole at the floor (`2 r_u + c`), band
///   [`SEPARATION_BAND_M`] beyond it, on the horizontal distance (a quadrotor's downwash
///   reaches the one below it);
/// - with it (`shaped`), the contact barrier: pole at contact (`2 r_u`), band the floor `c`, on
///   the 3-D distance between the centres, the distance the floor is judged on. It is zero
///   wherever a pair keeps the floor, so it leaves the shaped formation's neighbours (1.2-1.5 m
///   apart for the paper's 0.445 m bodies, some of them at different heights in a narrowing)
///   alone, where the full barrier slowed the team to a crawl; inside the floor it pushes the
///   pair apart before the bodies touch. Off without a positive floor.
///
/// Off (a zero pole) without a body.
pub fn separation_pole_band(body_r_m: f32, floor_m: f32, shaped: bool) -> SeparationSpec {
    let off = SeparationSpec::OFF;
    if !(body_r_m > 0.0) {
        off
    } else if shaped {
        if floor_m > 0.0 { SeparationSpec { pole_m: 2.0 * body_r_m, band_m: floor_m, three_d: true } } else { off }
    } else {
        SeparationSpec { pole_m: 2.0 * body_r_m + vt_fpu::max(floor_m, 0.0), ..off }
    }
}

/// Separation velocity of UAV `id` at `own_m` from the neighbours' positions (m; missing or
/// non-finite ones skipped, own slot ignored), m/s in the horizontal plane, and whether two
/// UAVs coincided horizontally (then they part along `+x` for the lower id, as the springs do).
/// The barrier acts on the pair's horizontal distance, or with `three_d` on their 3-D distance
/// `r`: the velocity is then the horizontal part of the 3-D gradient, `-V'(r) (q_i - q_j) / r`
/// on the horizontal offset (the altitudes are the altitude law's).
pub fn separation_velocity(id: usize, own_m: &Vec3, neighbours_m: &[Option<Vec3>], barrier: &BarrierParams, three_d: bool) -> (Vec2, bool) {
    let mut v = Vec2::zeros();
    let mut coincident = false;
    let q = own_m.xy();
    for (j, p) in neighbours_m.iter().enumerate() {
        let Some(p) = p else { continue };
        if j == id || !(p.x.is_finite() && p.y.is_finite()) {
            continue;
        }
        let d = q - p.xy();
        let dz = if three_d { own_m.z - p.z } else { 0.0 };
        let horizontal_sq = d.norm_squared();
        let dist = vt_fpu::sqrt(horizontal_sq + dz * dz);
        if !(dist < barrier.r_active_m) {
            continue;
        }
        // Inside the pole the barrier's slope overflows f32 (`eval` saturates it at
        // `-f32::MAX`): cap each pair's push so that the sum stays finite.
        let push = (-barrier.eval(dist).deriv).min(PAIR_CAP_MPS);
        if horizontal_sq >= COINCIDENT_M * COINCIDENT_M {
            v += d * (push / dist);
        } else {
            coincident = true;
            v.x += if id < j { push } else { -push };
        }
    }
    (v, coincident)
}

#[cfg(test)]
mod tests {
    use super::*;

    const B: BarrierParams = BarrierParams::tube(1.0, 1.0, 1.5);

    #[test]
    fn off_at_zero_and_silent_beyond_the_band() {
        assert!(separation_barrier(1.0, &SeparationSpec::OFF).is_none());
        assert!(separation_barrier(1.0, &SeparationSpec { pole_m: 1.1, band_m: 0.0, three_d: false }).is_none());
        let b = separation_barrier(1.0, &SeparationSpec { pole_m: 1.1, ..SeparationSpec::OFF }).unwrap();
        assert_eq!((b.r_safe_m, b.r_active_m), (1.1, 1.1 + SEPARATION_BAND_M));
        let n = [Some(Vec3::new(1.6, 0.0, 0.0)), None];
        assert_eq!(separation_velocity(1, &Vec3::zeros(), &n, &B, false).0, Vec2::zeros());
    }

    #[test]
    fn pushes_apart_horizontally_and_symmetrically() {
        let a = Vec3::new(0.0, 0.0, 10.0);
        let b = Vec3::new(1.2, 0.3, 11.0);
        let n = [Some(a), Some(b)];
        let (va, _) = separation_velocity(0, &a, &n, &B, false);
        let (vb, _) = separation_velocity(1, &b, &n, &B, false);
        assert!(va.x < 0.0 && va.y < 0.0, "away from the other: {va:?}");
        assert!((va + vb).norm() < 1e-6, "equal and opposite: {va:?} {vb:?}");
        // Along the horizontal line between them.
        let d = (a - b).xy();
        assert!((va.perp(&d)).abs() < 1e-5);
        // Stronger closer to the pole.
        let c = Vec3::new(1.05, 0.0, 10.0);
        let (vc, _) = separation_velocity(0, &a, &[Some(a), Some(c)], &B, false);
        assert!(vc.norm() > va.norm());
    }

    /// The contact barrier of a shaped formation acts only inside the clearance floor, on the
    /// 3-D distance: silent for a pair that keeps it (also one whose centres are closer
    /// horizontally but apart in height), pushing apart inside it, strongest towards contact;
    /// the full barrier (no shape) starts at the floor, reaches a band beyond it and is
    /// horizontal.
    #[test]
    fn the_contact_barrier_acts_only_inside_the_floor() {
        let (r, c) = (0.445, 0.2);
        let full = separation_pole_band(r, c, false);
        assert_eq!((full.pole_m, full.band_m, full.three_d), (2.0 * r + c, SEPARATION_BAND_M, false));
        let contact = separation_pole_band(r, c, true);
        assert_eq!((contact.pole_m, contact.band_m, contact.three_d), (2.0 * r, c, true));
        for (body, floor, shaped) in [(0.0, c, true), (0.0, c, false), (f32::NAN, c, true), (r, 0.0, true), (r, f32::NAN, true)] {
            let sh = separation_pole_band(body, floor, shaped);
            assert!(separation_barrier(1.0, &sh).is_none(), "off: {body} {floor} {shaped}");
        }
        let b = separation_barrier(1.0, &contact).unwrap();
        let own = Vec3::new(0.0, 0.0, 10.0);
        let push = |d: f32, dz: f32| separation_velocity(0, &own, &[None, Some(Vec3::new(d, 0.0, 10.0 + dz))], &b, true).0;
        // Silent at the floor and beyond: at the shaped formation's 1.2-1.5 m, at 1.09 m, and
        // 0.8 m apart horizontally with 0.8 m between their heights (1.13 m).
        for (d, dz) in [(2.0 * r + c, 0.0), (1.2, 0.0), (1.5, 0.0), (0.8, 0.8)] {
            assert_eq!(push(d, dz), Vec2::zeros(), "at {d} m, {dz} m above");
        }
        // Inside the floor: away from the neighbour, growing towards contact; a height
        // difference inside the floor still counts, and the push stays horizontal.
        let (a, bb, cc) = (push(1.05, 0.0), push(0.95, 0.0), push(0.9, 0.0));
        assert!(a.x < 0.0 && a.y == 0.0);
        assert!(bb.x < a.x && cc.x < bb.x, "{a:?} {bb:?} {cc:?}");
        assert!(push(0.9, 0.3).x < 0.0 && push(0.9, 0.3).x > cc.x);
        // Horizontally the same pair 0.8 m apart is inside the full barrier's reach.
        let fb = separation_barrier(1.0, &full).unwrap();
        let n = [None, Some(Vec3::new(0.8, 0.0, 10.8))];
        assert!(separation_velocity(0, &own, &n, &fb, false).0.x < 0.0);
        assert!(separation_velocity(0, &own, &[None, Some(Vec3::new(1.3, 0.0, 10.0))], &fb, false).0.x < 0.0);
        // A neighbour with no finite height is skipped in 3-D.
        assert_eq!(separation_velocity(0, &own, &[None, Some(Vec3::new(0.9, 0.0, f32::NAN))], &b, true).0, Vec2::zeros());
    }

    /// The velocity is the negative gradient of `sum_j V_m(|q - q_j|)`: a small step along it
    /// lowers the barrier energy (Lyapunov decrease), finite even at and inside the pole.
    #[test]
    fn descends_the_barrier_potential_and_stays_finite() {
        let others = [None, Some(Vec3::new(1.2, 0.2, 0.0)), Some(Vec3::new(0.3, 1.3, 0.0))];
        let energy = |q: &Vec3| -> f32 {
            others.iter().flatten().map(|p| B.eval((q - p).xy().norm()).value).sum()
        };
        let q = Vec3::new(0.0, 0.0, 0.0);
        let (v, _) = separation_velocity(0, &q, &others, &B, false);
        let step = Vec3::new(v.x, v.y, 0.0) * 1e-4;
        assert!(energy(&(q + step)) < energy(&q));
        for p in [Vec3::new(0.5, 0.0, 0.0), Vec3::zeros(), Vec3::new(f32::NAN, 0.0, 0.0)] {
            let (v, _) = separation_velocity(0, &q, &[None, Some(p)], &B, false);
            assert!(v.x.is_finite() && v.y.is_finite());
        }
        let (v, c) = separation_velocity(0, &q, &[None, Some(Vec3::new(0.0, 0.0, 3.0))], &B, false);
        assert!(c && v.x > 0.0, "coincident horizontally: the lower id parts along +x");
    }
}
