//! The mission's phases as the world sees them (issue 27 §2; the companions fly them,
//! `vt_dissipative::phases`): the team's phases with their start times and the load's swing,
//! the lift's peak tension and share spread (a ground start), the touchdown speed (a ground
//! start's, or an air start's set-down, issue 29), the refusal.

use crate::summary::PhaseMark;
use nalgebra::Vector3;
use vt_dissipative::Phase;

type V3 = Vector3<f64>;

/// Height above its resting altitude at which the load counts as off the ground, m.
const OFF_GROUND_M: f64 = 0.01;
/// Height above its resting altitude at which the load counts as lifted (the touchdown after
/// it is the set-down), m.
const LIFTED_M: f64 = 0.1;

/// What the phases did, recorded at the plant rate.
#[derive(Debug, Clone)]
pub(crate) struct PhaseRecord {
    /// The load's resting altitude, m.
    rest_z_m: f64,
    /// An air start: no lift, no lift figures.
    air: bool,
    marks: Vec<PhaseMark>,
    /// Bit `code` set: that phase is marked.
    seen: u16,
    /// The lowest phase any UAV flies (0: not reported yet).
    team_phase: u8,
    lift_peak_n: f64,
    spread: Option<f64>,
    lifted: bool,
    touchdown_mps: Option<f64>,
    /// The first refusal a UAV reported: (UAV, refusal code of its heartbeat).
    refusal: Option<(usize, u8)>,
}

impl PhaseRecord {
    /// The load resting at `rest_z_m` on the ground; `air`: an air start (the load up from the
    /// start, the phases only for a set-down).
    pub(crate) fn new(rest_z_m: f64, air: bool) -> Self {
        Self {
            rest_z_m,
            air,
            marks: Vec::new(),
            seen: 0,
            team_phase: 0,
            lift_peak_n: 0.0,
            spread: None,
            lifted: false,
            touchdown_mps: None,
            refusal: None,
        }
    }

    /// The phases (codes, `vt_dissipative::Phase`) and refusal codes each UAV reported at time
    /// `t` (s), with the bodies' positions for the swing (`attached`: cables still attached).
    pub(crate) fn report(&mut self, t: f64, phases: &[u8], refusals: &[u8], uav_pos_m: &[V3], load_pos_m: &V3, attached: &[bool]) {
        if let (None, Some((i, &code))) = (self.refusal, refusals.iter().enumerate().find(|(_, c)| **c != 0)) {
            self.refusal = Some((i, code));
        }
        self.team_phase = phases.iter().copied().filter(|&c| c != 0).min().unwrap_or(0);
        for &code in phases {
            let bit = 1u16.checked_shl(u32::from(code)).unwrap_or(0);
            if self.seen & bit != 0 {
                continue;
            }
            if let Some(p) = Phase::from_code(code) {
                self.seen |= bit;
                let swing_deg = swing_deg(uav_pos_m, load_pos_m, attached);
                self.marks.push(PhaseMark { name: p.name().into(), start_s: t, swing_deg });
            }
        }
    }

    /// The phases marked so far, in order.
    pub(crate) fn marks(&self) -> &[PhaseMark] {
        &self.marks
    }

    /// One plant step: the cable tensions (N), the load's position, and its speed into the
    /// ground if it made contact this step (`Plant::ground_contact`).
    pub(crate) fn step(&mut self, tensions_n: &[f64], load_pos_m: &V3, contact_mps: Option<f64>) {
        let before_transport = self.team_phase != 0 && self.team_phase < Phase::Transport as u8;
        if before_transport {
            self.lift_peak_n = tensions_n.iter().copied().fold(self.lift_peak_n, f64::max);
        }
        let height = load_pos_m.z - self.rest_z_m;
        if self.spread.is_none() && !self.air && self.team_phase >= Phase::Lift as u8 && height > OFF_GROUND_M {
            let (lo, hi, sum) = tensions_n.iter().fold((f64::INFINITY, 0.0f64, 0.0), |(lo, hi, s), &x| (lo.min(x), hi.max(x), s + x));
            let mean = sum / tensions_n.len().max(1) as f64;
            self.spread = Some(if mean > 0.0 { (hi - lo) / mean } else { f64::NAN });
        }
        if height > LIFTED_M {
            self.lifted = true;
        }
        if let (true, None, Some(v)) = (self.lifted, self.touchdown_mps, contact_mps) {
            self.touchdown_mps = Some(v);
        }
    }

