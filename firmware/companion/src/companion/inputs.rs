//! What the companion receives outside the configuration: position reports (own autopilot,
//! load tracker, team members), the own autopilot's clock (`SYSTEM_TIME`, which in lockstep
//! opens and closes the low-level periods) and the team members' modes (`HEARTBEAT`). The frame
//! handlers map ids; the typed entry points below them are what SIL calls directly.

use mavlink::dialects::common::{HEARTBEAT_DATA, LOCAL_POSITION_NED_DATA, SYSTEM_TIME_DATA};

use super::{Core, Io, Mode, Source, POSITION_LIMIT_M, VELOCITY_LIMIT_MPS};
use crate::flight::{Flight, Stamped, State};
use crate::framer::Frame;
use crate::frames::enu_from_ned;
use crate::params::Param;
use crate::{Vec3, AUTOPILOT_COMPONENT_ID, COMPANION_COMPONENT_ID};

impl Core<'_> {
    /// `LOCAL_POSITION_NED`: its sender by the frame's ids, then [`Self::position`].
    pub(super) fn on_local_position(&mut self, f: &Frame<'_>, d: &LOCAL_POSITION_NED_DATA, io: &mut impl Io) {
        let own_sys = self.own_system_id();
        let from = if f.system_id == own_sys && f.component_id == AUTOPILOT_COMPONENT_ID {
            Source::Own
        } else if f.system_id == own_sys && u32::from(f.component_id) == self.params.get_u32(Param::LoadComp) {
            Source::Load
        } else if f.component_id == AUTOPILOT_COMPONENT_ID {
            Source::Member(u32::from(f.system_id).wrapping_sub(self.params.get_u32(Param::SysidBase)) as usize)
        } else {
            return self.ignored();
        };
        self.position(from, enu_from_ned(d.x, d.y, d.z), enu_from_ned(d.vx, d.vy, d.vz), d.time_boot_ms, io);
    }

    pub(super) fn position(&mut self, from: Source, pos: Vec3, vel: Vec3, time_boot_ms: u32, io: &mut impl Io) {
        if !(within(&pos, POSITION_LIMIT_M) && within(&vel, VELOCITY_LIMIT_MPS)) {
            return self.bad_value();
        }
        let lockstep = self.params.get_u32(Param::Lockstep) == 1;
        // Receipt stamp (freshness): lockstep, the host's simulated time (the SYSTEM_TIME that
        // opened this period, else the message's own time); else the board's clock at receipt.
        let stamp_ms = match (lockstep, self.lockstep_now_ms) {
            (true, Some(now)) => now,
            (true, None) => time_boot_ms,
            (false, _) => io.now_ms(),
        };
        // Sample time on the companion's clock (delay compensation, vt_cfo::prediction): the
        // autopilot's `time_boot_ms` shifted by the SYSTEM_TIME offset; unknown offset: receipt.
        let offset = if lockstep { Some(0) } else { self.autopilot_offset_ms };
        // Made where it is stored: a member's position (most reports) keeps no state.
        let state = || {
            let sample_ms = offset.map_or(stamp_ms, |o| time_boot_ms.wrapping_add(o));
            Stamped { value: State { pos_m: pos, vel_mps: vel, sample_ms }, stamp_ms }
        };
        // Before the mission: the take-off survey averages every position (docs/design.md,
        // "Take-off survey"); a new `VT_CAL_N` restarts it.
        let surveying = self.flight.is_none();
        if surveying {
            let window = self.params.get_u32(Param::CalN);
            if self.sources.survey.window() != window {
                self.sources.survey.reset(window);
            }
        }
        match from {
            Source::Own => {
                // The own state closes the period.
                self.lockstep_now_ms = None;
                if lockstep && self.flight.is_some() {
                    self.clock_ms = stamp_ms;
                    self.lockstep_tick(state(), io);
                } else {
                    self.sources.own = Some(state());
                    if surveying {
                        self.sources.survey.push_own(&pos);
                    }
                    if lockstep {
                        self.clock_ms = stamp_ms;
                        // Before the mission: the team's first tube is planned and taken.
                        #[cfg(feature = "perception")]
                        self.preflight_period(&pos, io);
                    }
                }
            }
            Source::Load => {
                #[cfg(feature = "perception")]
                self.note_team_data();
                self.sources.load = Some(state());
                if surveying {
                    self.sources.survey.push_load(&pos);
                }
            }
            Source::Member(j) => {
                let n = self.params.get_u32(Param::NUavs) as usize;
                match self.sources.neighbours.get_mut(j) {
                    Some(slot) if j < n => {
                        *slot = Some(Stamped { value: pos, stamp_ms });
                        if let Some(v) = self.sources.neighbour_vel_mps.get_mut(j) {
                            *v = vel.xy();
                        }
                        #[cfg(feature = "perception")]
                        self.note_team_data();
                        if surveying {
                            self.sources.survey.push_member(j, &pos);
                        }
                    }
                    _ => self.ignored(),
                }
            }
        }
    }

    /// A team member's companion announces its mode (`custom_mode` low byte) and its phase
    /// (bits 24..31): remember whether it holds and whether it was released (docs/protocol.md,
    /// "Team failsafe"). Other heartbeats are ignored silently.
    pub(super) fn on_heartbeat(&mut self, f: &Frame<'_>, d: &HEARTBEAT_DATA) {
        if f.component_id != COMPANION_COMPONENT_ID || f.system_id == self.own_system_id() {
            return;
        }
        let j = u32::from(f.system_id).wrapping_sub(self.params.get_u32(Param::SysidBase)) as usize;
        self.member_heartbeat(j, d.custom_mode);
    }

    pub(super) fn member_heartbeat(&mut self, j: usize, custom_mode: u32) {
        let n = self.params.get_u32(Param::NUavs) as usize;
        if j < n && j != self.params.get_u32(Param::Id) as usize {
            self.sources.neighbour_hold.set(j, custom_mode & 0xFF == Mode::Hold as u32);
            self.sources.neighbour_released.set(j, custom_mode >> 24 == vt_dissipative::Phase::Released as u32);
        }
    }

    /// `SYSTEM_TIME` from the own autopilot. Lockstep: it opens a period at the simulated time
    /// `time_boot_ms` (the period's measurements may be older: sensor latency) and the own state
    /// closes it; a second `SYSTEM_TIME` at the same time closes it without an own state (the
    /// own feed is silent this period: one low-level period with the data held, which age and
    /// go stale after `FS_OWN_TMO`). Else the offset between the board's clock and the
    /// autopilot's `time_boot_ms` (the message's own transport delay is taken as negligible;
    /// docs/protocol.md).
    pub(super) fn on_system_time(&mut self, f: &Frame<'_>, d: &SYSTEM_TIME_DATA, io: &mut impl Io) {
        if !(f.system_id == self.own_system_id() && f.component_id == AUTOPILOT_COMPONENT_ID) {
            return self.ignored();
        }
        self.system_time(d.time_boot_ms, io);
    }

    pub(super) fn system_time(&mut self, time_boot_ms: u32, io: &mut impl Io) {
        if self.params.get_u32(Param::Lockstep) != 1 {
            self.autopilot_offset_ms = Some(io.now_ms().wrapping_sub(time_boot_ms));
        } else if self.lockstep_now_ms != Some(time_boot_ms) {
            self.lockstep_now_ms = Some(time_boot_ms);
        } else {
            self.lockstep_now_ms = None;
            self.clock_ms = time_boot_ms;
            if self.flight.is_some() {
                if self.flight.as_ref().is_some_and(Flight::high_level_due) {
                    #[cfg(feature = "perception")]
                    if let Some(own) = self.sources.own {
                        self.perception_step(&own.value.pos_m, io);
                    }
                    self.high_level(io);
                }
                self.low_level(io);
            }
        }
    }

    /// Lockstep: the own state `own` closes one low-level period. The high level runs first
    /// when due, with the data held before this message (the last sample, as host-sim's
    /// controllers read their latest sensor snapshot); then `own` is taken and the low level
    /// runs with its velocity.
    pub(super) fn lockstep_tick(&mut self, own: Stamped<State>, io: &mut impl Io) {
        if self.flight.as_ref().is_some_and(Flight::high_level_due) {
            // Issue 28: the perception step sees this period's own position (its stop and the
            // team it must hold), the high level the one it was sampled with.
            #[cfg(feature = "perception")]
            self.perception_step(&own.value.pos_m, io);
            self.high_level(io);
        }
        self.sources.own = Some(own);
        self.low_level(io);
    }
}

