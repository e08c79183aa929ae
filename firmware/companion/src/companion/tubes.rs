//! Issue 28: the tube a companion flies when its team re-plans in flight: what it flies now,
//! the switch to a re-planned tube under `perception::accept`, and the no-route hold.

use super::{Companion, Core};
use crate::replanning::Crew;
use crate::{CompanionTube, Param, Vec3};

impl<'t> Companion<'t> {
    /// The tube flown (`None`: none uploaded or accepted yet).
    pub fn tube(&self) -> Option<&CompanionTube> {
        self.core.tube()
    }
}

impl<'t> Crew<'t> for Core<'t> {
    fn tube(&self) -> Option<&CompanionTube> {
        Core::tube(self)
    }
    /// The accept rule for this UAV's and the load's last positions (margin: the flown
    /// `r_safe`; the barrier may rise to its value halfway through the activation band at most);
    /// no own or load position yet counts as outside.
    fn switch_tube(&mut self, candidate: &mut &'t mut CompanionTube) -> Result<(), crate::perception::Keep> {
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
    fn need_half_width_m(&self, load_m: &Vec3) -> f32 {
        let Some(fl) = self.flight.as_ref() else {
            return 0.0;
        };
        fl.shaped_need_half_width_m(self.tube, load_m.xy()).unwrap_or(0.0)
    }
}

impl<'t> Crew<'t> for Companion<'t> {
    fn tube(&self) -> Option<&CompanionTube> {
        self.core.tube()
    }
    fn switch_tube(&mut self, candidate: &mut &'t mut CompanionTube) -> Result<(), crate::perception::Keep> {
        Crew::switch_tube(&mut self.core, candidate)
    }
    fn stop_distance_m(&self) -> f32 {
        Crew::stop_distance_m(&self.core)
    }
    fn set_blocked(&mut self, on: bool) {
        Crew::set_blocked(&mut self.core, on);
    }
    fn r_safe_m(&self) -> f32 {
        Crew::r_safe_m(&self.core)
    }
    fn team_no_route(&self) -> bool {
        Crew::team_no_route(&self.core)
    }
    fn v_max_mps(&self) -> f32 {
        Crew::v_max_mps(&self.core)
    }
    fn need_half_width_m(&self, load_m: &Vec3) -> f32 {
        Crew::need_half_width_m(&self.core, load_m)
    }
}
