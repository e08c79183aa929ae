//! Issue 28: the tube a companion flies when its team re-plans in flight: what it flies now,
//! the switch to a re-planned tube under `perception::accept`, and the no-route hold.

use super::Companion;
use crate::{CompanionTube, Param};

impl<'t> Companion<'t> {
    /// The tube flown (`None`: none uploaded or accepted yet).
    pub fn tube(&self) -> Option<&CompanionTube> {
        self.core.tube()
    }

    /// Issue 28: the team's planner found no route (on) or a route again (off): this UAV
    /// holds in place with [`crate::HoldReasons::NO_ROUTE`]. False when no mission runs.
    pub fn set_no_route(&mut self, on: bool) -> bool {
        self.core.flight.as_mut().map(|fl| fl.set_no_route(on)).is_some()
    }

    /// Issue 28: the team holds for want of a route ([`Companion::set_no_route`]). False when
    /// no mission runs.
    pub fn team_no_route(&self) -> bool {
        self.core.flight.as_ref().is_some_and(crate::Flight::team_no_route)
    }

    /// Issue 28: how far ahead of this UAV an obstacle in its tube makes it stop, m
    /// ([`crate::perception::stop_distance_m`] of `VT_BODY_R` and `VT_V_MAX`).
    pub fn stop_distance_m(&self) -> f32 {
        let p = &self.core.params;
        crate::perception::stop_distance_m(p.get(crate::params::Param::BodyR), p.get(crate::params::Param::VMax))
    }

    /// Issue 28: this UAV's own tube is blocked close ahead and it has no tube it may take
    /// (`perception::Perception::must_stop`): it holds in place with
    /// [`crate::HoldReasons::NO_ROUTE`] while on. False when no mission runs.
    pub fn set_blocked(&mut self, on: bool) -> bool {
        self.core.flight.as_mut().map(|fl| fl.set_blocked(on)).is_some()
    }

    /// Issue 28: switches to the tube the caller built in `candidate` when
    /// [`crate::perception::accept`] allows it for this UAV's and the load's last positions
    /// (margin: the flown `r_safe`; the barrier may rise to its value halfway through the
    /// activation band at most). On success `candidate` holds the old tube's storage.
    ///
    /// # Errors
    /// Why the old tube is kept (no own or load position yet counts as outside).
    pub fn switch_tube(&mut self, candidate: &mut &'t mut CompanionTube) -> Result<(), crate::perception::Keep> {
        use crate::perception::{accept_joining, Keep};
        let core = &mut self.core;
        let own = core.sources.own.map(|s| s.value.pos_m).ok_or(Keep::OwnOutside)?;
        let load = core.sources.load.map(|s| s.value.pos_m).ok_or(Keep::LoadOutside)?;
        let r_safe = core.params.r_safe_m();
        let band_mid = 0.5 * (r_safe + core.params.get(Param::RActive));
        let verdict = accept_joining(candidate, core.tube_ok.then_some(&*core.tube), &own, &load, r_safe, band_mid);
        // A UAV outside the new tube joins it widened when its controller can (the dissipative
        // one); otherwise it keeps its old tube.
        let joined = match verdict {
            Ok(false) => false,
            Ok(true) if core.flight.as_mut().is_some_and(|fl| fl.tube_joined()) => true,
            other => {
                if let Some(fl) = core.flight.as_mut() {
                    fl.tube_declined();
                }
                return Err(other.err().unwrap_or(Keep::OwnOutside));
            }
        };
        core::mem::swap(&mut core.tube, candidate);
        core.tube_ok = true;
        if !joined {
            if let Some(fl) = core.flight.as_mut() {
                fl.tube_switched();
            }
        }
        Ok(())
    }
}
