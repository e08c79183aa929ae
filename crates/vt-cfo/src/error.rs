//! The crate's error type: which parameter a constructor rejected.
use core::fmt;

/// Why a parameter set was rejected (each variant names the bad parameter).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CfoError {
    /// `bandwidth_rad_s` (observer bandwidth `mu`) is NaN, infinite or <= 0.
    InvalidBandwidth,
    /// `mass_kg` is NaN, infinite or <= 0.
    InvalidMass,
    /// `period_s` (control period `h`) is NaN, infinite or <= 0.
    InvalidPeriod,
    /// `bandwidth_rad_s * period_s` exceeds the forward-Euler bound
    /// [`MAX_BANDWIDTH_PERIOD`](crate::MAX_BANDWIDTH_PERIOD).
    BandwidthTooHighForPeriod {
        /// The offending product `mu * h`.
        mu_h: f32,
    },
    /// `thrust_min_n` is NaN, infinite or < 0.
    InvalidThrustMin,
    /// `thrust_max_n` is NaN, infinite or not above `thrust_min_n`.
    InvalidThrustMax,
    /// `tilt_max_rad` is NaN or outside `(0, pi/2)`.
    InvalidTiltMax,
    /// `kp` on `axis` (0 = x/east, 1 = y/north, 2 = z/up) is NaN, infinite or < 0.
    InvalidKp {
        /// Axis index.
        axis: usize,
    },
    /// `ki` on `axis` is NaN, infinite or < 0.
    InvalidKi {
        /// Axis index.
        axis: usize,
    },
    /// `kd` on `axis` is NaN or outside `[0, 1)` (the derivative feeds back the applied thrust).
    InvalidKd {
        /// Axis index.
        axis: usize,
    },
    /// `integral_limit_mps2` on `axis` is NaN, infinite or < 0.
    InvalidIntegralLimit {
        /// Axis index.
        axis: usize,
    },
    /// `actuator_lag_s` is NaN, infinite or < 0.
    InvalidActuatorLag,
    /// The thrust command filter's time constant is NaN, infinite or negative.
    InvalidCommandFilter,
    /// The horizontal reserve is NaN, outside `[0, 1)`, or leaves no vertical range.
    InvalidHorizontalReserve,
    /// The hover thrust `mass_kg * g` lies outside `[thrust_min_n, thrust_max_n]`.
    HoverOutsideThrustLimits {
        /// The hover thrust, N.
        hover_n: f32,
    },
}

impl fmt::Display for CfoError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::InvalidBandwidth => write!(f, "bandwidth_rad_s must be finite and > 0"),
            Self::InvalidMass => write!(f, "mass_kg must be finite and > 0"),
            Self::InvalidPeriod => write!(f, "period_s must be finite and > 0"),
            Self::BandwidthTooHighForPeriod { mu_h } => write!(
                f,
                "bandwidth_rad_s * period_s = {mu_h:.3} exceeds {} (forward-Euler bound)",
                crate::MAX_BANDWIDTH_PERIOD
            ),
            Self::InvalidThrustMin => write!(f, "thrust_min_n must be finite and >= 0"),
            Self::InvalidThrustMax => {
                write!(f, "thrust_max_n must be finite and > thrust_min_n")
            }
            Self::InvalidTiltMax => write!(f, "tilt_max_rad must lie in (0, pi/2)"),
            Self::InvalidHorizontalReserve => {
                write!(f, "horizontal reserve must lie in [0, 1) and leave the vertical cap above thrust_min_n")
            }
            Self::InvalidKp { axis } => write!(f, "kp[{axis}] must be finite and >= 0"),
            Self::InvalidKi { axis } => write!(f, "ki[{axis}] must be finite and >= 0"),
            Self::InvalidKd { axis } => write!(f, "kd[{axis}] must lie in [0, 1)"),
            Self::InvalidIntegralLimit { axis } => {
                write!(f, "integral_limit_mps2[{axis}] must be finite and >= 0")
            }
            Self::InvalidActuatorLag => write!(f, "actuator_lag_s must be finite and >= 0"),
            Self::InvalidCommandFilter => write!(f, "command_filter_s must be finite and >= 0"),
            Self::HoverOutsideThrustLimits { hover_n } => write!(
                f,
                "hover thrust mass_kg * g = {hover_n:.2} N lies outside [thrust_min_n, thrust_max_n]"
            ),
        }
    }
}

impl core::error::Error for CfoError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_names_the_bad_parameter() {
        assert!(CfoError::InvalidMass.to_string().contains("mass_kg"));
        assert!(CfoError::InvalidKd { axis: 2 }
            .to_string()
            .contains("kd[2]"));
        assert!(CfoError::BandwidthTooHighForPeriod { mu_h: 0.8 }
            .to_string()
            .contains("bandwidth_rad_s * period_s"));
        assert!(CfoError::HoverOutsideThrustLimits { hover_n: 60.0 }
            .to_string()
            .contains("thrust_max_n"));
    }

    #[test]
    fn is_a_core_error() {
        fn takes_error(_: &dyn core::error::Error) {}
        takes_error(&CfoError::InvalidTiltMax);
    }
}
