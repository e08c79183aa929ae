//! The tube crate's error type.
use core::fmt;

/// Why a tube (or its input) was rejected.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TubeError {
    /// Fewer than two waypoints.
    TooFewWaypoints,
    /// More waypoints than the fixed capacity `W`.
    TooManyWaypoints {
        /// The capacity.
        capacity: usize,
    },
    /// A waypoint coordinate or width is NaN or infinite.
    NonFinite {
        /// Index of the offending waypoint.
        index: usize,
    },
    /// Two consecutive waypoints coincide (zero-length chord).
    CoincidentWaypoints {
        /// Index of the second of the two.
        index: usize,
    },
    /// A half-width is zero or negative.
    NonPositiveWidth {
        /// Index of the offending waypoint.
        index: usize,
    },
    /// The offset curves fold: `max(w_L, w_R) * |kappa| >= 1` at arc length `s_m`.
    Folding {
        /// Arc length where the condition is violated, m.
        s_m: f32,
        /// `max(w_L, w_R) * |kappa|` there (must be < 1).
        ratio: f32,
    },
    /// The start and end cross-sections intersect.
    OverlappingTerminals,
    /// A cross-section point at arc length `s_m` is closer to another part of the curve:
    /// the tube overlaps itself and `s(q)` would be ambiguous.
    SelfOverlap {
        /// Arc length of the section that overlaps, m.
        s_m: f32,
    },
}

impl fmt::Display for TubeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::TooFewWaypoints => write!(f, "a tube needs at least two waypoints"),
            Self::TooManyWaypoints { capacity } => {
                write!(f, "too many waypoints (capacity {capacity})")
            }
            Self::NonFinite { index } => write!(f, "waypoint {index} has a non-finite value"),
            Self::CoincidentWaypoints { index } => {
                write!(f, "waypoint {index} coincides with waypoint {}", index.saturating_sub(1))
            }
            Self::NonPositiveWidth { index } => {
                write!(f, "waypoint {index} has a half-width <= 0")
            }
            Self::Folding { s_m, ratio } => write!(
                f,
                "tube boundary folds at s = {s_m:.2} m (max half-width x |curvature| = {ratio:.3}, must be < 1)"
            ),
            Self::OverlappingTerminals => write!(f, "the start and end cross-sections intersect"),
            Self::SelfOverlap { s_m } => {
                write!(f, "the tube overlaps itself at s = {s_m:.2} m")
            }
        }
    }
}

impl core::error::Error for TubeError {}
