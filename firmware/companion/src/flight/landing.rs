//! The landing after the release (a delivery, a set-down, a refusal on the ground): where each
//! UAV lands, the guard it lands with, and the land detector (`vt_dissipative::landing`;
//! docs/design.md, "Landing", "The landing after the release tilts to 60 deg", "The landing
//! keeps the tube and its neighbours").

use nalgebra::Vector2;
use vt_dissipative::controller::HOLD_POSITION_GAIN_PER_S;
use vt_dissipative::keeping::keeping_velocity;
use vt_dissipative::landing::{
    guarded_landing_velocity, hover_keeping_band_m, landing_velocity_mps, pairwise_pushes_mps, place_inside_tube, LandDetector, LAND_SEPARATION_BAND_M,
    LAND_SEPARATION_GAIN_PER_S, LAND_SPACING_M, LAND_SPREAD_GAIN_PER_S,
};
use vt_tube::BarrierParams;

use crate::params::{Param, Params};
use crate::{CompanionTube, Vec3};

/// One UAV's landing: its place, its guard's parameters and its land detector.
#[derive(Debug, Clone)]
pub(super) struct Landing {
    /// Where the landing holds the UAV, m (set at the first released step).
    place_m: Option<Vector2<f32>>,
    /// The land detector: once landed the rotors idle.
    detector: LandDetector,
    /// How far inside the tube's boundary the place stays, m (`Params::r_safe_m`): the pole of
    /// the guard's tube keeping too.
    keep_m: f32,
    /// The guard's tube keeping: gain `VT_K3`, m^2/s, and activation radius `VT_R_ACT`, m.
    keeping: [f32; 2],
    /// The separation floor the guard's push keeps, m (`Params::separation_m`; 0, no body
    /// declared: the guard is off).
    separation_m: f32,
    /// Warm start of the place's tube lookup.
    hint: usize,
}

impl Landing {
    /// A landing not begun, with the guard's parameters from `params`.
    pub(super) fn new(params: &Params) -> Self {
        Self {
            place_m: None,
            detector: LandDetector::default(),
            keep_m: params.r_safe_m(),
            keeping: [params.get(Param::K3), params.get(Param::RActive)],
            separation_m: params.separation_m(),
            hint: 0,
        }
    }

    /// True once landed.
    pub(super) fn landed(&self) -> bool {
        self.detector.landed()
    }

    /// One step of UAV `id` at `own_m` after `dt_s`, neighbours in `view`: the place (first
    /// `first_place_m`, then moved by the spread and kept inside the tube), the land detector,
    /// and the velocity (ENU, m/s): the place's hold at `v_max_mps` with the guard, a descent at
    /// `LAND_SPEED_MPS`. Also returns how far the UAV is off its place, m.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn step(&mut self, tube: &CompanionTube, id: usize, own_m: &Vec3, view: &[Option<Vec3>], first_place_m: Vector2<f32>, dt_s: f32, v_max_mps: f32) -> (Vec3, f32) {
        // The place moves away from neighbours too close horizontally (a formation may stack
        // UAVs above one another): `vt_dissipative::landing::landing_spread_mps`, in one pass
        // with the guard's push (`pairwise_pushes_mps`); and it stays inside the tube
        // (`place_inside_tube`).
        let ranges = [LAND_SPACING_M, self.separation_m + LAND_SEPARATION_BAND_M];
        let [[sx, sy], push] = pairwise_pushes_mps([own_m.x, own_m.y], others_xy(view, id), ranges, [LAND_SPREAD_GAIN_PER_S, LAND_SEPARATION_GAIN_PER_S]);
        let mut place = *self.place_m.get_or_insert(first_place_m) + Vector2::new(sx, sy) * dt_s;
        if let Some(sec) = tube.locate(place, self.hint) {
            self.hint = sec.segment;
            let [x, y] = place_inside_tube([place.x, place.y], [sec.midpoint_m.x, sec.midpoint_m.y], sec.half_width_m, self.keep_m);
            place = Vector2::new(x, y);
        }
        self.place_m = Some(place);
        let drift_m = vt_fpu::norm(&(own_m.xy() - place));
        self.detector.step(own_m.z, dt_s);
        let [x, y, z] = landing_velocity_mps([own_m.x, own_m.y], [place.x, place.y], HOLD_POSITION_GAIN_PER_S, v_max_mps);
        let v = self.guard(tube, own_m, Vector2::new(push[0], push[1]), Vector2::new(x, y), v_max_mps, self.keeping[1]);
        (Vec3::new(v.x, v.y, z), drift_m)
    }

    /// The hover's guard (docs/design.md, "The hover keeps the tube"): `hold_mps` (m/s,
    /// horizontal ENU) of UAV `id` at `own_m` with the tube kept as the landing keeps it, pole at
    /// `r_safe`, within `vt_dissipative::landing::hover_keeping_band_m` of it (narrowed by the
    /// closest neighbour in `view`). Only with a body declared, as the landing's guard.
    pub(super) fn guard_hover(&self, tube: &CompanionTube, id: usize, own_m: &Vec3, view: &[Option<Vec3>], hold_mps: Vector2<f32>, v_max_mps: f32) -> Vector2<f32> {
        let band_m = hover_keeping_band_m([own_m.x, own_m.y], others_xy(view, id), self.separation_m);
        let r_active_m = vt_fpu::min(self.keeping[1], self.keep_m + band_m);
        self.guard(tube, own_m, Vector2::zeros(), hold_mps, v_max_mps, r_active_m)
    }

    /// The guard (`vt_dissipative::landing::guarded_landing_velocity`): the tube keeping at the
    /// own position (eq:2-14/eq:2-15, pole at the place's keep) and the push from the
    /// neighbours within `LAND_SEPARATION_BAND_M` of the separation floor, added to the place's
    /// hold `hold_mps` (m/s); the barrier acts within `r_active_m` of the boundary (the
    /// landing's `VT_R_ACT`, the hover's band). Only with a body declared (`VT_BODY_R`): without one the push has
    /// no floor, and the keeping alone presses the UAVs at the formation's edge into their
    /// neighbours (generated teams at 3x: 26 -> 29 runs in contact); the hold is flown as it is.
    fn guard(&self, tube: &CompanionTube, own_m: &Vec3, push_mps: Vector2<f32>, hold_mps: Vector2<f32>, v_max_mps: f32, r_active_m: f32) -> Vector2<f32> {
        if !(self.separation_m > 0.0) {
            return hold_mps;
        }
        let k3 = self.keeping[0];
        let own_xy = own_m.xy();
        let keeping = if r_active_m > self.keep_m {
            tube.locate(own_xy, self.hint).map_or(Vector2::zeros(), |sec| keeping_velocity(&sec, &own_xy, &BarrierParams::tube(k3, self.keep_m, r_active_m)).0)
        } else {
            Vector2::zeros()
        };
        guarded_landing_velocity(hold_mps, keeping, push_mps, v_max_mps)
    }
}

/// The horizontal positions of UAV `id`'s neighbours in `view` (the slots that hold one).
fn others_xy(view: &[Option<Vec3>], id: usize) -> impl Iterator<Item = [f32; 2]> + '_ {
    view.iter().enumerate().filter(move |&(j, _)| j != id).filter_map(|(_, v)| v.map(|p| [p.x, p.y]))
}
