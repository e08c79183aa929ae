//! The mission's phases aboard (`vt_dissipative::phases`): the ground start's sequence before
//! and after the arming, arrival and the set-down's trigger in transport (both starts), and the
//! command of a ground start before its arming.

use nalgebra::Vector2;
use vt_dissipative::controller::HOLD_POSITION_GAIN_PER_S;
use vt_dissipative::landing::{hold_velocity_xy_mps, landing_tilt_max_tan, STATION_DRIFT_ABORT_M};
use vt_dissipative::phases::{horizontal_speed_limit_mps, tension_climb_mps};
use vt_dissipative::wind::GustSurvey;
use vt_dissipative::{Abort, Phase, PhaseProfile, TakeoffSurvey, VerticalParams};

use super::{arm, Flight, HighLevel, StartError};
use crate::frames::finite3;
use crate::params::{Param, Params};
use crate::{CompanionTube, Vec3, MAX_UAVS};

/// In transport the phases look at the load (arrival, the set-down's trigger,
/// `vt_dissipative::phases::HoldWatch`) this often, s: the wind moves a team over seconds, and
/// a look costs a tube lookup (about 370 Cortex-M4 instructions) that every step would pay.
pub const TRANSPORT_WATCH_S: f32 = 0.2;

/// High-level steps between two looks at the load in transport (at least 1).
pub(super) fn watch_every(hl_dt_s: f32) -> u32 {
    if hl_dt_s.is_finite() && hl_dt_s > 0.0 {
        libm::roundf(TRANSPORT_WATCH_S / hl_dt_s).clamp(1.0, 1000.0) as u32
    } else {
        1
    }
}

