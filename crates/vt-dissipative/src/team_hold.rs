//! Team failsafe of a cable-coupled team: the mode each UAV flies and broadcasts, and the
//! hysteresis that makes the team resume together (`docs/design.md`, "Team failsafe").
//!
//! One UAV that stops alone drags its neighbours through the cables, so a hold is a team
//! decision. Each UAV, at every high-level step, feeds [`TeamHoldSupervisor::step`] with
//! - `detected`: its own failsafe tripped (own or load data stale, a neighbour stale when the
//!   team holds on stale neighbours, or the controller flagged its output), and
//! - `followed`: a fresh neighbour broadcasts [`TeamMode::Hold`].
//!
//! It answers the mode to fly and to broadcast. Only [`TeamMode::Hold`] (a UAV's *own*
//! detection) makes the others hold; a UAV that only follows broadcasts
//! [`TeamMode::TeamHold`], which nobody follows. The hold therefore never latches: once every
//! UAV's own data are fresh, nobody broadcasts `Hold`, and everybody resumes after
//! `resume_steps` quiet steps. The flying law of a holding UAV with usable own data is the
//! controller's team hold ([`crate::DissipativeController::set_team_hold`]).

use crate::ControlError;

/// What a UAV flies and broadcasts to its team.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TeamMode {
    /// Flying the transport law.
    #[default]
    Transport,
    /// Its own failsafe tripped: the team must hold (followed by every neighbour).
    Hold,
    /// Holding with the team (following a neighbour's `Hold`, or waiting out the resume
    /// hysteresis); not followed.
    TeamHold,
}

impl TeamMode {
    /// True in `Hold` and `TeamHold`.
    #[inline]
    pub fn is_holding(self) -> bool {
        self != Self::Transport
    }
}

/// The hold / resume state machine of one UAV.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TeamHoldSupervisor {
    resume_steps: u32,
    quiet_steps: u32,
    holding: bool,
}

impl TeamHoldSupervisor {
    /// Supervisor that resumes after `resume_s` seconds without any alarm, stepped every
    /// `dt_s` seconds: `round(resume_s / dt_s)` quiet steps (0: resume at the first quiet step).
    ///
    /// # Errors
    /// [`ControlError::InvalidParameter`] for a negative or non-finite `resume_s`, a
    /// non-positive or non-finite `dt_s`, or more than `u32::MAX` steps.
    pub fn new(resume_s: f32, dt_s: f32) -> Result<Self, ControlError> {
        if !(resume_s.is_finite() && resume_s >= 0.0) {
            return Err(ControlError::InvalidParameter("team_hold.resume_s"));
        }
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(ControlError::InvalidParameter("team_hold.dt_s"));
        }
        // Round to the nearest step: 1 s at 0.02 s is 50 steps although 1/0.02f32 > 50.
        let steps = resume_s / dt_s + 0.5;
        if !(steps < u32::MAX as f32) {
            return Err(ControlError::InvalidParameter("team_hold.resume_s"));
        }
        Ok(Self { resume_steps: steps as u32, quiet_steps: 0, holding: false })
    }

    /// Quiet steps needed to resume.
    pub fn resume_steps(&self) -> u32 {
        self.resume_steps
    }

    /// True while holding (after the last step).
    #[inline]
    pub fn holding(&self) -> bool {
        self.holding
    }

    /// One high-level step: `detected` (own failsafe) and `followed` (a fresh neighbour
    /// broadcasts `Hold`) -> the mode for this step. Any alarm restarts the quiet count; the
    /// hold ends after `resume_steps` consecutive quiet steps.
    pub fn step(&mut self, detected: bool, followed: bool) -> TeamMode {
        if detected || followed {
            self.holding = true;
            self.quiet_steps = 0;
        } else if self.holding {
            self.quiet_steps = self.quiet_steps.saturating_add(1);
            if self.quiet_steps >= self.resume_steps {
                self.holding = false;
                self.quiet_steps = 0;
            }
        }
        match (detected, self.holding) {
            (true, _) => TeamMode::Hold,
            (false, true) => TeamMode::TeamHold,
            (false, false) => TeamMode::Transport,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_parameters_are_refused() {
        assert!(TeamHoldSupervisor::new(-1.0, 0.02).is_err());
        assert!(TeamHoldSupervisor::new(f32::NAN, 0.02).is_err());
        assert!(TeamHoldSupervisor::new(1.0, 0.0).is_err());
        assert!(TeamHoldSupervisor::new(1.0, f32::INFINITY).is_err());
        assert!(TeamHoldSupervisor::new(f32::MAX, 1e-30).is_err());
        assert_eq!(TeamHoldSupervisor::new(1.0, 0.02).unwrap().resume_steps(), 50);
        assert_eq!(TeamHoldSupervisor::new(0.0, 0.02).unwrap().resume_steps(), 0);
    }

    #[test]
    fn own_detection_holds_and_is_broadcast_as_hold() {
        let mut s = TeamHoldSupervisor::new(0.1, 0.02).unwrap();
        assert_eq!(s.step(false, false), TeamMode::Transport);
        assert_eq!(s.step(true, false), TeamMode::Hold);
        assert_eq!(s.step(true, true), TeamMode::Hold, "own detection wins over following");
        // Detection gone: team hold for exactly 5 quiet steps, then transport.
        for k in 0..4 {
            assert_eq!(s.step(false, false), TeamMode::TeamHold, "quiet step {k}");
        }
        assert_eq!(s.step(false, false), TeamMode::Transport);
        assert!(!s.holding());
    }

    #[test]
    fn following_holds_as_team_hold_and_any_alarm_restarts_the_count() {
        let mut s = TeamHoldSupervisor::new(0.06, 0.02).unwrap();
        assert_eq!(s.step(false, true), TeamMode::TeamHold);
        assert_eq!(s.step(false, false), TeamMode::TeamHold);
        assert_eq!(s.step(false, false), TeamMode::TeamHold);
        assert_eq!(s.step(false, true), TeamMode::TeamHold, "alarm again: count restarts");
        assert_eq!(s.step(false, false), TeamMode::TeamHold);
        assert_eq!(s.step(false, false), TeamMode::TeamHold);
        assert_eq!(s.step(false, false), TeamMode::Transport);
    }

    #[test]
    fn two_followers_never_latch() {
        // A and B follow only each other's broadcast: a TeamHold is not followed, so once the
        // cause (C's Hold) is gone both resume on the same step.
        let (mut a, mut b) = (TeamHoldSupervisor::new(0.04, 0.02).unwrap(), TeamHoldSupervisor::new(0.04, 0.02).unwrap());
        let (mut ma, mut mb) = (TeamMode::Transport, TeamMode::Transport);
        for k in 0..20 {
            let c_holds = k < 5;
            let na = a.step(false, c_holds || mb == TeamMode::Hold);
            let nb = b.step(false, c_holds || ma == TeamMode::Hold);
            (ma, mb) = (na, nb);
            if k >= 7 {
                assert_eq!((ma, mb), (TeamMode::Transport, TeamMode::Transport), "step {k}");
            }
        }
    }

    #[test]
    fn zero_resume_time_resumes_at_the_first_quiet_step() {
        let mut s = TeamHoldSupervisor::new(0.0, 0.02).unwrap();
        assert_eq!(s.step(false, true), TeamMode::TeamHold);
        assert_eq!(s.step(false, false), TeamMode::Transport);
    }
}
