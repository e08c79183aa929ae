//! The dissipative controller's gains and limits (REFERENCE §5, §6) and their validation.

use crate::tray::TrayParams;
use crate::vertical::VerticalParams;
use crate::separation::SeparationSpec;
use crate::ControlError;
use vt_tube::BarrierParams;

/// Gains and limits of the dissipative controller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DissipativeParams {
    /// Passing gain `k1`, 1/s.
    pub k1: f32,
    /// Spring gain `k2`, 1/s.
    pub k2: f32,
    /// Tube-barrier gain `k3`, m^2/s.
    pub k3: f32,
    /// Velocity limit `v_m` (eq:2-13, eq:2-21), m/s.
    pub v_max_mps: f32,
    /// Tube barrier safety radius `r_s`, m.
    pub r_safe_m: f32,
    /// Tube barrier activation radius `r_a`, m.
    pub r_active_m: f32,
    /// The separation barrier between UAVs (extension, [`crate::separation`]): its pole (0: off,
    /// the paper's controller), band and distance ([`crate::separation::separation_pole_band`]).
    pub separation: SeparationSpec,
    /// Share of `k2` the springs fly while the load's altitude is being changed (lift, climb,
    /// descent: [`crate::DissipativeController::set_heaving`]), in (0, 1] (1: the paper's springs;
    /// extension, [`crate::springs::heave_spring_share`]).
    pub heave_spring_share: f32,
    /// Gain of the dashpot beside each UAV-UAV spring, on the pair's relative horizontal velocity
    /// along it (extension, [`crate::springs::dashpot_velocity`]), dimensionless; 0: off (the
    /// paper's springs).
    pub dashpot: f32,
    /// Virtual tray geometry.
    pub tray: TrayParams,
    /// Altitude law.
    pub vertical: VerticalParams,
}

impl Default for DissipativeParams {
    /// The paper's simulation gains (REFERENCE §5): `k1 = k2 = k3 = 1`, `v_m = 1.5 m/s`;
    /// barrier radii `r_s = 0.5 m`, `r_a = 1.5 m` (REFERENCE §6).
    fn default() -> Self {
        Self {
            k1: 1.0,
            k2: 1.0,
            k3: 1.0,
            v_max_mps: 1.5,
            r_safe_m: 0.5,
            r_active_m: 1.5,
            separation: SeparationSpec::OFF,
            heave_spring_share: 1.0,
            dashpot: 0.0,
            tray: TrayParams::default(),
            vertical: VerticalParams::default(),
        }
    }
}

impl DissipativeParams {
    /// The paper's outdoor-experiment gains: `k1 = 0.3`, `k2 = 0.1`, `k3 = 1`, `v_m = 1 m/s`.
    pub fn paper_experiment() -> Self {
        Self { k1: 0.3, k2: 0.1, k3: 1.0, v_max_mps: 1.0, ..Self::default() }
    }

    /// Checks every field.
    ///
    /// # Errors
    /// [`ControlError::InvalidParameter`] naming the bad field.
    pub fn validate(&self) -> Result<(), ControlError> {
        validate_gains([self.k1, self.k2, self.k3], self.v_max_mps, self.r_safe_m, self.r_active_m)?;
        if !(self.separation.pole_m.is_finite() && self.separation.pole_m >= 0.0) {
            return Err(ControlError::InvalidParameter("separation.pole_m"));
        }
        if !(self.separation.band_m.is_finite() && self.separation.band_m > 0.0) {
            return Err(ControlError::InvalidParameter("separation.band_m"));
        }
        if !(self.heave_spring_share > 0.0 && self.heave_spring_share <= 1.0) {
            return Err(ControlError::InvalidParameter("heave_spring_share"));
        }
        if !(self.dashpot.is_finite() && self.dashpot >= 0.0) {
            return Err(ControlError::InvalidParameter("dashpot"));
        }
        self.tray.validate()?;
        self.vertical.validate()
    }

    /// The tube barrier eq:2-15-1 these parameters define.
    pub fn tube_barrier(&self) -> BarrierParams {
        BarrierParams::tube(self.k3, self.r_safe_m, self.r_active_m)
    }
}

/// Checks the gains `k1..k3`, the speed limit and the barrier radii shared by both
/// controllers' parameter sets, naming the first bad one.
pub(crate) fn validate_gains(k: [f32; 3], v_max_mps: f32, r_safe_m: f32, r_active_m: f32) -> Result<(), ControlError> {
    let pos = |x: f32| x.is_finite() && x > 0.0;
    let checks: [(bool, &'static str); 6] = [
        (pos(k[0]), "k1"),
        (pos(k[1]), "k2"),
        (pos(k[2]), "k3"),
        (pos(v_max_mps), "v_max_mps"),
        (pos(r_safe_m), "r_safe_m"),
        (r_active_m.is_finite() && r_active_m > r_safe_m, "r_active_m"),
    ];
    match checks.iter().find(|(ok, _)| !ok) {
        Some((_, name)) => Err(ControlError::InvalidParameter(name)),
        None => Ok(()),
    }
}
