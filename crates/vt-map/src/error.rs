//! The map's error type.
use core::fmt;

/// Why a map could not be built or read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MapError {
    /// A parameter is out of range (the name of the field or argument).
    BadParams {
        /// Name of the offending field or argument.
        field: &'static str,
    },
    /// `width * height` exceeds the grid's capacity.
    TooManyCells {
        /// Cells asked for (saturated at `usize::MAX` on overflow).
        needed: usize,
        /// The capacity, `CELLS`.
        capacity: usize,
    },
    /// The caller's output slice is shorter than the grid it must hold.
    OutputTooShort {
        /// Cells needed.
        needed: usize,
        /// Length of the slice given.
        len: usize,
    },
    /// The grid has no cells (made by `OccupancyGrid::empty` and never `reset`).
    EmptyGrid,
    /// A packed grid cannot hold every log-odds value the sensor model reaches.
    TooManyStates {
        /// Values a packed cell holds.
        max: usize,
    },
}

impl fmt::Display for MapError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::BadParams { field } => write!(f, "map parameter `{field}` is out of range"),
            Self::TooManyCells { needed, capacity } => {
                write!(
                    f,
                    "the map needs {needed} cells; its capacity is {capacity}"
                )
            }
            Self::OutputTooShort { needed, len } => {
                write!(
                    f,
                    "output slice too short: {len} cells given, {needed} needed"
                )
            }
            Self::EmptyGrid => write!(f, "the map has no cells (never reset)"),
            Self::TooManyStates { max } => {
                write!(f, "the sensor model reaches more than {max} log-odds values; a packed map holds {max}")
            }
        }
    }
}

impl core::error::Error for MapError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_names_the_field() {
        let s = format!(
            "{}",
            MapError::BadParams {
                field: "resolution_m"
            }
        );
        assert!(s.contains("resolution_m"));
        let s = format!(
            "{}",
            MapError::TooManyCells {
                needed: 12,
                capacity: 10
            }
        );
        assert!(s.contains("12") && s.contains("10"));
    }
}