/// True when every component of `v` is finite and within `+-lim` (`lim` finite and >= 0, in
/// `v`'s unit): `|c| <= lim` for each `c`, false for an infinity or a NaN (a NaN compares
/// false), so no separate finiteness test. Evaluated without short circuit: three compares
/// the compiler can take together.
#[inline]
fn within(v: &Vec3, lim: f32) -> bool {
    (v.x.abs() <= lim) & (v.y.abs() <= lim) & (v.z.abs() <= lim)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `within` is the first-written test, `finite3(v) && v.iter().all(|c| c.abs() <= lim)`,
    /// for every special value.
    #[test]
    fn within_is_the_finite_and_bounded_test() {
        let lim = POSITION_LIMIT_M;
        let vals = [f32::NEG_INFINITY, -f32::MAX, -1.0e5, -99_999.99, -0.0, 0.0, f32::MIN_POSITIVE / 4.0, 1.0e5, 100_000.01, f32::MAX, f32::INFINITY, f32::NAN, -f32::NAN];
        for x in vals {
            for y in vals {
                for z in [0.5, f32::NAN, -1.0e6] {
                    let v = Vec3::new(x, y, z);
                    let literal = v.iter().all(|c| c.is_finite()) && v.iter().all(|c| c.abs() <= lim);
                    assert_eq!(within(&v, lim), literal, "{v:?}");
                }
            }
        }
    }
}