    /// The lowest phase any UAV flies.
    pub(crate) fn team_phase(&self) -> Option<Phase> {
        Phase::from_code(self.team_phase)
    }

    /// The first refusal reported: (UAV, code).
    pub(crate) fn refusal(&self) -> Option<(usize, u8)> {
        self.refusal
    }

    /// The phase marks, the lift's peak tension, the share spread and the touchdown speed.
    pub(crate) fn figures(&self) -> (Vec<PhaseMark>, Option<f64>, Option<f64>, Option<f64>) {
        let peak = (self.team_phase != 0 && !self.air).then_some(self.lift_peak_n);
        (self.marks.clone(), peak, self.spread, self.touchdown_mps)
    }
}

/// The load's swing: the angle from the vertical of the line from the attached UAVs' centroid
/// down to the load, deg (NaN with no cable attached).
pub(crate) fn swing_deg(uav_pos_m: &[V3], load_pos_m: &V3, attached: &[bool]) -> f64 {
    let (sum, k) = uav_pos_m.iter().zip(attached).filter(|(_, a)| **a).fold((V3::zeros(), 0usize), |(s, k), (p, _)| (s + p, k + 1));
    if k == 0 {
        return f64::NAN;
    }
    let d = sum / k as f64 - load_pos_m;
    d.x.hypot(d.y).atan2(d.z).to_degrees()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn swing_is_zero_under_the_centroid_and_45_deg_offset() {
        let uavs = [V3::new(1.0, 0.0, 5.0), V3::new(-1.0, 0.0, 5.0)];
        assert!(swing_deg(&uavs, &V3::new(0.0, 0.0, 1.0), &[true, true]).abs() < 1e-12);
        assert!((swing_deg(&uavs, &V3::new(4.0, 0.0, 1.0), &[true, true]) - 45.0).abs() < 1e-9);
        assert!(swing_deg(&uavs, &V3::zeros(), &[false, false]).is_nan());
    }

    #[test]
    fn marks_lift_and_touchdown() {
        let mut g = PhaseRecord::new(0.3, false);
        let uavs = [V3::new(0.0, 0.0, 3.0)];
        let on_ground = V3::new(0.0, 0.0, 0.3);
        g.report(0.0, &[1], &[0], &uavs, &on_ground, &[true]);
        g.step(&[0.0], &on_ground, Some(0.0));
        g.report(5.0, &[3], &[0], &uavs, &on_ground, &[true]);
        g.step(&[12.0, 8.0], &V3::new(0.0, 0.0, 0.32), None);
        g.step(&[30.0, 8.0], &V3::new(0.0, 0.0, 0.5), None);
        // A contact after the lift is the touchdown; later ones do not count.
        g.report(9.0, &[6], &[0], &uavs, &V3::new(0.0, 0.0, 0.5), &[true]);
        g.step(&[5.0, 5.0], &on_ground, Some(0.2));
        g.step(&[0.0, 0.0], &on_ground, Some(0.7));
        let (marks, peak, spread, touch) = g.figures();
        assert_eq!(marks.iter().map(|m| m.name.as_str()).collect::<Vec<_>>(), ["takeoff", "lift", "descent"]);
        assert_eq!(peak, Some(30.0), "the peak counts until the transport");
        assert!((spread.unwrap() - 0.4).abs() < 1e-12);
        assert_eq!(touch, Some(0.2));
        assert_eq!(g.refusal(), None);
    }
}
