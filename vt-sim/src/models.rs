//! The plant models a scenario can choose (docs/plant.md): the UAV model (`rigid_body`, the
//! default, or the paper's `point_mass`) and the cable model (`elastic`, the default, or the
//! paper's `paper_clamp`), with the integrator-stability check of the cable.

use serde::{Deserialize, Serialize};

/// UAV model of the plant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum), value(rename_all = "snake_case"))]
#[serde(rename_all = "snake_case")]
pub enum UavModel {
    /// 6-DOF quadrotor behind a PX4-style attitude/rate autopilot (docs/plant.md).
    #[default]
    RigidBody,
    /// The paper's point mass whose world-frame thrust vector follows the command through a
    /// first-order lag (REFERENCE §1).
    PointMass,
}

impl UavModel {
    /// Name in scenarios and reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::RigidBody => "rigid_body",
            Self::PointMass => "point_mass",
        }
    }
}

/// Cable model of the plant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum), value(rename_all = "snake_case"))]
#[serde(rename_all = "snake_case")]
pub enum CableModel {
    /// Tension-only spring-damper with no cap: tension above `rated_n` is reported, above
    /// `breaking_n` the cable snaps.
    #[default]
    Elastic,
    /// The paper's cable: tension clamped at the capacity `f_max` (= `rated_n`); it never breaks.
    PaperClamp,
}

impl CableModel {
    /// Name in scenarios and reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Elastic => "elastic",
            Self::PaperClamp => "paper_clamp",
        }
    }
}

/// CFO bandwidth flown on the `rigid_body` plant unless `[velocity_loop.rigid_body]` says
/// otherwise, rad/s: the paper's 15 rad/s (docs/design.md, "Velocity loop behind an attitude
/// autopilot"; 8 rad/s before the latency compensation).
pub const RIGID_BODY_CFO_BANDWIDTH_RAD_S: f64 = 15.0;
/// Thrust-response lag the CFO models on the `rigid_body` plant unless
/// `[velocity_loop.rigid_body]` says otherwise, s (same source).
pub const RIGID_BODY_ACTUATOR_LAG_S: f64 = 0.05;
/// Time constant of the thrust command filter on the `rigid_body` plant unless
/// `[velocity_loop.rigid_body]` says otherwise, s (docs/design.md, "Thrust command filter":
/// with the take-off survey every campaign flies as well or better with it, and 3x velocity
/// noise only with it; the point mass keeps none).
pub const RIGID_BODY_COMMAND_FILTER_S: f64 = 0.02;


/// Default breaking strength over rated capacity of the elastic cable: a deliberately modest
/// design factor (lifting slings are rated at 5:1 to 7:1 of their breaking strength), so that
/// "no cable breaks" checks the peak dynamic tension of a mission, not only the static margin.
pub const DEFAULT_BREAKING_FACTOR: f64 = 3.0;

/// Largest `omega h` the plant's semi-implicit Euler integrator is allowed for a cable mode
/// (`omega = sqrt(k / mu)`, `mu` the reduced mass of the UAV-load pair, `h` the sub-step).
/// Symplectic Euler is stable up to `omega h < 2`; at 0.2 one period takes over 30 sub-steps and
/// the energy and phase errors stay at the percent level (Hairer, Lubich & Wanner, *Geometric
/// Numerical Integration*, 2006, §I.1).
pub const MAX_OMEGA_H: f64 = 0.2;

/// Largest `(b / mu) h` for the cable damper (explicit damping is stable below 2; the same
/// accuracy margin as [`MAX_OMEGA_H`]).
pub const MAX_DAMPING_H: f64 = 0.2;

/// Why the integrator cannot hold a cable stable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StiffnessError {
    /// `sqrt(k / mu) h` is too large.
    Stiffness {
        /// The value of `sqrt(k / mu) h`.
        omega_h: f64,
    },
    /// `(b / mu) h` is too large.
    Damping {
        /// The value of `(b / mu) h`.
        damping_h: f64,
    },
}

/// Checks that the plant's sub-step `h_s` (s) resolves a cable of stiffness `k` (N/m) and
/// damping `b` (N s/m) between a UAV of mass `m_uav_kg` and a load of mass `m_load_kg`.
///
/// # Errors
/// [`StiffnessError`] with the offending product.
pub fn check_cable_integration(k: f64, b: f64, m_uav_kg: f64, m_load_kg: f64, h_s: f64) -> Result<(), StiffnessError> {
    let mu = m_uav_kg * m_load_kg / (m_uav_kg + m_load_kg);
    let omega_h = (k / mu).sqrt() * h_s;
    if omega_h.is_nan() || omega_h > MAX_OMEGA_H {
        return Err(StiffnessError::Stiffness { omega_h });
    }
    let damping_h = b / mu * h_s;
    if damping_h.is_nan() || damping_h > MAX_DAMPING_H {
        return Err(StiffnessError::Damping { damping_h });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_cables_pass_and_a_steel_wire_at_one_khz_fails() {
        // Paper: k = 500 N/m, b = 30 N s/m, 2 kg UAV, 18 kg load, 1 kHz x 2 sub-steps.
        assert!(check_cable_integration(500.0, 30.0, 2.0, 18.0, 0.5e-3).is_ok());
        // An 8 m steel wire (EA ~ 1e6 N): k ~ 1.25e5 N/m -> omega h ~ 0.13 at 2 kHz... ok;
        // at 1 kHz without sub-steps and k = 1e6 N/m it is not.
        assert!(matches!(check_cable_integration(1e6, 30.0, 2.0, 18.0, 1e-3), Err(StiffnessError::Stiffness { .. })));
        assert!(matches!(check_cable_integration(500.0, 5000.0, 2.0, 18.0, 1e-3), Err(StiffnessError::Damping { .. })));
        // NaN never passes.
        assert!(check_cable_integration(f64::NAN, 30.0, 2.0, 18.0, 1e-3).is_err());
    }
}
