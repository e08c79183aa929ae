//! Issue 28: the tube a companion flies when its team re-plans in flight: what it flies now,
//! the switch to a re-planned tube under `perception::accept`, and the no-route hold.

use super::{Companion, Core};
use crate::replanning::Crew;
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
        self.core.stop_distance_m()
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
        self.core.switch_tube(candidate)
    }
}

impl<'t> Core<'t> {
    /// [`Companion::switch_tube`].
    pub(super) fn switch_tube(&mut self, candidate: &mut &'t mut CompanionTube) -> Result<(), crate::perception::Keep> {
        use crate::perception::{accept_joining, Keep};
        let own = self.sources.own.map(|s| s.value.pos_m).ok_or(Keep::OwnOutside)?;
        let load = self.sources.load.map(|s| s.value.pos_m).ok_or(Keep::LoadOutside)?;
        let r_safe = self.params.r_safe_m();
        let band_mid = 0.5 * (r_safe + self.params.get(Param::RActive));
        let verdict = accept_joining(candidate, self.tube_ok.then_some(&*self.tube), &own, &load, r_safe, band_mid);
        // A UAV outside the new tube joins it widened when its controller can (the dissipative
        // one); otherwise it keeps its old tube.
        let joined = match verdict {
            Ok(false) => false,
            Ok(true) if self.flight.as_mut().is_some_and(|fl| fl.tube_joined()) => true,
            other => {
                if let Some(fl) = self.flight.as_mut() {
                    fl.tube_declined();
                }
                return Err(other.err().unwrap_or(Keep::OwnOutside));
            }
        };
        core::mem::swap(&mut self.tube, candidate);
        self.tube_ok = true;
        if !joined {
            if let Some(fl) = self.flight.as_mut() {
                fl.tube_switched();
            }
        }
        Ok(())
    }

    fn stop_distance_m(&self) -> f32 {
        crate::perception::stop_distance_m(self.params.get(Param::BodyR), self.params.get(Param::VMax))
    }
}

impl<'t> Crew<'t> for Core<'t> {
    fn tube(&self) -> Option<&CompanionTube> {
        Core::tube(self)
    }
    fn switch_tube(&mut self, candidate: &mut &'t mut CompanionTube) -> Result<(), crate::perception::Keep> {
        Core::switch_tube(self, candidate)
    }
    fn stop_distance_m(&self) -> f32 {
        Core::stop_distance_m(self)
    }
    fn set_blocked(&mut self, on: bool) {
        if let Some(fl) = self.flight.as_mut() {
            fl.set_blocked(on);
        }
    }
    fn r_safe_m(&self) -> f32 {
        self.params.r_safe_m()
    }
    fn team_no_route(&self) -> bool {
        self.flight.as_ref().is_some_and(crate::Flight::team_no_route)
    }
    fn v_max_mps(&self) -> f32 {
        self.params.get(Param::VMax)
    }
}

impl<'t> Crew<'t> for Companion<'t> {
    fn tube(&self) -> Option<&CompanionTube> {
        self.core.tube()
    }
    fn switch_tube(&mut self, candidate: &mut &'t mut CompanionTube) -> Result<(), crate::perception::Keep> {
        self.core.switch_tube(candidate)
    }
    fn stop_distance_m(&self) -> f32 {
        self.core.stop_distance_m()
    }
    fn set_blocked(&mut self, on: bool) {
        Crew::set_blocked(&mut self.core, on);
    }
    fn r_safe_m(&self) -> f32 {
        self.core.params.r_safe_m()
    }
    fn team_no_route(&self) -> bool {
        Crew::team_no_route(&self.core)
    }
    fn v_max_mps(&self) -> f32 {
        self.core.params.get(Param::VMax)
    }
}
