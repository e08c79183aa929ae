//! The planner's error type.
use core::fmt;
use vt_tube::TubeError;

/// Why a tube could not be planned.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PlanError {
    /// A parameter is out of range (the name of the field).
    BadParams {
        /// Name of the offending [`crate::PlanParams`] field or argument.
        field: &'static str,
    },
    /// The caller's work space is smaller than the lattice.
    WorkspaceTooSmall {
        /// Nodes the lattice needs.
        needed: usize,
    },
    /// The start (`which = "start"`) or goal lies outside the map.
    OutsideMap {
        /// `"start"` or `"goal"`.
        which: &'static str,
        /// Easting, m.
        x_m: f32,
        /// Northing, m.
        y_m: f32,
    },
    /// The start or goal lies inside an obstacle (clearance <= 0).
    InsideObstacle {
        /// `"start"` or `"goal"`.
        which: &'static str,
        /// Easting, m.
        x_m: f32,
        /// Northing, m.
        y_m: f32,
    },
    /// No corridor is wide enough: the narrowest passage of the widest route.
    TooNarrow {
        /// Easting of the narrowest passage, m.
        x_m: f32,
        /// Northing of the narrowest passage, m.
        y_m: f32,
        /// Free width there (twice the clearance), m.
        width_m: f32,
        /// Width the team needs (twice the required half-width plus margin), m.
        needed_m: f32,
    },
    /// The corridor needs more discs than [`crate::MAX_DISCS`].
    TooManyDiscs {
        /// The capacity.
        capacity: usize,
    },
    /// The generator curve could not be kept inside the corridor near this point.
    CurveLeavesCorridor {
        /// Easting, m.
        x_m: f32,
        /// Northing, m.
        y_m: f32,
    },
    /// The acceptance gate (`vt_tube::Tube::from_waypoints`) rejected the planned tube.
    Tube(TubeError),
}

impl fmt::Display for PlanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::BadParams { field } => write!(f, "planner parameter `{field}` is out of range"),
            Self::WorkspaceTooSmall { needed } => write!(f, "planner work space too small: the lattice has {needed} nodes"),
            Self::OutsideMap { which, x_m, y_m } => write!(f, "{which} ({x_m:.2}, {y_m:.2}) lies outside the map"),
            Self::InsideObstacle { which, x_m, y_m } => write!(f, "{which} ({x_m:.2}, {y_m:.2}) lies inside an obstacle"),
            Self::TooNarrow { x_m, y_m, width_m, needed_m } => write!(
                f,
                "no corridor is wide enough: the narrowest passage, at ({x_m:.2}, {y_m:.2}), is {width_m:.2} m wide; the team needs {needed_m:.2} m"
            ),
            Self::TooManyDiscs { capacity } => write!(f, "the corridor needs more than {capacity} discs"),
            Self::CurveLeavesCorridor { x_m, y_m } => {
                write!(f, "the generator curve leaves the corridor near ({x_m:.2}, {y_m:.2})")
            }
            Self::Tube(e) => write!(f, "planned tube rejected: {e}"),
        }
    }
}

impl core::error::Error for PlanError {}

impl From<TubeError> for PlanError {
    fn from(e: TubeError) -> Self {
        Self::Tube(e)
    }
}