impl Flight {
    /// The phases' step: arrival and the set-down's trigger from the load's place in the tube,
    /// the ramp, and (a ground start) the survey of the tension phase and the arming at its end;
    /// `member_released`: a member's heartbeat says it is in `released`.
    #[inline(never)]
    pub(super) fn advance_phases(&mut self, tube: &CompanionTube, own_m: &Vec3, load_m: &Vec3, view: &[Option<Vec3>], holding: bool, member_released: bool) {
        let Some(profile) = self.profile.as_mut() else {
            return;
        };
        let mut arrived = false;
        let mut dt_s = self.hl_dt_s;
        if profile.phase() == Phase::Transport {
            // In transport the reference stands still: the phases look at the load every
            // `TRANSPORT_WATCH_S` (arrival, the set-down's trigger), with the time since.
            self.watch_ticks = self.watch_ticks.saturating_add(1);
            if self.watch_ticks < self.watch_every {
                return;
            }
            dt_s = self.watch_ticks as f32 * self.hl_dt_s;
            self.watch_ticks = 0;
            if let Some(sec) = tube.locate(load_m.xy(), self.load_hint) {
                self.load_hint = sec.segment;
                arrived = sec.remaining_m <= self.end_tol_m;
                // The formation shaped to the tube ahead (vt_dissipative::shape), at the same looks.
                if let Some(HighLevel::Dissipative(c)) = self.high.as_mut() {
                    c.shape_to_tube(tube, &sec);
                }
                // The team cannot hold the tube (wind beyond its capacity): set the load down
                // here, inside the tube (issue 29; vt_dissipative::phases::HoldWatch).
                // After arrival the end is a stop: a load carried past it sets down too.
                let d_m = sec.boundary_distance_m(load_m.xy());
                let lost = if self.on_declined_tube {
                    false
                } else if arrived {
                    self.hold_watch.cannot_hold_end((load_m.xy() - sec.point_m).dot(&sec.tangent), d_m, dt_s)
                } else {
                    self.hold_watch.cannot_hold(sec.s_m, d_m, dt_s)
                };
                if lost {
                    profile.set_down_now();
                }
            }
        }
        profile.step(dt_s, Some(load_m.z), arrived, holding);
        if profile.phase() == Phase::Lift && load_m.z < profile.params().ground_z_m + profile.params().lift_clear_m {
            // An overload shows as the own cable's tension staying past the abort level with
            // the load still down (vt_dissipative::phases::OverloadWatch).
            if self.overload.overloaded(cable_tension_n(&self.f_hat_n, own_m, load_m), self.rated_n, dt_s) {
                profile.abort_lift();
            }
        }
        if let Some(pending) = self.pending.as_mut() {
            if matches!(profile.phase(), Phase::Takeoff | Phase::Tension) {
                // Before the arming, a member released (it refused, or could not hold its
                // place) ends the start for the team, which lands at once instead of holding
                // `LIFT_HOLD_ABORT_S` in the wind that blew the member off (docs/design.md, "A
                // member's refusal lands its team at once").
                if member_released {
                    profile.refuse();
                    return;
                }
                // A UAV blown off its place by a wind it cannot hold on its own refuses and
                // lands at once (issue 29; the hover cannot measure that wind safely).
                let drift_m = vt_fpu::norm(&(own_m.xy() - pending.hold_xy_m));
                if self.refusal.is_none() && drift_m > STATION_DRIFT_ABORT_M {
                    self.refusal = Some(StartError::Station { drift_m });
                    self.refusal_unreported = true;
                    profile.land_now();
                    return;
                }
            }
            if profile.wind_surveying() && !holding {
                // The wind the hover sees: each sample's airspeed on its own cable line, scaled
                // from its height above the load's centre (a little low: the safe side) to the
                // transport's, over the take-off and the tension phase (vt_dissipative::wind; a
                // non-finite estimate is not counted).
                if let Some(u) = (own_m - load_m).try_normalize(1e-6) {
                    pending.gusts.push(&self.f_hat_n, &u, own_m.z - load_m.z, pending.params.get(Param::DragQ), pending.params.get(Param::DragL));
                }
            }
            if profile.surveying() && !holding {
                pending.survey.push_own(own_m);
                pending.survey.push_load(load_m);
                for (j, v) in view.iter().enumerate().take(self.n) {
                    if let (true, Some(p)) = (j != self.id, v) {
                        pending.survey.push_member(j, p);
                    }
                }
            }
            if profile.ready_to_arm() {
                // The survey's means (the last sample for a source it has none of); a member
                // never heard refuses, as at an air start.
                let mut takeoff = [Vec3::zeros(); MAX_UAVS];
                let mut complete = true;
                for (j, slot) in takeoff.iter_mut().enumerate().take(self.n) {
                    let pos = if j == self.id { pending.survey.own().or(Some(*own_m)) } else { pending.survey.member(j).or(view.get(j).copied().flatten()) };
                    complete &= pos.is_some();
                    *slot = pos.unwrap_or(*own_m);
                }
                let ground_load = pending.survey.load().unwrap_or(*load_m);
                // The wind the hover's observer saw (issue 29) and its gust margin.
                let seen_wind = pending.gusts.mean_mps().map(|w| (w, pending.gusts.margin_mps().unwrap_or(0.0)));
                let armed = if complete { arm(&pending.params, self.id, self.n, takeoff.get(..self.n).unwrap_or(&[]), &ground_load, seen_wind) } else { Err(StartError::StaleData) };
                match armed {
                    Ok((high, margin)) => {
                        self.high = Some(high);
                        profile.armed(ground_load.z);
                        profile.brake_descent(margin);
                    }
                    Err(e) => {
                        self.refusal = Some(e);
                        self.refusal_unreported = true;
                        profile.refuse();
                    }
                }
                // Keep the nominal law for a refused team's slack; forget the rest.
                if self.high.is_some() {
                    self.pending = None;
                }
            }
        }
        if profile.abort() == Some(Abort::LiftFailed) && self.refusal.is_none() {
            self.refusal = Some(StartError::LiftFailed);
            self.refusal_unreported = true;
        }
    }

    /// The command of a ground start without its armed law (own, load and neighbour data): the
    /// own horizontal position held with the tube kept (docs/design.md, "The hover keeps the
    /// tube"); vertically the nominal cable's altitude law on the ramp (take-off, slack),
    /// or the tension build-up on the observer's tension estimate.
    pub(super) fn unarmed_command(&self, tube: &CompanionTube, own_m: &Vec3, load_m: &Vec3, view: &[Option<Vec3>]) -> Vec3 {
        let (Some(profile), Some(pending)) = (self.profile.as_ref(), self.pending.as_ref()) else {
            return Vec3::zeros();
        };
        let vp = VerticalParams { load_altitude_ref_m: profile.load_altitude_ref_m(), ..pending.vertical };
        let v_max = pending.params.get(Param::VMax);
        let [vx, vy] = hold_velocity_xy_mps([own_m.x, own_m.y], [pending.hold_xy_m.x, pending.hold_xy_m.y], HOLD_POSITION_GAIN_PER_S, v_max);
        let guarded = self.landing.guard_hover(tube, self.id, own_m, view, Vector2::new(vx, vy), v_max);
        let d = own_m - load_m;
        let offset = vt_fpu::sqrt(d.x * d.x + d.y * d.y);
        let v_z = if profile.phase() == Phase::Tension {
            let tension = cable_tension_n(&self.f_hat_n, own_m, load_m);
            // Never above the longest plausible cable's taut altitude.
            let ceiling = vp.load_altitude_ref_m.max(load_m.z) + vt_fpu::sqrt((pending.params.max_cable_m() * pending.params.max_cable_m() - offset * offset).max(0.0));
            let v = tension_climb_mps(tension, profile.params());
            if own_m.z >= ceiling { v.min(0.0) } else { v }
        } else {
            vp.vertical_velocity_mps(own_m.z, offset)
        };
        let v = Vec3::new(guarded.x, guarded.y, v_z);
        if finite3(&v) { v } else { Vec3::zeros() }
    }

