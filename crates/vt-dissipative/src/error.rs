//! The controller crate's error type.
use core::fmt;

/// Why controller parameters or a take-off formation were rejected.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ControlError {
    /// A parameter is NaN, infinite, or outside its valid range; names the parameter.
    InvalidParameter(&'static str),
    /// The UAV id is not below the team size.
    IdOutOfRange {
        /// The id given.
        id: usize,
        /// The team size.
        n_uavs: usize,
    },
    /// More UAVs than the fixed capacity.
    TooManyUavs {
        /// The capacity.
        capacity: usize,
    },
    /// A take-off position is non-finite, or a UAV is not above the load.
    BadTakeoff {
        /// Index of the offending UAV.
        index: usize,
    },
}

impl fmt::Display for ControlError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::InvalidParameter(name) => write!(f, "invalid controller parameter `{name}`"),
            Self::IdOutOfRange { id, n_uavs } => write!(f, "UAV id {id} out of range for {n_uavs} UAVs"),
            Self::TooManyUavs { capacity } => write!(f, "more than {capacity} UAVs"),
            Self::BadTakeoff { index } => {
                write!(f, "take-off position of UAV {index} is non-finite or not above the load")
            }
        }
    }
}

impl core::error::Error for ControlError {}