    /// The landing after the release ([`super::landing::Landing`]): a start refused before the
    /// arming lands on the UAV's own station (the place it held since the take-off,
    /// `Pending::hold_xy_m`), not where the wind that refused it has carried it, towards a
    /// neighbour; any other landing where it was released (ENU velocity, m/s).
    #[cold]
    #[inline(never)]
    pub(super) fn landing_command(&mut self, tube: &CompanionTube, own_m: Vec3, view: &[Option<Vec3>]) -> Vec3 {
        let first_place = self.pending.as_ref().map_or(own_m.xy(), |p| p.hold_xy_m);
        let (v, drift_m) = self.landing.step(tube, self.id, &own_m, view, first_place, self.hl_dt_s, self.v_max_mps);
        // Carried off its place, the UAV may lean further above the touchdown (docs/design.md,
        // "The landing after the release tilts to 60 deg").
        self.low.set_tilt_max_tan(landing_tilt_max_tan(own_m.z, drift_m, self.tilt_max_tan));
        v
    }

    /// A delivery's descent and slack: the formation's horizontal speed limited
    /// (`vt_dissipative::phases::DESCENT_V_MAX_MPS`; a set-down keeps `v_max`). Out of line:
    /// the transport, which the MCU budget measures, pays only the phase test.
    #[cold]
    #[inline(never)]
    pub(super) fn limit_descent_speed(&mut self, phase: Phase) {
        let set_down = self.profile.as_ref().is_some_and(PhaseProfile::set_down_early);
        let lim = horizontal_speed_limit_mps(phase, set_down, self.v_max_mps);
        let v_xy = vt_tube::sat(self.vel_cmd_mps.xy(), lim);
        self.vel_cmd_mps.x = v_xy.x;
        self.vel_cmd_mps.y = v_xy.y;
    }

    /// The mission's phase (an air start: [`Phase::Transport`] until a set-down).
    pub fn phase(&self) -> Phase {
        self.profile.as_ref().map_or(Phase::Transport, PhaseProfile::phase)
    }

    /// The load altitude reference of the phases, m.
    pub fn load_altitude_ref_m(&self) -> Option<f32> {
        self.profile.as_ref().map(PhaseProfile::load_altitude_ref_m)
    }
}

/// The own cable's tension as the observer estimates it: `f_hat` along the unit vector from the
/// load to the UAV, N (the estimate `vt_dissipative::vertical` shares the load with); NaN with
/// the UAV on the load.
fn cable_tension_n(f_hat_n: &Vec3, own_m: &Vec3, load_m: &Vec3) -> f32 {
    let d = own_m - load_m;
    let len = vt_fpu::sqrt(d.norm_squared());
    if len > 0.0 { f_hat_n.dot(&d) / len } else { f32::NAN }
}

/// The ground start before its arming: what the arming reads and what the UAV flies until then.
#[derive(Debug, Clone)]
pub(super) struct Pending {
    /// The parameters the arming reads.
    pub(super) params: Params,
    /// The own horizontal position held until the arming, m.
    pub(super) hold_xy_m: Vector2<f32>,
    /// The altitude law of the nominal cable (take-off, and the slack after a refusal).
    pub(super) vertical: VerticalParams,
    /// The survey of the tension phase's last `settle_s` (the arming calibrates from it).
    pub(super) survey: TakeoffSurvey<MAX_UAVS>,
    /// The wind the take-off and tension hover saw (`vt_dissipative::wind::GustSurvey`).
    pub(super) gusts: GustSurvey,
}

